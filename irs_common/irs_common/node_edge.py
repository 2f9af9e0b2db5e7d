"""The stamp rule at a node's edge, with what every node needs around it (rclpy glue).

:class:`EdgeGate` composes the :class:`~irs_common.stamp_gate.StampGate` of a node's steps with
the node-side glue every node repeated: the count of dropped messages, the throttled warning
that names the input and the verdict, the time reset (a stamp more than 1 s back, or the node
clock jumping back: :func:`~irs_common.time_jump.on_time_jump_back`) that calls the node's own
``reset`` and counts it. :class:`StaleTimer` is the timer that checks an input's age every half
``stale_timeout``, is re-created when the timeout changes, and does not judge an input while
its own node has just been starved.

The per-step path (:meth:`EdgeGate.take_step`, :meth:`EdgeGate.admit`) allocates nothing on
``OK``: the callbacks handed to the gate are bound once here, and a warning's text is built
only when one is logged.
"""
import time

from .input_checks import ThrottledWarner
from .stamp_gate import StampGate
from .stamps import from_ns
from .start_gate import StartGate
from .time_jump import on_time_jump_back

__all__ = ['EdgeGate', 'StaleTimer', 'UNPAIRED_AFTER']

#: [s] of wall time an incomplete set of paired inputs waits before it is dropped and reported
#: (:meth:`EdgeGate.expire_unpaired`): far beyond a lock-step step or a real-time delivery.
UNPAIRED_AFTER = 1.0


class EdgeGate:
    """One node's stamp gate and its glue (module docstring).

    ``node`` (rclpy Node) gives the clock-jump callback; ``future_tolerance`` [s];
    ``step_name`` names the stepping input in log lines (``'encoders'``); ``reset()`` is the
    node's time-state reset (stamps, histories, controller state), called on a time reset and
    after :meth:`clear_time`; ``warner`` the node's :class:`ThrottledWarner` (one is made on
    the node's logger if None).

    A node clock at 0 is a node on simulation time that has not yet received ``/clock``: it
    has no time to judge a stamp's future by, so the future check waits for the first clock
    (the other checks apply). A message that arrives before the clock, as a replayed one can
    when the player's ``/clock`` lead-in reaches a starved process late, is then taken rather
    than dropped as stamped ahead of time 0.
    """

    __slots__ = ('gate', 'warner', 'dropped', 'time_resets', 'step_name', '_reset',
                 '_drop_step', '_time_reset', 'jump_handle', 'start', '_unpaired_at')

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
        self.start = StartGate(node)    # lock-step: the first step waits for the consumers
        self._unpaired_at = None         # monotonic time of the last expire_unpaired

    @property
    def future_tolerance_ns(self) -> int:
        return self.gate.future_tolerance_ns

    @property
    def last_ns(self):
        return self.gate.last_ns

    def take_step(self, stamp_ns: int, now_ns, answer) -> bool:
        """:meth:`StampGate.take_step` with this node's drop and time-reset glue; False (not
        taken, not judged) while the node's :class:`~irs_common.start_gate.StartGate` holds
        its first step (the rig publishes the step again).
        """
        if not self.start.open and not self.start.ready():
            return False
        if now_ns == 0:
            now_ns = None     # no /clock yet: nothing to judge the future by (class docstring)
        return self.gate.take_step(stamp_ns, now_ns, answer, self._drop_step, self._time_reset)

    def admit(self, what: str, stamp_ns: int, now_ns, pairing: bool = True) -> bool:
        """Whether input ``what`` stamped ``stamp_ns`` may join the pairing
        (:meth:`StampGate.admit`); a refused one is dropped, counted and reported.
        """
        verdict = self.gate.admit(stamp_ns, now_ns if now_ns != 0 else None, pairing)
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

    def expire_unpaired(self, sync, now: float | None = None) -> int:
        """Take out of ``sync`` (:class:`~irs_common.stamp_sync.StampSync`) the sets that have
        waited 1-2 s (:data:`UNPAIRED_AFTER`, by arrival on the monotonic clock ``now``, so any
        stamps qualify) for an input of their stamp, and warn (throttled) naming what came and
        what did not; returns how many were taken out.

        A message published alone, such as one input of a pair by ``ros2 topic pub``, or an
        input lost on the way, is then answered by a log line rather than by silence. The
        node's stale timer calls it as often as it likes; it acts once per ``UNPAIRED_AFTER``.
        """
        now = time.monotonic() if now is None else now
        last = self._unpaired_at
        if last is not None and now - last < UNPAIRED_AFTER:
            return 0
        self._unpaired_at = now
        gone = sync.expire()
        if gone:
            stamp_ns, missing = gone[-1]
            came = [n for n in sync.inputs if n not in missing]
            self.warner.warn(
                'unpaired', f'{len(gone)} input set(s) dropped unanswered: {", ".join(came)} '
                f'stamped {stamp_ns * 1e-9:.3f} s had no {", ".join(missing)} of the same stamp '
                f'within {UNPAIRED_AFTER:g} s ({", ".join(sync.inputs)} are paired by stamp: '
                'a partner lost on the way, or a message published alone)', now)
        return len(gone)

    def own_command_stamp(self, now_msg):
        """The stamp of a command the node sends on its own, with no step to answer (an input
        gone stale): the last step's stamp, else ``now_msg`` (the node clock) before any step.

        The consumer takes it as that step again (``REPEAT``) and goes on taking the steps after
        it. A clock stamp would be ahead of every step still to come from a rig that lags real
        time (a starved one), and the consumer would drop them all as out of order until the
        rig caught up.
        """
        last = self.gate.last_ns
        return from_ns(last) if last is not None else now_msg

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

    A node that was itself starved (its tick more than ``timeout`` after the one before: a
    stopped or starved process, every node of a composed one at once) has not yet taken the
    messages that arrived meanwhile, so their age says nothing about their source: after such a
    tick the checks pause for ``timeout / 2`` of node time (:attr:`skipped` counts those ticks),
    while the executor takes what is queued. An input that is really silent is then found one
    half-timeout later than otherwise. Times come from the node clock (``/clock`` with
    ``use_sim_time``).
    """

    __slots__ = ('node', 'check', 'timer', 'timeout_ns', 'last_tick_ns', 'resumed_ns',
                 'skipped')

    def __init__(self, node, timeout: float, check):
        self.node = node
        self.check = check
        self.last_tick_ns = None
        self.resumed_ns = None
        self.skipped = 0
        self.timer = None
        self.set_timeout(timeout)

    def set_timeout(self, timeout: float) -> None:
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
        self.timeout_ns = int(timeout * 1e9)
        self.last_tick_ns = None
        self.timer = self.node.create_timer(max(timeout / 2.0, 0.001), self._tick)

    def _tick(self) -> None:
        now = self.node.get_clock().now().nanoseconds
        last, self.last_tick_ns = self.last_tick_ns, now
        if last is not None and now - last > self.timeout_ns:
            self.resumed_ns = now                 # this node was starved: take the queue first
        if self.resumed_ns is not None:
            if now - self.resumed_ns < self.timeout_ns // 2:
                self.skipped += 1
                return
            self.resumed_ns = None
        self.check()
