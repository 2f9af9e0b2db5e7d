"""Differentiator transfer function, delay and noise gain."""
import math

import numpy as np
import pytest
from scipy.signal import lfilter

from irs_sensing.differentiator import (BackwardDifferenceLowPass, SavitzkyGolayDifferentiator,
                                        make_differentiator)

DT = 0.001
FILTERS = [
    ('lowpass 10 Hz', lambda: BackwardDifferenceLowPass(DT, 10.0)),
    ('lowpass 25 Hz zoh', lambda: BackwardDifferenceLowPass(DT, 25.0, 'zoh')),
    ('savgol N=20 p=1', lambda: SavitzkyGolayDifferentiator(DT, 20, 1)),
    ('savgol N=31 p=2', lambda: SavitzkyGolayDifferentiator(DT, 31, 2)),
]


@pytest.mark.parametrize('name,make', FILTERS)
def test_ramp_slope_exact(name, make):
    d = make()
    t = np.arange(400) * DT
    y = [d.update(3.0 * tt - 1.0) for tt in t]
    assert y[-1] == pytest.approx(3.0, rel=1e-6)
    assert d.dc_slope_gain() == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize('name,make', FILTERS)
def test_group_delay_from_parabola_lag(name, make):
    """x = t^2/2 has derivative t; the steady-state estimate is t - tau_d."""
    d = make()
    t = np.arange(2000) * DT
    y = np.array([d.update(0.5 * tt * tt) for tt in t])
    lag = t[-1] - y[-1]
    print(f'{name}: group delay {d.group_delay() * 1e3:.3f} ms, parabola lag {lag * 1e3:.3f} ms')
    assert lag == pytest.approx(d.group_delay(), abs=1e-9)
    assert d.group_delay() == pytest.approx(d.analytic_group_delay(), abs=1e-12)


@pytest.mark.parametrize('name,make', FILTERS)
def test_group_delay_matches_phase_slope(name, make):
    d = make()
    f = np.array([0.05, 0.1])
    ph = np.unwrap(np.angle(d.frequency_response(f)))
    gd = -(ph[1] - ph[0]) / (2 * np.pi * (f[1] - f[0]))
    assert gd == pytest.approx(d.group_delay(), abs=1e-6)


@pytest.mark.parametrize('name,make', FILTERS)
def test_noise_gain_empirical(name, make):
    d = make()
    rng = np.random.default_rng(42)
    sigma = 1e-3
    x = sigma * rng.standard_normal(200_000)
    b, a = d.transfer_function()
    y = lfilter(b, a, x)[2000:]
    empirical = np.std(y) / (sigma / DT)
    print(f'{name}: noise gain computed {d.noise_gain():.4f}, empirical {empirical:.4f}')
    assert empirical == pytest.approx(d.noise_gain(), rel=0.02)


def test_running_update_equals_lfilter():
    d = BackwardDifferenceLowPass(DT, 10.0)
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal(500))
    x[0] = 0.0  # reset initialises the history with the first sample
    y = np.array([d.update(v) for v in x])
    b, a = d.transfer_function()
    assert np.allclose(y, lfilter(b, a, x), atol=1e-9)


def test_analytic_noise_gain_lowpass():
    d = BackwardDifferenceLowPass(DT, 10.0)
    assert d.noise_gain() == pytest.approx(d.analytic_noise_gain(), rel=1e-9)
    # a plain backward difference (very high cut-off) tends to sqrt(2)
    assert BackwardDifferenceLowPass(DT, 1e6).noise_gain() == pytest.approx(math.sqrt(2), rel=1e-3)


def test_savgol_linear_matches_closed_form():
    n = 10
    d = SavitzkyGolayDifferentiator(DT, n, 1)
    b, _ = d.transfer_function()
    k = np.arange(n)
    expected = (((n - 1) / 2 - k) / np.sum((k - (n - 1) / 2) ** 2)) / DT
    assert np.allclose(b, expected)
    assert d.noise_gain() == pytest.approx(math.sqrt(12 / (n * (n * n - 1))), rel=1e-9)


def test_factory_and_validation():
    assert isinstance(make_differentiator('savgol', DT, window=5), SavitzkyGolayDifferentiator)
    with pytest.raises(ValueError):
        make_differentiator('bogus', DT)
    with pytest.raises(ValueError):
        BackwardDifferenceLowPass(DT, -1.0)
    with pytest.raises(ValueError):
        SavitzkyGolayDifferentiator(DT, 2, 2)
    with pytest.raises(ValueError):
        BackwardDifferenceLowPass(DT, 10.0).update(float('nan'))


@pytest.mark.parametrize('window,order', [(2, 1), (10, 1), (20, 1), (31, 2), (8, 3)])
def test_savgol_taps_match_scipy(window, order):
    """Our causal taps equal scipy's Savitzky-Golay derivative coefficients (newest sample)."""
    from scipy.signal import savgol_coeffs

    b, a = SavitzkyGolayDifferentiator(DT, window, order).transfer_function()
    ref = savgol_coeffs(window, order, deriv=1, delta=DT, pos=window - 1, use='conv')
    np.testing.assert_array_equal(a, [1.0])
    np.testing.assert_allclose(b, ref, rtol=0.0, atol=1e-12 * np.max(np.abs(ref)))
