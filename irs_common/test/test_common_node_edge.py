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
