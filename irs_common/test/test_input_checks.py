"""Input checks at node edges: value checks, the stamp rule, throttled warnings."""
import math

from hypothesis import given, settings, strategies as st

from irs_common.input_checks import (StampVerdict, ThrottledWarner, abs_limit_problem,
                                     finite_problem, range_problem, stamp_problem)

ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)
MAX_NS = 2 ** 63 - 1


def test_finite_problem():
    assert finite_problem('y', 0.1) is None
    assert finite_problem('y', 3) is None
    assert 'not finite' in finite_problem('y', math.nan)
    assert 'not finite' in finite_problem('y', -math.inf)
    assert 'not a number' in finite_problem('y', True)
    assert 'not a number' in finite_problem('y', None)
    assert 'not a number' in finite_problem('y', '1.0')


def test_range_problem_names_value_and_range():
    assert range_problem('y', 0.5, -2.0, 2.0, 'm') is None
    assert range_problem('y', 2.0, -2.0, 2.0) is None   # inclusive
    msg = range_problem('y', 1e308, -2.0, 2.0, 'm')
    assert 'y = 1e+308 m' in msg and '[-2, 2] m' in msg
    assert 'not finite' in abs_limit_problem('y', math.inf, 2.0)
    assert range_problem('v', 1e300, 0.0, math.inf) is None


def test_an_infinite_value_is_refused_also_within_infinite_limits():
    # inf lies in [-inf, inf]: a finite-float fast path must not let it through
    assert 'not finite' in range_problem('v', math.inf, -math.inf, math.inf)
    assert 'not finite' in abs_limit_problem('v', -math.inf, math.inf)
    assert 'not finite' in abs_limit_problem('v', math.nan, math.inf)


@settings(max_examples=300, deadline=None)
@given(ANY_FLOAT, st.floats(0.0, 1e6))
def test_range_problem_none_iff_usable(v, lim):
    ok = abs_limit_problem('v', v, lim) is None
    assert ok == (math.isfinite(v) and abs(v) <= lim)


def test_stamp_rule():
    now, tol = 10_000_000_000, 500_000_000
    assert stamp_problem(now, now, tol, None) == (StampVerdict.OK, None)
    assert stamp_problem(now + tol, now, tol, None)[0] is StampVerdict.OK
    v, why = stamp_problem(now + 86_400 * 10**9, now, tol, now - 1)
    assert v is StampVerdict.FUTURE and 'ahead of the clock' in why
    assert stamp_problem(MAX_NS, now, tol, None)[0] is StampVerdict.FUTURE
    v, why = stamp_problem(now - 5, now, tol, now - 5)
    assert v is StampVerdict.REPEAT and 'repeats' in why
    v, why = stamp_problem(0, now, tol, now - 5)
    assert v is StampVerdict.OLD and 'older' in why
    assert stamp_problem(MAX_NS, None, tol, 5)[0] is StampVerdict.OK   # no clock: no future check
    assert StampVerdict.FUTURE == 'future'


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, MAX_NS), min_size=1, max_size=30), st.integers(0, 10**12))
def test_future_stamp_never_blocks_later_data(stamps, tol):
    """Following the rule (store only OK stamps), a stamp accepted ahead of the clock can hide
    genuine readings for at most ``future_tolerance`` s: a reading stamped with the clock is
    accepted again once the clock has advanced by the tolerance, whatever was seen before.
    """
    now = 1_000_000_000
    last = None
    for s in stamps:
        verdict, why = stamp_problem(s, now, tol, last)
        assert (why is None) == (verdict is StampVerdict.OK)
        if verdict is StampVerdict.OK:
            assert s <= now + tol
            last = s
        now += tol + 1
        verdict, _ = stamp_problem(now, now, tol, last)   # a genuine reading, tolerance later
        assert verdict is StampVerdict.OK
        last = now


def test_throttled_warner_counts_suppressed():
    lines = []
    w = ThrottledWarner(lines.append, period=1.0)
    assert w.warn('nan', 'bad y', 0.0)
    for k in range(1, 5):
        assert not w.warn('nan', 'bad y', 0.1 * k)
    assert w.suppressed('nan') == 4
    assert w.warn('other', 'bad ref', 0.5)           # keys are independent
    assert w.warn('nan', 'bad y', 1.0)
    assert lines == ['bad y', 'bad ref', 'bad y (4 more suppressed)']
    assert w.warn('nan', 'bad y', 0.2)               # the clock jumped back: log again


def test_throttled_warner_reports_an_episode_once_and_its_end_with_the_count():
    lines, ends = [], []
    w = ThrottledWarner(lines.append, period=1.0)
    assert w.once('rejected', 'reading rejected', 0.0)
    for k in range(1, 5000):                 # 5 s of a persisting condition: no more lines
        assert not w.once('rejected', 'reading rejected', k * 1e-3)
    assert lines == ['reading rejected (reported once while it lasts)']
    assert w.end('rejected', ends.append, 'readings accepted again', 5.0)
    assert ends == ['readings accepted again (5000 in the episode)']
    assert not w.end('rejected', ends.append, 'again', 5.1)         # no episode open
    assert w.once('rejected', 'reading rejected', 6.5)                # a new episode: logged
    assert len(lines) == 2


def test_throttled_warner_throttles_flapping_episodes():
    lines, ends = [], []
    w = ThrottledWarner(lines.append, period=1.0)
    for k in range(100):                      # bad, good, bad, good ... every 10 ms
        w.once('bad', 'bad', k * 0.02)
        w.end('bad', ends.append, 'good', k * 0.02 + 0.01)
    assert len(lines) == 2 and len(ends) == 2     # 2 s: at most one of each a second


def test_a_flapping_input_is_one_episode_ended_once_it_settles():
    """Stale, fresh, stale ... every 0.3 s for 10 s (a starved graph after a stop): one line at
    the start and one once it has stayed fresh for the settling time, with the count.
    """
    lines, ends = [], []
    w = ThrottledWarner(lines.append, period=1.0)
    t = 0.0
    for _ in range(34):
        w.once('stale', 'input stale', t)
        for k in range(3):                    # three fresh samples 0.1 s apart, then stale
            w.end_settled('stale', ends.append, 'input fresh again', t + 0.1 * (k + 1))
        t += 0.3
    assert lines == ['input stale (reported once while it lasts)'] and ends == []
    for k in range(12):                       # fresh for 1.2 s: the episode ends once
        w.end_settled('stale', ends.append, 'input fresh again', t + 0.1 * k, settle=1.0)
    assert ends == ['input fresh again (34 in the episode)']
    assert not w.in_episode('stale')
    assert w.once('stale', 'input stale', t + 5.0)   # a later episode is logged again
    assert len(lines) == 2
