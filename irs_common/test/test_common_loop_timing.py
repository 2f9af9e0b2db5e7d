"""LoopTiming (irs_common.loop_timing): misses, latency percentiles from the histogram, and a
percentile beyond the histogram's reach written as such.
"""
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from irs_common.loop_timing import LATENCY_RANGE, LoopTiming, format_ms


def test_misses_and_percentiles_are_counted_to_the_bin():
    t = LoopTiming(bin_s=10e-6)
    for k in range(100):
        t.step(answered=k % 10 != 0)
        t.add_latency(0.0002 if k < 98 else 0.003)
    s = t.summary()
    assert (s['steps'], s['deadline_misses'], s['miss_pct']) == (100, 10, 10.0)
    assert math.isclose(s['latency_p50_ms'], 0.21) and math.isclose(s['latency_p99_ms'], 3.01)
    assert math.isclose(s['latency_max_ms'], 3.0)
    assert math.isnan(LoopTiming().percentile(50))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=50), st.floats(1.0, 99.0))
def test_a_percentile_bounds_the_latencies_to_one_bin_or_is_beyond_the_reach(lat, q):
    t = LoopTiming()
    for v in lat:
        t.add_latency(v)
    p = t.percentile(q)
    # at or below the upper edge of the percentile's bin (a latency on an edge may fall either
    # side of it by the rounding of latency / bin_s)
    below = sum(max(v, 0.0) <= p * (1.0 + 1e-12) for v in lat)
    assert below >= q / 100.0 * len(lat) - 1e-9 or p > LATENCY_RANGE
    text = format_ms(1e3 * p)
    assert text == '> 50' if p > LATENCY_RANGE else float(text) == round(1e3 * p, 3)


def test_format_ms_writes_a_latency_beyond_the_histogram_as_a_bound():
    assert format_ms(0.2714) == '0.271'
    assert format_ms(50.01) == '> 50' and format_ms(49.99) == '49.990'
    assert format_ms(math.inf) == '> 50'


def test_timing_level_is_ok_warn_error_by_the_share_of_missed_deadlines():
    from irs_common.loop_timing import MISS_ERROR_PCT, MISS_WARN_PCT, LoopTiming, timing_level
    t = LoopTiming()
    assert timing_level(t.summary()) == 0                   # no step yet
    levels = []
    for misses in (0, 9, 10, 99, 100, 1000):
        t.steps, t.misses = 1000, misses
        levels.append(timing_level(t.summary()))
    assert levels == [0, 0, 1, 1, 2, 2]
    assert (MISS_WARN_PCT, MISS_ERROR_PCT) == (1.0, 10.0)
