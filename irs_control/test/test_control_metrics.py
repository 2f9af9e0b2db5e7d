"""Step metrics on analytic signals."""
import math

import numpy as np
import pytest

from irs_control.metrics import (ise_vs_model, oscillation_count, overshoot_percent, peak_abs,
                                 residual_oscillation, rise_time, settling_time, step_metrics)

T = np.linspace(0.0, 20.0, 200001)


def first_order(tau=0.5):
    return 1.0 - np.exp(-T / tau)


def second_order(zeta=0.3, wn=2.0):
    wd = wn * math.sqrt(1 - zeta ** 2)
    phi = math.acos(zeta)
    return 1.0 - np.exp(-zeta * wn * T) / math.sqrt(1 - zeta ** 2) * np.sin(wd * T + phi)


def test_first_order_rise_and_settling():
    tau = 0.5
    y = first_order(tau)
    assert rise_time(T, y, 1.0) == pytest.approx(tau * math.log(9.0), rel=1e-4)
    assert settling_time(T, y, 1.0) == pytest.approx(tau * math.log(50.0), rel=1e-3)
    assert overshoot_percent(y, 1.0) == 0.0
    assert oscillation_count(y, 1.0) == 0


@pytest.mark.parametrize('zeta', [0.2, 0.5, 0.7])
def test_second_order_overshoot(zeta):
    y = second_order(zeta)
    expected = 100.0 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta ** 2))
    assert overshoot_percent(y, 1.0) == pytest.approx(expected, rel=1e-4)


def test_second_order_oscillations_and_settling():
    zeta, wn = 0.1, 2.0
    y = second_order(zeta, wn)
    # envelope bound: settles by about -ln(0.02 sqrt(1-z^2))/(z wn) = 19.6 s
    ts = settling_time(T, y, 1.0)
    assert 10.0 < ts < 19.7
    # crossings every half damped period, first at ~ (pi - acos z)/wd
    assert oscillation_count(y, 1.0) >= 8
    assert residual_oscillation(T, y, 15.0) > 0.0


def test_negative_step_and_errors():
    y = -first_order()
    assert rise_time(T, y, -1.0) == pytest.approx(0.5 * math.log(9.0), rel=1e-4)
    with pytest.raises(ValueError, match='non-zero'):
        rise_time(T, y, 0.0)
    with pytest.raises(ValueError, match='equal length'):
        ise_vs_model(T, y, y[:-1])


def test_ise_and_peak():
    # (y - ym) = 0.1 over 20 s -> ISE = 0.01 * 20 = 0.2
    assert ise_vs_model(T, np.full_like(T, 1.1), np.ones_like(T)) == pytest.approx(0.2)
    assert peak_abs(np.array([0.1, -0.3, 0.2])) == 0.3


def test_step_metrics_bundle():
    y = first_order()
    m = step_metrics(T, y, 1.0, y_model=y, steer=0.2 * np.ones_like(T))
    assert m.ise_vs_model == 0.0 and m.peak_steer == 0.2
    assert m.residual_oscillation < 1e-6
    m2 = step_metrics(T, y, 1.0)
    assert math.isnan(m2.ise_vs_model) and math.isnan(m2.peak_steer)


@pytest.mark.parametrize('step', [1.0, -0.02])
def test_step_metrics_match_python_control(step):
    """Rise time, overshoot and settling time agree with ``control.step_info`` on a step response.

    step_info takes the first sample at or past each level (we interpolate between samples) and
    counts ``|y - y_final| >= 2 %`` as unsettled (we count ``>``): both differ by at most one
    sample period.
    """
    import control

    t = np.linspace(0.0, 10.0, 100001)
    dt = t[1] - t[0]
    _, y = control.step_response(control.tf([4.0 * step], [1.0, 1.2, 4.0]), t)
    info = control.step_info(y, t, yfinal=step)
    assert rise_time(t, y, step) == pytest.approx(info['RiseTime'], abs=dt)
    assert overshoot_percent(y, step) == pytest.approx(info['Overshoot'], rel=1e-12)
    assert settling_time(t, y, step) == pytest.approx(info['SettlingTime'], abs=dt)
    assert info['Overshoot'] == pytest.approx(100 * math.exp(-0.3 * math.pi / math.sqrt(0.91)),
                                              rel=1e-6)
