"""The stamp rule at a node's edge, with what every node needs around it (rclpy glue).

:class:`EdgeGate` composes the :class:`~irs_common.stamp_gate.StampGate` of a node's steps with
the node-side glue every node repeated: the count of dropped messages, the throttled warning
that names the input and the verdict, the time reset (a stamp more than 1 s back, or the node
clock jumping back: :func:`~irs_common.time_jump.on_time_jump_back`) that calls the node's own
``reset`` and counts it. :class:`StaleTimer` is the timer that checks an input's age every half
``stale_timeout`` and is re-created when the timeout changes.

The per-step path (:meth:`EdgeGate.take_step`, :meth:`EdgeGate.admit`) allocates nothing on
``OK``: the callbacks handed to the gate are bound once here, and a warning's text is built
only when one is logged.
"""
import time

from .input_checks import ThrottledWarner
from .stamp_gate import StampGate
from .time_jump import on_time_jump_back

__all__ = ['EdgeGate', 'StaleTimer']


class EdgeGate:
    """One node's stamp gate and its glue (module docstring).

    ``node`` (rclpy Node) gives the clock-jump callback; ``future_tolerance`` [s];
    ``step_name`` names the stepping input in log lines (``'encoders'``); ``reset()`` is the
    node's time-state reset (stamps, histories, controller state), called on a time reset and
    after :meth:`clear_time`; ``warner`` the node's :class:`ThrottledWarner` (one is made on
    the node's logger if None).
    """

    __slots__ = ('gate', 'warner', 'dropped', 'time_resets', 'step_name', '_reset',
                 '_drop_step', '_time_reset', 'jump_handle')

    def __init__(self, node, future_tolerance: float, step_name: str, reset,
                 warner: ThrottledWarner | None = None):
        self.gate = StampGate(int(round(future_tolerance * 1e9)))
        self.warner = warner or ThrottledWarner(node.get_logger().warning, 1.0)
        self.dropped = 0          # messages dropped for their stamps (future, out of order)
        self.time_resets = 0
        self.step_name = step_name
        self._reset = reset
        # bound once: StampGate.take_step is called on every step
        self._drop_step = self._on_drop_step
        self._time_reset = self._on_time_reset
        self.jump_handle = on_time_jump_back(node, lambda _delta: self.clear_time())

    @property
    def future_tolerance_ns(self) -> int:
        return self.gate.future_tolerance_ns

    @property
    def last_ns(self):
        return self.gate.last_ns

    def take_step(self, stamp_ns: int, now_ns, answer) -> bool:
        """:meth:`StampGate.take_step` with this node's drop and time-reset glue."""
        return self.gate.take_step(stamp_ns, now_ns, answer, self._drop_step, self._time_reset)

    def admit(self, what: str, stamp_ns: int, now_ns, pairing: bool = True) -> bool:
        """Whether input ``what`` stamped ``stamp_ns`` may join the pairing
        (:meth:`StampGate.admit`); a refused one is dropped, counted and reported.
        """
        verdict = self.gate.admit(stamp_ns, now_ns, pairing)
        if verdict is None:
            return True
        self.drop(what, verdict, stamp_ns, now_ns)
        return False

    def drop(self, what: str, verdict: str, stamp_ns: int, now_ns, gate=None) -> None:
        """Count a message of input ``what`` dropped for its stamp and warn (throttled);
        ``gate`` is the :class:`StampGate` that judged it (default: this one's).
        """
        self.dropped += 1
        gate = gate or self.gate
        self.warner.warn(f'{what}-{verdict}', f'{what}: {gate.reason(verdict, stamp_ns, now_ns)}',
                         time.monotonic())

    def clear_time(self) -> None:
        """Time went back (the clock, or a stamp more than 1 s back): forget the last stamp and
        call the node's ``reset``.
        """
        self.time_resets += 1
        self.gate.clear()
        self._reset()

    def _on_drop_step(self, verdict, stamp_ns, now_ns):
        self.drop(self.step_name, verdict, stamp_ns, now_ns)

    def _on_time_reset(self, verdict, stamp_ns, now_ns):
        self.warner.warn('reset', f'{self.step_name} '
                         f'{self.gate.reason(verdict, stamp_ns, now_ns)}', time.monotonic())
        self.clear_time()


class StaleTimer:
    """A node timer calling ``check()`` every ``timeout / 2`` s (at least every 1 ms);
    :meth:`set_timeout` re-creates it for a new ``stale_timeout`` [s].
    """

    __slots__ = ('node', 'check', 'timer')

    def __init__(self, node, timeout: float, check):
        self.node = node
        self.check = check
        self.timer = node.create_timer(max(timeout / 2.0, 0.001), check)

    def set_timeout(self, timeout: float) -> None:
        self.node.destroy_timer(self.timer)
        self.timer = self.node.create_timer(max(timeout / 2.0, 0.001), self.check)
