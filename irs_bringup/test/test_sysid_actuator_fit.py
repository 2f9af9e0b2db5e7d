"""actuator_fit on synthetic data (known first order + delay, with noise) and on the servo model.

Tolerances: pole 3 %, dead time 1 ms, gain 2 % on a 12 s sweep with output noise of 2 % of the
amplitude; the stated 95 % intervals must cover the true values.  Steps: the slew rate of a ramp
exactly, the dead time to the sample, the time-domain tau within 2 %.
"""
import math

import numpy as np
import pytest
from scipy import signal

from irs_bringup.sysid import actuator_fit as af
from irs_vehicle_sim.actuator import LEGACY, ActuatorParams, SteeringActuator

DT = 1e-3


def first_order_delay_sim(u, pole_hz, delay, gain=1.0):
    """Exact ZOH simulation of K p / (s + p) e^{-sT} (delay a whole number of samples)."""
    p = 2 * math.pi * pole_hz
    num, den, _ = signal.cont2discrete(([gain * p], [1.0, p]), DT, method='zoh')
    y = signal.lfilter(np.ravel(num), den, u)
    n = int(round(delay / DT))
    return np.concatenate([np.zeros(n), y[:len(y) - n]])


def chirp_input(amplitude, t_end=12.0, f0=0.5, f1=12.0):
    t = np.arange(0.0, t_end, DT)
    return t, amplitude * signal.chirp(t, f0, t[-1], f1, method='logarithmic', phi=-90)


@pytest.mark.parametrize('pole_hz, delay, gain', [(4.6, 0.017, 1.0), (1.5, 0.030, 0.8)])
def test_first_order_and_delay_recovered_with_noise(pole_hz, delay, gain):
    rng = np.random.default_rng(7)
    t, u = chirp_input(0.05)
    y = first_order_delay_sim(u, pole_hz, delay, gain) + rng.normal(0.0, 0.001, t.size)
    r = af.frequency_response(t, u, y, 0.5, 10.0, bands=30)
    fit = af.fit_first_order_delay(r)
    assert fit.poles_hz[0] == pytest.approx(pole_hz, rel=0.03)
    assert fit.delay == pytest.approx(delay, abs=1e-3)
    assert fit.gains[0] == pytest.approx(gain, rel=0.02)
    # the 95 % intervals are honest: they cover the truth, and they are not absurdly wide
    assert abs(fit.poles_hz[0] - pole_hz) <= fit.poles_ci95[0] + 0.01 * pole_hz
    assert 0.0 < fit.poles_ci95[0] < 0.2 * pole_hz
    assert 0.0 < fit.delay_ci95 < 0.005


def test_shared_delay_with_two_poles():
    t, u = chirp_input(0.05)
    rs = [af.frequency_response(t, u, first_order_delay_sim(u, f, 0.02), 0.5, 10.0, bands=30)
          for f in (6.0, 2.0)]
    fit = af.fit_first_order_delay(rs)
    np.testing.assert_allclose(fit.poles_hz, [6.0, 2.0], rtol=0.03)
    assert fit.delay == pytest.approx(0.02, abs=1e-3)
    fixed = af.fit_first_order_delay(rs, fixed_delay=0.02)
    np.testing.assert_allclose(fixed.poles_hz, [6.0, 2.0], rtol=0.03)


def test_frequency_response_rejects_bad_input():
    t = np.arange(0.0, 1.0, DT)
    with pytest.raises(ValueError, match='equal'):
        af.frequency_response(t, t[:-1], t, 0.5, 10.0)
    with pytest.raises(ValueError, match='finite'):
        af.frequency_response(t, np.full_like(t, np.nan), t, 0.5, 10.0)
    with pytest.raises(ValueError, match='no frequency'):
        af.frequency_response(t, np.sin(t), np.sin(t), 2000.0, 2100.0)
    with pytest.raises(ValueError, match='f_lo'):
        af.frequency_response(t, np.sin(t), np.sin(t), 5.0, 1.0)


def test_steps_ramp_and_lag():
    # a ramp at 1.2 rad/s after 20 samples of dead time, then a pure first-order step
    t = np.arange(0.0, 2.0, DT)
    u = np.where(t >= 0.5, 0.3, 0.0)
    y = np.clip((t - 0.52) * 1.2, 0.0, 0.3)
    idx = af.find_steps(t, u)
    assert idx == [500]
    s = af.analyse_step(t, u, y, 500, len(t))
    assert s.size == pytest.approx(0.3)
    assert s.rate == pytest.approx(1.2, rel=1e-9) and s.linearity > 0.9999
    assert s.dead_time == pytest.approx(0.02 + 0.02 * 0.3 / 1.2, abs=1.5e-3)  # 2 % of the travel
    tau, delay = 0.03, 0.017
    y2 = 0.1 * (1 - np.exp(-np.clip(t - 0.5 - delay, 0.0, None) / tau))
    s2 = af.analyse_step(t, np.where(t >= 0.5, 0.1, 0.0), y2, 500, len(t))
    assert s2.linearity < 0.99   # an exponential is not a ramp
    got_tau, got_delay, tau_ci, _ = af.fit_step(t[500:], y2[500:], 0.5, 0.0, 0.1)
    assert got_tau == pytest.approx(tau, rel=0.02) and got_delay == pytest.approx(delay, abs=1e-3)


def _fitted_poles(params, amps_deg):
    t = np.arange(0.0, 12.0, DT)
    responses = []
    for a in amps_deg:
        u = math.radians(a) * signal.chirp(t, 0.5, t[-1], 12.0, method='logarithmic', phi=-90)
        act = SteeringActuator(params)
        y = np.array([act.step(c, DT) for c in u])
        responses.append(af.frequency_response(t, u, y, 0.5, 10.0, bands=30))
    return af.fit_first_order_delay(responses).poles_hz


def test_servo_model_pole_falls_with_amplitude_legacy_does_not():
    poles = _fitted_poles(ActuatorParams(), (2.0, 4.0, 8.0, 15.0))
    print('fitted poles [Hz] at 2, 4, 8, 15 deg:', np.round(poles, 2))
    assert np.all(np.diff(poles) < 0.0)
    assert poles[0] > 5.0 and poles[-1] < 3.2   # paper Fig. 6: between 1 and 7 Hz
    flat = _fitted_poles(ActuatorParams(**LEGACY), (2.0, 15.0))
    assert abs(flat[1] / flat[0] - 1.0) < 0.25
