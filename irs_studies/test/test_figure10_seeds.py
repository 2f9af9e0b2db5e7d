"""Figure 10 seed statistics: the noise-dominated flag, the noise band, and short offline runs."""
import math

import numpy as np
import pytest

from irs_studies.figure10 import seeds as F


def test_seed_stats_median_range_and_flags():
    rng = np.random.default_rng(0)
    steady = 2.0 + 0.01 * rng.standard_normal(8)          # spread ~2 % of the median
    st = F.seed_stats(steady)
    assert st['median'] == pytest.approx(np.median(steady))
    assert (st['min'], st['max']) == (steady.min(), steady.max())
    assert not st['noise_dominated'] and st['finite'] == 8
    wide = np.linspace(1.0, 1.5, 8)                       # spread 0.5 > 20 % of 1.25
    assert F.seed_stats(wide)['noise_dominated']
    assert not F.seed_stats(wide, floor=0.6)['noise_dominated']   # below the print resolution
    some_nan = np.r_[steady[:5], [math.nan] * 3]
    st = F.seed_stats(some_nan)
    assert st['noise_dominated'] and 'undefined for 3 of 8' in st['why']
    all_nan = F.seed_stats([math.nan] * 4)
    assert all_nan['finite'] == 0 and not all_nan['noise_dominated']
    assert F.seed_stats(steady, band_inside_noise=True)['noise_dominated']


def test_noise_band_is_the_seed_scatter_after_the_transient():
    t = np.arange(0.0, 5.0, 0.001)
    base = np.where(t > 1.0, 0.02, 0.0)
    offsets = (-1e-3, 0.0, 1e-3)                          # seeds scatter by +-1 mm ...
    traces = [{'time': t, 'y_s': base + np.where(t > 3.0, o, 5 * o)} for o in offsets]
    nb = F.noise_band(traces, 3.5)                        # ... from 3.5 s on only
    assert nb == pytest.approx(1e-3)
    assert F.noise_band(traces[:1], 3.5) == 0.0           # one seed: no scatter


@pytest.fixture(scope='module')
def short_study():
    """MRC with the actuator, 0.1 m step, both anti-windup choices, 2 seeds, 2 s records."""
    return F.seed_study(steps=(0.1,), seeds=2, designs=('mrc_with_actuator',), duration=2.0)


def test_clip_and_back_calculation_differ_at_the_large_step(short_study):
    metrics, traces = short_study
    d = 'mrc_with_actuator'
    aw, clip = metrics[(d, 0.1, 'back_calculation', 0)], metrics[(d, 0.1, 'clip', 0)]
    assert aw['time_at_limit'] > 0 and clip['time_at_limit'] > 0     # both saturate
    # without anti-windup the wound-up states overshoot far more
    assert clip['overshoot_percent'] > aw['overshoot_percent'] + 10.0
    summary = F.summarise(metrics, traces)
    assert set(summary) == {(d, 0.1, 'back_calculation'), (d, 0.1, 'clip')}
    row = summary[(d, 0.1, 'clip')]
    assert row['overshoot_percent']['median'] == pytest.approx(
        np.median([metrics[(d, 0.1, 'clip', k)]['overshoot_percent'] for k in (0, 1)]))
    assert '0.1 m' in F.stats_markdown(summary)


def test_seeds_change_the_noise_and_a_seed_repeats_exactly(short_study):
    metrics, traces = short_study
    d = 'mrc_with_actuator'
    a, b = traces[(d, 0.1, 'clip', 0)], traces[(d, 0.1, 'clip', 1)]
    assert not np.array_equal(a['y_measured'], b['y_measured'])
    again = F.run_case((d, 0.1, 'clip', 1, 2.0))[2]
    np.testing.assert_array_equal(again['y_s'], b['y_s'])
    assert 0 < metrics[(d, 0.1, 'clip', 0)]['measurement_noise_rms'] < 1e-3
