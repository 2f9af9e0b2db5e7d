"""StampGate.admit: which input stamps may join a stamp pairing (irs_common.stamp_gate)."""
from hypothesis import given, strategies as st

from irs_common.stamp_gate import FUTURE, OK, OLD, RESET, StampGate

MS = 1_000_000


def test_admit_drops_the_future_and_the_old_but_not_a_time_reset():
    gate = StampGate(future_tolerance_ns=100 * MS, reset_after_ns=1000 * MS)
    assert gate.admit(5 * MS, now_ns=0) is None              # first message, near the clock
    assert gate.admit(200 * MS, now_ns=0) == FUTURE          # beyond the tolerance
    assert gate.check(500 * MS, now_ns=500 * MS) == OK       # a step taken at 0.5 s
    assert gate.admit(400 * MS, now_ns=500 * MS) == OLD      # older than it: can never pair
    assert gate.admit(400 * MS, now_ns=500 * MS, pairing=False) is None   # latest-value input
    assert gate.admit(500 * MS, now_ns=500 * MS) is None     # the same step (a repeat)
    assert gate.admit(600 * MS, now_ns=500 * MS) is None     # the next one
    assert gate.check(3000 * MS, now_ns=3000 * MS) == OK
    assert gate.admit(100 * MS, now_ns=3000 * MS) is None    # 2.9 s back: a time reset
    assert gate.admit(0, now_ns=None) is None                # no clock: no future check


@given(last=st.none() | st.integers(0, 10**12), stamp=st.integers(0, 10**12),
       now=st.none() | st.integers(0, 10**12))
def test_admit_stores_nothing_and_agrees_with_check(last, stamp, now):
    """admit never changes the gate, and it drops exactly what check calls FUTURE or OLD."""
    gate = StampGate()
    gate.last_ns = last
    verdict = gate.admit(stamp, now)
    assert gate.last_ns == last
    assert verdict == {FUTURE: FUTURE, OLD: OLD}.get(gate.check(stamp, now))


class _Node:
    """What take_step calls: the answer cache's repeat, the node's drop and time reset (which,
    like every node's, clears the gate).
    """

    def __init__(self, gate):
        self.gate, self.calls = gate, []

    def repeat(self):
        self.calls.append('repeat')

    def drop(self, verdict, stamp_ns, now_ns):
        self.calls.append(('drop', verdict, stamp_ns, now_ns))

    def reset(self, verdict, stamp_ns, now_ns):
        self.calls.append(('reset', verdict, stamp_ns))
        self.gate.clear()


def test_take_step_answers_a_repeat_drops_future_and_old_and_resets_keeping_the_new_stamp():
    gate = StampGate(future_tolerance_ns=100 * MS)
    node = _Node(gate)

    def take(stamp, now):
        return gate.take_step(stamp, now, node, node.drop, node.reset)

    assert take(500 * MS, 500 * MS) and node.calls == []                  # a step: compute it
    assert not take(500 * MS, 500 * MS) and node.calls == ['repeat']      # the same step again
    assert not take(900 * MS, 500 * MS)                                   # beyond the tolerance
    assert node.calls[-1] == ('drop', FUTURE, 900 * MS, 500 * MS)
    assert not take(400 * MS, 500 * MS) and node.calls[-1] == ('drop', OLD, 400 * MS, 500 * MS)
    assert gate.last_ns == 500 * MS                                       # neither was stored
    assert take(600 * MS, 600 * MS) and len(node.calls) == 3
    assert take(3000 * MS, 3000 * MS)
    assert take(100 * MS, 3000 * MS)                                      # 2.9 s back: reset
    assert node.calls[-1] == ('reset', 'reset', 100 * MS)
    assert gate.last_ns == 100 * MS, 'the reset cleared the gate, the new stamp stays'
    assert not take(100 * MS, 3000 * MS) and node.calls[-1] == 'repeat'   # now a repeat of it


@given(last=st.none() | st.integers(0, 10**12), stamp=st.integers(0, 10**12),
       now=st.none() | st.integers(0, 10**12))
def test_take_step_agrees_with_check(last, stamp, now):
    """take_step computes exactly the steps check calls OK or RESET, and stores what check does."""
    a, b = StampGate(), StampGate()
    a.last_ns = b.last_ns = last
    node = _Node(a)
    verdict = b.check(stamp, now)
    assert a.take_step(stamp, now, node, node.drop, node.reset) == (verdict in (OK, RESET))
    assert a.last_ns == b.last_ns
    assert len(node.calls) == (verdict != OK)


def test_answer_age_is_the_age_of_a_sample_the_rig_gave_out():
    from irs_common.stamp_gate import answer_age

    first, now = 1000 * MS, 1700 * MS
    assert answer_age(1699 * MS, first, now) == 1e-3          # the last step's sample
    assert answer_age(1100 * MS, first, now) == (600 * MS) * 1e-9   # a queue 0.6 s behind
    assert answer_age(first, first, now) == (700 * MS) * 1e-9
    assert answer_age(now, first, now) == 0.0                  # the current sample
    assert answer_age(0, first, now) == 0.0                    # `ros2 topic pub`: stamp 0
    assert answer_age(999 * MS, first, now) == 0.0             # before the run
    assert answer_age(2000 * MS, first, now) == 0.0            # ahead of the rig (another clock)


@given(first=st.integers(0, 10**12), span=st.integers(0, 10**10), stamp=st.integers(0, 10**13))
def test_answer_age_is_never_negative_and_at_most_the_run(first, span, stamp):
    from irs_common.stamp_gate import answer_age

    now = first + span
    age = answer_age(stamp, first, now)
    assert 0.0 <= age <= span * 1e-9
    assert (age > 0.0) == (first <= stamp < now)
