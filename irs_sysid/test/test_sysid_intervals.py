"""The 95 % intervals of the identification (irs_sysid.intervals) cover 95 % of the time,
also when the noise is correlated in time.

Coverage: the share of noise draws (fixed seeds) whose interval holds the true value. With N
draws its standard error is ``sqrt(0.95 * 0.05 / N)``; each test accepts 0.95 within 3.3 of them
(and no more than 0.995: an interval too wide is not honest either). The noise is
Ornstein-Uhlenbeck with a correlation time of 0.2 s (:func:`sysid_generators.ou_noise`), against
which the white-noise interval ``s^2 (J^T J)^-1`` covers about a third of the time; that interval
(``noise_order=0``) is run on the same draws and must fail the same test.
"""
import math

import numpy as np
import pytest

from irs_sysid import intervals
from irs_sysid.treadmill_fit import fit_coast, fit_drive
from sysid_generators import Belt, belt_run, ou_noise

DT = 1e-3


def accepted(coverage, n):
    """0.95 within 3.3 standard errors (two-sided 1e-3), and below 0.995."""
    se = math.sqrt(0.95 * 0.05 / n)
    return 0.95 - 3.3 * se <= coverage <= 0.995


def test_line_fit_on_correlated_noise():
    """A straight line per segment (three segments of 2 s, shared slope) under OU noise sampled
    every 10 ms: the intervals of slope and intercepts cover 95 %; the white-noise ones do not.
    """
    rng = np.random.default_rng(23)
    n, segs, trials = 200, 3, 400
    t = np.tile(np.arange(n) * 0.01, segs)
    bounds = [(i * n, (i + 1) * n) for i in range(segs)]
    J = np.zeros((n * segs, segs + 1))
    J[:, 0] = t
    for i, (a, b) in enumerate(bounds):
        J[a:b, 1 + i] = 1.0
    truth = np.r_[0.5, np.arange(segs, dtype=float)]
    hit = np.zeros(segs + 1)
    hit_white = np.zeros(segs + 1)
    for _ in range(trials):
        y = J @ truth + np.concatenate([ou_noise(rng, n, 0.01, 0.2, 1.0) for _ in range(segs)])
        est = np.linalg.lstsq(J, y, rcond=None)[0]
        resid = J @ est - y
        hw, model = intervals.half_widths(J, resid, bounds)
        hw_white, _ = intervals.half_widths(J, resid, bounds, p_max=0)
        hit += np.abs(est - truth) <= hw
        hit_white += np.abs(est - truth) <= hw_white
    cov, cov_white = hit / trials, hit_white / trials
    print('coverage:', cov, 'white-noise interval:', cov_white)
    assert all(accepted(c, trials) for c in cov), cov
    assert not any(accepted(c, trials) for c in cov_white), cov_white


@pytest.fixture(scope='module')
def belt_data():
    """The encoder speed of steps up from 0.5 V to 1.5, 3 and 4 V (2 s each) and a coast."""
    schedule = [(0.0, 0.5), (1.0, 1.5), (3.0, 3.0), (5.0, 4.0), (7.0, 0.0)]
    belt = Belt()
    t, v, u = belt_run(belt, schedule, 21.0)
    truth = np.array([belt.a, belt.b, belt.measured_delay(DT), belt.c, belt.k])
    return t, v, u, truth


def _coverage(belt_data, trials, noise_order, seed=29):
    t, v, u, truth = belt_data
    rng = np.random.default_rng(seed)
    hit = np.zeros(5)
    for _ in range(trials):
        vn = v + ou_noise(rng, t.size, DT, 0.2, 0.01)
        d = fit_drive(t, vn, u, noise_order=noise_order)
        c = fit_coast(t, vn, u, noise_order=noise_order)
        est = np.array([d.a, d.b, d.delay, c.b_over_j, c.f_over_b])
        hw = np.array([d.a_ci, d.b_ci, d.delay_ci, c.b_over_j_ci, c.f_over_b_ci])
        hit += np.abs(est - truth) <= hw
    return hit / trials


def test_treadmill_intervals_on_slow_noise(belt_data):
    """1 cm/s of OU noise (tau = 0.2 s) on the encoder speed: a, b, T_d, B/J, F/B covered at
    0.95 (200 draws); the white-noise intervals on the first 60 of them cover far less.
    """
    cov = _coverage(belt_data, 200, intervals.P_MAX)
    white = _coverage(belt_data, 60, 0)
    print('coverage a, b, T_d, B/J, F/B:', cov, 'white-noise intervals:', white)
    assert all(accepted(c, 200) for c in cov), cov
    assert np.all(white < 0.7), white
