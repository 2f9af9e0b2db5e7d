"""StampGate.admit: which input stamps may join a stamp pairing (irs_common.stamp_gate)."""
from hypothesis import given, strategies as st

from irs_common.stamp_gate import FUTURE, OLD, OK, StampGate

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
