"""Exact-time pairing of inputs by their header stamps (no rclpy).

In lock-step runs every message of step k carries the stamp t_k. A node that needs several inputs
of the same step (a controller: measurement and reference; the rig: steering and drive commands)
must not act on whichever arrived first, or the run depends on DDS delivery order. ``StampSync``
buffers each input by its stamp (integer nanoseconds) and hands out a complete set only once every
input of that stamp is there, in stamp order -- the exact-time policy of ROS message_filters.
"""
from dataclasses import dataclass, field


@dataclass
class StampSync:
    """Collect one value per input name per stamp; release complete sets in stamp order.

    Parameters
    ----------
    inputs : sequence of str
        Names of the inputs that make a set complete.
    max_pending : int
        Stamps kept waiting at most; older incomplete sets are dropped and counted in ``dropped``.

    An input lost on the way, or a message published alone (``ros2 topic pub`` of one input),
    leaves a set that never completes: :meth:`expire` takes such sets out, for the node to say
    what was missing.
    """

    inputs: tuple
    max_pending: int = 10000
    dropped: int = 0
    expired: int = 0
    _pending: dict = field(default_factory=dict)
    _marked: set = field(default_factory=set)

    def __post_init__(self):
        self.inputs = tuple(self.inputs)
        if not self.inputs:
            raise ValueError('StampSync needs at least one input name')

    def add(self, name: str, stamp_ns: int, value) -> list:
        """Store ``value`` of input ``name`` at ``stamp_ns``; return newly complete sets.

        Returns a list of ``(stamp_ns, {name: value})`` in increasing stamp order. A set is
        released once all inputs of its stamp are present; incomplete older sets stay pending
        (lock-step peers may be slower on one input than on another).
        """
        if name not in self.inputs:
            raise KeyError(f"unknown input '{name}', expected one of {self.inputs}")
        stamp_ns = int(stamp_ns)
        vals = self._pending.setdefault(stamp_ns, {})
        vals[name] = value
        # A complete set leaves at once, so the set just added to is the only one that can be
        # complete: O(1) per message however many incomplete sets wait (inputs lost on the way).
        if len(vals) == len(self.inputs):
            del self._pending[stamp_ns]
            return [(stamp_ns, vals)]
        while len(self._pending) > self.max_pending:
            self._pending.pop(min(self._pending))
            self.dropped += 1
        return []

    def expire(self) -> list:
        """Remove the incomplete sets that were already waiting at the previous call; return
        ``(stamp_ns, missing)`` of each, oldest first, ``missing`` the names of the inputs that
        never came for that stamp. Counted in ``expired``. Called every T s, it drops the sets
        that waited between T and 2 T, whatever time base their stamps are in.
        """
        old = sorted(s for s in self._marked if s in self._pending)
        gone = []
        for s in old:
            vals = self._pending.pop(s)
            gone.append((s, tuple(n for n in self.inputs if n not in vals)))
        self.expired += len(gone)
        self._marked = set(self._pending)
        return gone
