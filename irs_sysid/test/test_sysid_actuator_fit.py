"""actuator_fit on data it shares no code with: a first-order lag behind a dead time.

The data: :func:`sysid_generators.lag_and_delay` (exact on a ten times finer grid, a dead time
that is not a whole number of samples), driven by a logarithmic swept sine, the
response quantised to 0.1 mrad and with white noise. Tolerances: ``Z_TEST`` = 4 standard
deviations of the best estimate the noise allows on the fitted band
(:func:`sysid_generators.band_covariance`, the quantisation counted as white noise of variance
q^2/12). A fit whose model pole is 1 % off (test-only) must fail the same check. The 95 %
intervals of the frequency fit cover 95 % of the time on white and on slow noise.
"""
import math

import numpy as np
import pytest
from scipy import signal

from irs_sysid import actuator_fit as af
from irs_vehicle_sim.actuator import LEGACY, ActuatorParams, SteeringActuator
from sysid_generators import Z_TEST, band_covariance, lag_and_delay, ou_noise, \
    predicted_covariance, swept_sine

DT = 1e-3
LSB = 1e-4            # [rad] quantum of the measured angle
NOISE = 5e-4          # [rad] RMS of the white noise on it
BAND = (0.5, 10.0)    # [Hz] fitted
SWEEP = swept_sine(0.05, 0.5, 12.0, 12.0)          # 0.05 rad, 0.5-12 Hz over 12 s, rest 0.5 s
T = np.arange(int(round(13.0 / DT))) * DT


def measured(y, rng, noise=NOISE, tau=0.0):
    return LSB * np.round((y + ou_noise(rng, y.size, DT, tau, noise)) / LSB)


def fit(y):
    return af.fit_first_order_delay(af.frequency_response(T, SWEEP(T), y, *BAND, bands=30))


def predicted_sd(gain, pole_hz, delay, noise=NOISE):
    cov = band_covariance(lambda th: lag_and_delay(SWEEP, T, *th), [gain, pole_hz, delay], DT,
                          *BAND, noise ** 2 + LSB ** 2 / 12, steps=[0, 0, DT / 10])
    return np.sqrt(np.diag(cov))


def check(found, truth, sd, names=('gain', 'pole', 'delay')):
    bad = [f'{n}: {f:.6g} against {t:.6g}, error {(f - t) / s:+.1f} sd (tolerance {Z_TEST:g} '
           f'sd = {Z_TEST * s:.3g})' for n, f, t, s in zip(names, found, truth, sd)
           if not abs(f - t) <= Z_TEST * s]
    assert not bad, '; '.join(bad)


@pytest.mark.parametrize('gain, pole_hz, delay', [(1.0, 4.6, 0.0173), (0.8, 1.5, 0.0306)])
def test_first_order_and_delay_recovered_within_the_noise(gain, pole_hz, delay):
    y = measured(lag_and_delay(SWEEP, T, gain, pole_hz, delay), np.random.default_rng(7))
    res = fit(y)
    sd = predicted_sd(gain, pole_hz, delay)
    print('error / sd:', (np.r_[res.gains[0], res.poles_hz[0], res.delay]
                          - [gain, pole_hz, delay]) / sd, 'sd:', sd)
    check([res.gains[0], res.poles_hz[0], res.delay], [gain, pole_hz, delay], sd)
    # tight enough to catch a 1 % error of the pole, 0.5 % of the gain, 0.3 ms of dead time
    assert np.all(Z_TEST * sd < [0.005 * gain, 0.01 * pole_hz, 3e-4])


def test_a_wrong_frequency_fit_fails_the_check(monkeypatch):
    """A fit whose model pole is 1 % off (test-only) is caught by the same check."""
    right = af.first_order_delay
    monkeypatch.setattr(af, 'first_order_delay',
                        lambda f, k, p, d: right(f, k, 1.01 * p, d))
    y = measured(lag_and_delay(SWEEP, T, 1.0, 4.6, 0.0173), np.random.default_rng(7))
    res = fit(y)
    with pytest.raises(AssertionError, match='pole'):
        check([res.gains[0], res.poles_hz[0], res.delay], [1.0, 4.6, 0.0173],
              predicted_sd(1.0, 4.6, 0.0173))


@pytest.mark.parametrize('tau', [0.0, 0.2])
def test_frequency_fit_intervals_cover(tau):
    """The 95 % intervals of gain, pole and dead time hold the truth 95 % of the time (150
    draws, 3.3 standard errors of a coverage: 0.89 at least) on white noise and on slow noise
    (Ornstein-Uhlenbeck, 0.2 s), 2 mrad RMS.
    """
    y0 = lag_and_delay(SWEEP, T, 1.0, 4.6, 0.0173)
    rng = np.random.default_rng(31)
    trials, hit = 150, np.zeros(3)
    for _ in range(trials):
        res = fit(measured(y0, rng, 0.002, tau))
        hit += np.abs(np.r_[res.gains[0] - 1.0, res.poles_hz[0] - 4.6, res.delay - 0.0173]) \
            <= np.r_[res.gains_ci95[0], res.poles_ci95[0], res.delay_ci95]
    print('coverage gain, pole, delay:', hit / trials)
    assert np.all(hit / trials >= 0.95 - 3.3 * math.sqrt(0.95 * 0.05 / trials)), hit / trials
    assert np.all(hit / trials <= 0.995), hit / trials


def test_shared_delay_with_two_poles():
    rng = np.random.default_rng(3)
    ys = [measured(lag_and_delay(SWEEP, T, 1.0, f, 0.02), rng) for f in (6.0, 2.0)]
    rs = [af.frequency_response(T, SWEEP(T), y, *BAND, bands=30) for y in ys]
    res = af.fit_first_order_delay(rs)
    sd6, sd2 = predicted_sd(1.0, 6.0, 0.02), predicted_sd(1.0, 2.0, 0.02)
    check(res.poles_hz, [6.0, 2.0], [sd6[1], sd2[1]], ('pole 6 Hz', 'pole 2 Hz'))
    # the shared delay is fixed better than either alone would fix it
    check([res.delay], [0.02], [min(sd6[2], sd2[2])], ('delay',))
    fixed = af.fit_first_order_delay(rs, fixed_delay=0.02)
    check(fixed.poles_hz, [6.0, 2.0], [sd6[1], sd2[1]], ('pole 6 Hz', 'pole 2 Hz'))


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
    # a ramp at 1.2 rad/s after 20 samples of dead time: slope exactly, dead time to the sample
    t = np.arange(0.0, 2.0, DT)
    u = np.where(t >= 0.5, 0.3, 0.0)
    y = np.clip((t - 0.52) * 1.2, 0.0, 0.3)
    idx = af.find_steps(t, u)
    assert idx == [500]
    s = af.analyse_step(t, u, y, 500, len(t))
    assert s.size == pytest.approx(0.3)
    assert s.rate == pytest.approx(1.2, rel=1e-9) and s.linearity > 0.9999
    assert s.dead_time == pytest.approx(0.02 + 0.02 * 0.3 / 1.2, abs=1.5e-3)  # 2 % of the travel


def test_step_fit_within_the_noise():
    """A 0.1 rad step through a 4.6 Hz lag behind 17.3 ms, quantised, 0.5 mrad of noise: tau
    and the dead time within 4 sd of the best estimate (:func:`predicted_covariance`).
    """
    tau, delay = 1.0 / (2 * math.pi * 4.6), 0.0173
    t = np.arange(0.0, 1.0, DT)

    def step(th):
        return lag_and_delay(lambda x: np.where(x >= 0.1, 0.1, 0.0), t,
                             1.0, 1.0 / (2 * math.pi * th[0]), th[1])
    y = measured(step([tau, delay]), np.random.default_rng(5))
    k = 100
    got_tau, got_delay, tau_ci, delay_ci = af.fit_step(t[k:], y[k:], 0.1, 0.0, 0.1)
    sigma = (NOISE ** 2 + LSB ** 2 / 12) * np.eye(t.size - k)
    sd = np.sqrt(np.diag(predicted_covariance(lambda th: step(th)[k:], [tau, delay], sigma,
                                              steps=[0, DT / 10])))
    check([got_tau, got_delay], [tau, delay], sd, ('tau', 'delay'))
    assert 0.0 < tau_ci < 10 * sd[0] and 0.0 < delay_ci < 10 * sd[1]
    # an exponential is not a ramp
    s2 = af.analyse_step(t, np.where(t >= 0.1, 0.1, 0.0), step([tau, delay]), k, len(t))
    assert s2.linearity < 0.99


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
    assert poles[0] > 4.0 and poles[-1] < 1.6   # paper Fig. 6: between 1 and 7 Hz
    flat = _fitted_poles(ActuatorParams(**LEGACY), (2.0, 15.0))
    assert abs(flat[1] / flat[0] - 1.0) < 0.25
