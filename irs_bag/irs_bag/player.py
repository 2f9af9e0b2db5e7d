"""The ROS side of ``bag play``: publishers, the /clock lead-in, the schedule, the end.

:class:`Player` publishes a :class:`~irs_bag.play.Plan` (read by :func:`irs_bag.play.prepare`):

1. publishers: ``/clock`` first (with ``--clock``), then one per played topic. A node learns a
   participant's endpoints in the order they were created (one reliable discovery stream), so
   a consumer's ``/clock`` subscription matches the player no later than its data
   subscriptions do;
2. with ``--wait-for-subscribers N``: wait until every publisher has matched N subscriptions;
3. the ``/clock`` lead-in: the first clock value is published every ``CLOCK_REPEAT_S`` until
   every ``/clock`` subscription has matched and ``CLOCK_LEAD_S`` have passed since the last
   one did (rclpy's time source subscribes best effort: nothing acknowledges, a repeat reaches
   it once it matched); then the reliable ones' acknowledgements of those values are awaited,
   with no new value published meanwhile (a value published while waiting would be one more
   to acknowledge: a writer learns of acknowledgements at its heartbeats, and a check right
   after a publish never sees all acknowledged). At most ``--ack-timeout`` in all, then a
   warning. So a consumer on ``use_sim_time`` has the data's time before the first message,
   and does not drop it as stamped ahead of its clock;
4. the schedule: message i at ``wall_start + (t_i - t_first) / rate``, ``/clock`` advanced to
   ``t_i`` right before it; sleeping in slices of at most ``SLICE_S``, spinning the last
   ``SPIN_S``; a message published late does not shift the ones after it (absolute times);
5. the end: every reliable subscriber's acknowledgement of every message is awaited
   (at most ``--ack-timeout``, default ``ACK_TIMEOUT_S``; a warning names the topics still
   unacknowledged), then one summary line. The player's writers send heartbeats every 50 ms
   (the environment's Fast DDS profile, or :func:`use_player_profile` where no profile is
   named), so acknowledgements come within about 0.1 s. With ``/clock``
   consumers a warning says what the player cannot see: a message a consumer received and then
   dropped against its clock (the consumer logs it).

SIGINT and SIGTERM set a flag (rclpy's handlers are off) that the schedule, the waits and the
lead-in check: the player stops within ``SLICE_S``, destroys its node and returns
``128 + signal`` (130 after Ctrl-C, 143 after SIGTERM), the same however busy the machine is.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from typing import Dict, List, Optional

from irs_common.dds_profile import PROFILE_VARIABLES, profile_file

__all__ = ['ACK_TIMEOUT_S', 'CLOCK_LEAD_S', 'CLOCK_REPEAT_S', 'Interrupt', 'Player',
           'TimingStats']

#: The last part of a wait before a due time is spun, not slept [s].
SPIN_S = 0.0003
#: Longest sleep between two looks at the interrupt flag [s].
SLICE_S = 0.05
#: Period of the first clock value during the lead-in [s].
CLOCK_REPEAT_S = 0.01
#: How long the first clock value is repeated after the last /clock subscription matched [s].
CLOCK_LEAD_S = 0.2
#: Default of ``--ack-timeout``: the longest wait for the reliable subscribers'
#: acknowledgements, at the lead-in and at the end [s].
ACK_TIMEOUT_S = 10.0


class Interrupt:
    """SIGINT / SIGTERM / SIGHUP recorded as a flag while installed; :attr:`exit_code` = 128 +
    signal. Under ``irs_common.cli.run_cli`` the command's guard keeps its handlers and calls
    the flag on the first signal (a second one leaves at once, as every command); called
    without it, the flag has handlers of its own for SIGINT and SIGTERM.
    """

    def __init__(self) -> None:
        from irs_common.cli import current_guard
        self.signum: Optional[int] = None
        self._old = {}
        self._guard = None
        if threading.current_thread() is not threading.main_thread():   # signals go there only
            return
        guard = current_guard()
        if guard is not None:
            self._guard = guard
            guard.on_first = lambda signum: self._on_signal(signum, None)
            if guard.signum is not None:
                # A signal came before: its Interrupted was raised where Python ignores
                # exceptions (seen inside the import system's module-lock callback at start-up),
                # or the command would not be here.
                self._on_signal(guard.signum, None)
        else:
            self._old = {sig: signal.signal(sig, self._on_signal)
                         for sig in (signal.SIGINT, signal.SIGTERM)}

    def _on_signal(self, signum, _frame) -> None:
        if self.signum is None:
            self.signum = signum

    def __bool__(self) -> bool:
        return self.signum is not None

    @property
    def exit_code(self) -> int:
        """128 + the signal number (130 for SIGINT), 0 if no signal came."""
        return 0 if self.signum is None else 128 + self.signum

    def restore(self) -> None:
        """Put the previous handlers back."""
        for sig, handler in self._old.items():
            signal.signal(sig, handler)
        self._old = {}


class TimingStats:
    """Accumulates ``actual - due`` publication errors [s]."""

    def __init__(self):
        self.errors: List[float] = []

    def add(self, err_s: float) -> None:
        self.errors.append(err_s)

    def summary(self) -> Dict[str, float]:
        if not self.errors:
            return {'n': 0, 'mean_ms': 0.0, 'p99_ms': 0.0, 'max_ms': 0.0, 'mean_signed_ms': 0.0}
        a = sorted(abs(e) for e in self.errors)
        n = len(a)
        return {'n': n, 'mean_ms': 1e3 * sum(a) / n,
                'p99_ms': 1e3 * a[min(n - 1, int(0.99 * n))], 'max_ms': 1e3 * a[-1],
                'mean_signed_ms': 1e3 * sum(self.errors) / n}


class Player:
    """Publishes a plan on a node of its own (module docstring); :meth:`run` returns the exit
    code.
    """

    def __init__(self, args, plan, interrupt: Interrupt, node) -> None:
        self.args, self.plan, self.interrupt, self.node = args, plan, interrupt, node
        self.log = (lambda *a: None) if args.quiet else (lambda s: print(s, flush=True))
        self.stats = TimingStats()
        self.played = self.clocks = 0
        self.last_clock: Optional[int] = None
        self.clock_pub = None
        self.pubs: Dict[str, object] = {}
        from builtin_interfaces.msg import Time
        from rosgraph_msgs.msg import Clock
        self._clock_types = (Clock, Time)

    def _clock_msg(self, t_ns: int):
        clock, time_type = self._clock_types
        return clock(clock=time_type(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000))

    # ------------------------------------------------------------------ steps
    def run(self) -> int:
        """Publishers, subscribers, lead-in, schedule (looped with ``--loop``), acks, summary."""
        self._create_publishers()
        if not self._wait_for_subscribers():
            return 1
        perf = time.perf_counter
        start = perf()
        elapsed = None
        if self.clock_pub is not None:
            self._clock_lead_in()
        loops = 0
        while not self.interrupt:
            self._play_once()
            loops += 1
            if not self.args.loop or self.interrupt:
                break
            self.log(f'bag play: loop {loops} done, playing again')
        if not self.interrupt:
            elapsed = perf() - start
            self._wait_for_acks()
        self._print_summary(elapsed)
        return self.interrupt.exit_code

    def _create_publishers(self) -> None:
        """``/clock`` first (see the module docstring), then one publisher per topic."""
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        plan, args = self.plan, self.args
        waits = plan.n_wait > 0
        if args.clock:
            self.clock_pub = self.node.create_publisher(Clock, '/clock', QoSProfile(
                history=HistoryPolicy.KEEP_LAST, depth=max(100, len(plan.todo) if waits else 0),
                reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE))
        for t in plan.wanted:
            offered = plan.infos[t].offered_qos_profiles or ''
            latched = 'transient_local' in offered and 'volatile' not in offered
            # When subscribers are waited for, keep the whole selection in the writer's history:
            # a reader whose side of the match completes just after ours can still get every
            # message by retransmission, even from a --fast burst.
            depth = max(1, args.qos_depth, plan.infos[t].message_count if waits else 0)
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                         else DurabilityPolicy.VOLATILE))
            self.pubs[t] = self.node.create_publisher(plan.types[t], plan.remaps.get(t, t), qos)

    def _endpoints(self) -> list:
        return ([self.clock_pub] if self.clock_pub is not None else []) + list(self.pubs.values())

    def _wait_for_subscribers(self) -> bool:
        """With ``--wait-for-subscribers N``: every publisher matched N (False: timed out)."""
        n = self.plan.n_wait
        if n <= 0:
            return True
        endpoints = self._endpoints()
        self.log(f'bag play: waiting for {n} subscriber(s) on '
                 f'{", ".join(p.topic_name for p in endpoints)}')
        deadline = time.monotonic() + self.args.wait_timeout
        while not self.interrupt:
            missing = [p.topic_name for p in endpoints if p.get_subscription_count() < n]
            if not missing:
                return True
            if time.monotonic() > deadline:
                print(f'bag play: error: timed out after {self.args.wait_timeout} s waiting for '
                      f'{n} subscriber(s) on {", ".join(missing)}', file=sys.stderr)
                return False
            time.sleep(0.01)
        return True

    def _clock_lead_in(self) -> None:
        """Repeat the first clock value until every /clock subscription has it (docstring)."""
        from rclpy.duration import Duration
        first = self.plan.clock_times[0]
        msg = self._clock_msg(first)
        now = time.monotonic
        timeout = self.args.ack_timeout
        deadline = now() + timeout
        matched, matched_at = -1, now()
        acked = False
        while not self.interrupt:
            self.clock_pub.publish(msg)
            self.clocks += 1
            count = self.clock_pub.get_subscription_count()
            if count != matched:
                matched, matched_at = count, now()
            if count >= self.plan.n_wait and now() - matched_at >= CLOCK_LEAD_S:
                break
            if now() > deadline:
                break
            time.sleep(CLOCK_REPEAT_S)
        # Then the acknowledgements of what was published, with no new value in the way: a
        # writer learns of them at its next heartbeat (Fast DDS: every 3 s by default).
        while not self.interrupt and not acked and now() <= deadline:
            acked = self.clock_pub.wait_for_all_acked(Duration(seconds=SLICE_S))
        if not acked and not self.interrupt:
            print(f'bag play: warning: /clock {first * 1e-9:.9f} s not acknowledged by every '
                  f'reliable /clock subscriber within {timeout:g} s; playing on',
                  file=sys.stderr, flush=True)
        self.last_clock = first

    def _play_once(self) -> None:
        """One pass over the selection on the schedule; ``/clock`` jumps back at its start.

        The per-message path is kept lean (locals, no calls but the publishes): at 13 topics x
        1 kHz a message has 77 us, and a player that falls behind plays late from then on.
        """
        plan, rate, perf, sleep = self.plan, self.plan.rate, time.perf_counter, time.sleep
        interrupt, pubs, clock_pub = self.interrupt, self.pubs, self.clock_pub
        add_error = self.stats.errors.append
        scale = 1e-9 / rate if rate > 0 else 0.0
        t_first = plan.times[0]
        if self.played:     # a later loop: the clock restarts with the data
            self.last_clock = None
        last_clock = self.last_clock
        wall0 = perf()
        for m, t_i, tc in zip(plan.todo, plan.times, plan.clock_times):
            if rate > 0:
                due = wall0 + (t_i - t_first) * scale
                rem = due - perf()
                while rem > SPIN_S and interrupt.signum is None:   # sleep in slices
                    sleep(min(rem - SPIN_S, SLICE_S))
                    rem = due - perf()
                while perf() < due and interrupt.signum is None:
                    pass
            if interrupt.signum is not None:
                break
            if clock_pub is not None and tc is not None and (
                    last_clock is None or tc > last_clock):
                clock_pub.publish(self._clock_msg(tc))
                last_clock = tc
                self.clocks += 1
            pubs[m.topic].publish(bytes(m.data))
            if rate > 0:
                add_error(perf() - due)
            self.played += 1
        self.last_clock = last_clock

    def _wait_for_acks(self) -> None:
        """Every reliable subscriber acknowledged every message (<= ``--ack-timeout``)."""
        from rclpy.duration import Duration
        timeout = self.args.ack_timeout
        t0 = time.monotonic()
        pending = self._endpoints()
        while pending and not self.interrupt and time.monotonic() - t0 < timeout:
            pending = [p for p in pending if not p.wait_for_all_acked(Duration(seconds=0.05))]
        if self.interrupt:
            return
        if pending:
            print(f'bag play: warning: not every subscriber acknowledged every message on '
                  f'{", ".join(p.topic_name for p in pending)} within {timeout:g} s',
                  file=sys.stderr, flush=True)
            return
        self.log(f'bag play: all messages acknowledged ({(time.monotonic() - t0) * 1e3:.1f} ms)')
        if self.clock_pub is not None and self.clock_pub.get_subscription_count():
            print('bag play: warning: acknowledged is received, not accepted: what a consumer on '
                  '/clock drops (stale or future-stamped against its clock) the player cannot '
                  'see; the consumer logs it', file=sys.stderr, flush=True)

    def _print_summary(self, elapsed: Optional[float]) -> None:
        s = self.stats.summary()
        timing = (f'timing error mean {s["mean_ms"]:.3f} ms, p99 {s["p99_ms"]:.3f} ms, '
                  f'max {s["max_ms"]:.3f} ms' if self.plan.rate > 0 else 'as fast as possible')
        what = f'played {self.played} messages'
        if self.args.clock:
            what += f' and {self.clocks} /clock'
        if self.interrupt:
            name = signal.Signals(self.interrupt.signum).name
            print(f'bag play: interrupted by {name} (exit code {self.interrupt.exit_code}), '
                  f'{what}', flush=True)
            return
        print(f'bag play: {what} in {elapsed:.3f} s; {timing}', flush=True)


def use_player_profile(environ=os.environ) -> Optional[str]:
    """Name the player's Fast DDS profile (``config/bag_play_fastdds.xml`` of ``irs_bag``:
    heartbeats every 50 ms, so the acknowledgements the player waits for come in about 0.1 s
    instead of up to 3 s) in ``environ``, unless a profile file is named there already; the
    file named, or None. Called before ``rclpy.init``: Fast DDS reads it once per process.
    """
    if profile_file(environ) is not None:
        return None
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    try:
        path = os.path.join(get_package_share_directory('irs_bag'), 'config',
                            'bag_play_fastdds.xml')
    except PackageNotFoundError:
        return None
    if not os.path.isfile(path):
        return None
    environ[PROFILE_VARIABLES[0]] = path
    return path


def topic_name_problem(name: str) -> Optional[str]:
    """What rcl finds wrong with ``name`` as a fully qualified topic name (the first line of
    rclpy's ``InvalidTopicNameException``), or None for a valid one.
    """
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.validate_full_topic_name import validate_full_topic_name
    try:
        validate_full_topic_name(name)
    except InvalidTopicNameException as exc:
        return str(exc).splitlines()[0]
    return None


def run_player(args, ros_args: List[str], plan, interrupt: Interrupt) -> int:
    """``rclpy.init`` (its signal handlers off: :class:`Interrupt` has them), one node, the
    :class:`Player`, clean shutdown; returns the exit code. The process's Fast DDS writers use
    the player's profile (:func:`use_player_profile`).
    """
    profile = use_player_profile()
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from irs_common.node_main import START_ERRORS, init_error_text
    node = None
    try:
        try:
            rclpy.init(args=['bag_play', *ros_args],
                       signal_handler_options=SignalHandlerOptions.NO)
        except START_ERRORS as exc:      # a --ros-args rcl refuses: as a node says it
            print(f'bag play: error: {init_error_text(exc)}', file=sys.stderr)
            return 2
        node = rclpy.create_node('bag_player')
        if profile is not None:    # read by now; not for processes this one may start
            os.environ.pop(PROFILE_VARIABLES[0], None)
        return Player(args, plan, interrupt, node).run()
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
