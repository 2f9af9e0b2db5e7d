"""EdgeGate and StaleTimer (irs_common.node_edge): the stamp-gate glue the nodes share."""
import rclpy

from irs_common.input_checks import ThrottledWarner
from irs_common.node_edge import EdgeGate, StaleTimer

MS = 1_000_000


class Answer:
    """Counts the repeats an AnswerCache would publish."""

    def __init__(self):
        self.repeats = 0

    def repeat(self):
        self.repeats += 1


def test_edge_gate_takes_drops_repeats_and_resets(context):
    node = rclpy.create_node('edge_gate_test', context=context)
    lines, resets = [], []
    edge = EdgeGate(node, 0.5, 'encoders', lambda: resets.append(1),
                    ThrottledWarner(lines.append, 0.0))
    answer = Answer()
    now = 100_000 * MS
    assert edge.take_step(now, now, answer)                       # OK
    assert not edge.take_step(now, now, answer)                   # REPEAT: answered again
    assert answer.repeats == 1
    assert not edge.take_step(now - 10 * MS, now, answer)         # OLD: dropped, reported
    assert not edge.take_step(now + 10_000 * MS, now, answer)     # FUTURE: dropped
    assert edge.dropped == 2 and any('encoders: stamp' in ln for ln in lines)
    assert edge.take_step(now - 5_000 * MS, now, answer)          # RESET: taken, state reset
    assert resets == [1] and edge.time_resets == 1 and edge.last_ns == now - 5_000 * MS
    assert any(ln.startswith('encoders stamp') and 'time went back' in ln for ln in lines)
    assert not edge.admit('pose', now + 10_000 * MS, now) and edge.dropped == 3
    assert edge.admit('pose', now, now)
    edge.clear_time()                                             # the clock jumped back
    assert edge.last_ns is None and resets == [1, 1] and edge.time_resets == 2
    node.destroy_node()


def test_stale_timer_is_recreated_for_a_new_timeout(context):
    node = rclpy.create_node('stale_timer_test', context=context)
    stale = StaleTimer(node, 0.1, lambda: None)
    first = stale.timer
    assert abs(first.timer_period_ns - 50 * MS) < 1000
    stale.set_timeout(1.0)
    assert stale.timer is not first and abs(stale.timer.timer_period_ns - 500 * MS) < 1000
    assert first not in node.timers and stale.timer in node.timers
    node.destroy_node()


class _FakeNode:
    """Just what StaleTimer uses of a node: timers and a clock whose time the test sets."""

    def __init__(self):
        self.now_ns = 0
        self.timers = []

    def create_timer(self, period, callback):
        self.timers.append((period, callback))
        return callback

    def destroy_timer(self, timer):
        self.timers = [t for t in self.timers if t[1] is not timer]

    def get_clock(self):
        node = self

        class _Clock:
            def now(self):
                return type('T', (), {'nanoseconds': node.now_ns})()
        return _Clock()


def test_stale_timer_pauses_its_checks_after_its_own_node_was_starved():
    node = _FakeNode()
    checks = []
    stale = StaleTimer(node, 0.05, lambda: checks.append(node.now_ns))
    [(period, tick)] = node.timers
    assert period == 0.025

    def at(ms):
        node.now_ns = int(ms * MS)
        tick()

    for ms in (25, 50, 75, 100):                  # running: every tick checks
        at(ms)
    assert len(checks) == 4 and stale.skipped == 0
    at(300)                                       # the node itself stalled 200 ms (> 50 ms)
    at(301)                                       # an immediate tick after it: still paused
    at(320)
    assert len(checks) == 4 and stale.skipped == 3
    at(326)                                       # 26 ms after the late tick: checks again
    at(351)
    assert checks[-2:] == [326 * MS, 351 * MS] and stale.skipped == 3
    at(400)                                       # 49 ms: a late tick, but not starved
    assert checks[-1] == 400 * MS
    stale.set_timeout(1.0)                        # a new timeout: a fresh timer, fresh history
    [(period, tick)] = node.timers
    assert period == 0.5
    at(2000)
    assert checks[-1] == 2000 * MS


def test_edge_gate_judges_no_future_before_the_first_clock(context):
    """A clock at 0 (simulation time before its first /clock) takes a stamp 5 s ahead; the same
    stamp against a clock 1 ns later than 0 is future and dropped. Out of order stays out of
    order whatever the clock.
    """
    node = rclpy.create_node('edge_gate_clock0', context=context)
    edge = EdgeGate(node, 0.5, 'readings', lambda: None, ThrottledWarner(lambda _: None, 0.0))
    answer = Answer()
    assert edge.take_step(5_000 * MS, 0, answer)
    assert edge.admit('pose', 5_001 * MS, 0)
    assert not edge.take_step(4_999 * MS, 0, answer)             # OLD, clock or not
    assert not edge.take_step(6_000 * MS, 1, answer)             # FUTURE against 1 ns
    assert not edge.admit('pose', 6_000 * MS, 1)
    assert edge.dropped == 3
    node.destroy_node()


def test_edge_gate_reports_a_set_of_paired_inputs_that_never_completed(context):
    """A pose published alone (no velocity of its stamp) is dropped after it has waited
    UNPAIRED_AFTER s (by arrival, whatever its stamp) with a line naming what came and what did
    not; one that arrived later waits on.
    """
    from irs_common.node_edge import UNPAIRED_AFTER
    from irs_common.stamp_sync import StampSync
    node = rclpy.create_node('edge_gate_unpaired', context=context)
    lines = []
    edge = EdgeGate(node, 0.5, 'pose', lambda: None, ThrottledWarner(lines.append, 0.0))
    sync = StampSync(('pose', 'velocity'))
    t = 100_000 * MS
    sync.add('pose', t, 'lone')
    assert edge.expire_unpaired(sync, 10.0) == 0                  # marks what waits
    sync.add('pose', t + 900 * MS, 'young')
    assert edge.expire_unpaired(sync, 10.0 + 0.5 * UNPAIRED_AFTER) == 0 and not lines
    assert edge.expire_unpaired(sync, 10.0 + UNPAIRED_AFTER) == 1
    assert lines == ['1 input set(s) dropped unanswered: pose stamped 100.000 s had no velocity '
                     'of the same stamp within 1 s (pose, velocity are paired by stamp: a '
                     'partner lost on the way, or a message published alone)']
    assert sync.add('velocity', t + 900 * MS, 'v') == [(t + 900 * MS,
                                                        {'pose': 'young', 'velocity': 'v'})]
    node.destroy_node()
