"""Call a function once per simulation tick (sim time) or at a fixed wall rate (real time).

``create_ticker(node, rate_hz, callback, on_reset=None)`` arranges ``callback(stamp, t)`` with
``stamp`` the ``builtin_interfaces/Time`` to put on the output and ``t`` [s] the time since the
start of the run:

- with ``use_sim_time`` (lock-step runs, bag replay with ``--clock``): once per ``/clock``
  message, ``stamp`` = that time and ``t`` = the same in seconds (simulation time starts at 0
  with the run). The ticker rides on the node's own (validated, reliable) ``/clock`` subscription
  (:func:`irs_common.sim_time.guard_clock`), so the node receives ``/clock`` once per step. A
  tick the rig publishes again (vehicle_sim's ``lockstep_resend_period``) is answered again, so a
  consumer that missed the first answer gets it;
- otherwise: a wall timer at ``rate_hz`` with the node clock's time as ``stamp`` and
  ``t = stamp - t0``, where t0 is the first tick (the node's start) or the last ``restart()``:
  references and speed profiles count from the start of the run, not from the Unix epoch.

In a lock-step run the ticker leaves a tick unanswered until the node's publishers have matched
the run's subscriptions (:class:`~irs_common.start_gate.StartGate`, ``start_subscribers``); the
rig publishes the tick again.

Time going backwards (``/clock`` jumping back, as ``bag play --loop --clock`` does) resets the
ticker: ``on_reset()`` is called so the node can clear its time-dependent state, and the ticks
continue from the new time.
"""
from . import qos
from .sim_time import guard_clock
from .start_gate import StartGate


class Ticker:
    """The object ``create_ticker`` returns."""

    def __init__(self, node, rate_hz: float, callback, on_reset=None):
        self.node = node
        self.callback = callback
        self.on_reset = on_reset
        self.t0_ns = None
        self.last_ns = -1
        self.timer = None
        self.subscription = None
        self.start = StartGate(node)
        if node.get_parameter('use_sim_time').value:
            self.subscription = guard_clock(node, self._on_clock, qos.CLOCK)
        else:
            self.timer = node.create_timer(1.0 / rate_hz, self._on_timer)

    def restart(self):
        """Count ``t`` from the next tick again (real time)."""
        self.t0_ns = None

    def _jumped_back(self, ns, previous):
        self.node.get_logger().warning(
            f'time jumped back from {previous * 1e-9:.6f} s to {ns * 1e-9:.6f} s: restarting')
        if self.on_reset is not None:
            self.on_reset()

    def _on_clock(self, stamp, ns):
        if not self.start.open and not self.start.ready():
            return      # held: the rig publishes the tick again
        if ns < self.last_ns:
            self._jumped_back(ns, self.last_ns)
        self.last_ns = ns
        self.callback(stamp, ns * 1e-9)

    def _on_timer(self):
        now = self.node.get_clock().now()
        ns = now.nanoseconds
        if self.t0_ns is None or ns < self.last_ns:
            if self.t0_ns is not None:
                self._jumped_back(ns, self.last_ns)
            self.t0_ns = ns
        self.last_ns = ns
        self.callback(now.to_msg(), (ns - self.t0_ns) * 1e-9)


def create_ticker(node, rate_hz: float, callback, on_reset=None) -> Ticker:
    """See the module docstring."""
    return Ticker(node, rate_hz, callback, on_reset)
