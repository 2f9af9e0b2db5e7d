"""Data generators for the identification tests that share no code with the fits they test.

Each generator is written here from the paper's equations with scipy and python-control, not
with the rig's models (``irs_vehicle_sim``) nor with the fits' own model functions, so that an
error in a fit's equations cannot cancel against the same error in its test data:

* :func:`belt_run`: Eq. 1-2 of the treadmill integrated by ``scipy.integrate.solve_ivp``
  (drive on: ``dV/dt = -a V + b u(t - T_d)``; drive off: ``dV/dt = -c (V + k)`` until rest),
  measured by a shaft encoder written here (counts of the belt travel differenced over a window,
  published late by whole samples);
* :func:`ou_noise`: Ornstein-Uhlenbeck noise, ``scipy.signal.lfilter`` of white noise;
* :func:`predicted_covariance`: the covariance a least-squares estimate has when its data carry
  noise of covariance ``Sigma``, ``B J^T Sigma J B`` with ``B = (J^T J)^-1``, ``J`` by central
  differences of a generator (the tolerances of the tests are a multiple of its square roots:
  derived from the noise of the data, not tuned to pass).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import toeplitz
from scipy.signal import lfilter

#: how many standard deviations a test allows: two-sided, a false failure once in 16 000
#: Gaussian draws per parameter
Z_TEST = 4.0


def ou_noise(rng, n: int, dt: float, tau: float, sigma: float) -> np.ndarray:
    """``n`` samples of Ornstein-Uhlenbeck noise of RMS ``sigma``, correlation time ``tau`` [s]
    (``tau = 0``: white), sampled every ``dt`` [s]; stationary from the first sample.
    """
    w = rng.standard_normal(n)
    if tau <= 0.0:
        return sigma * w
    phi = math.exp(-dt / tau)
    zi = np.array([phi * w[0]])           # start in the stationary distribution
    return sigma * lfilter([math.sqrt(1.0 - phi * phi)], [1.0, -phi], w, zi=zi)[0]


def ou_covariance(n: int, spacing: float, tau: float, sigma: float) -> np.ndarray:
    """Covariance of ``n`` samples ``spacing`` [s] apart of :func:`ou_noise`."""
    if tau <= 0.0:
        return sigma ** 2 * np.eye(n)
    return sigma ** 2 * toeplitz(np.exp(-np.arange(n) * spacing / tau))


@dataclass(frozen=True)
class Belt:
    """The treadmill of Eq. 1-2 and its encoder (values of the test, not of the rig).

    a [1/s], b [m/s^2/V], delay [s], c = B/J [1/s], k = F/B [m/s]; the encoder: ``count``
    [m of belt per count], ``window`` [samples] differenced, ``late`` [samples] of extra delay.
    """

    a: float = 4.5
    b: float = 2.38
    delay: float = 0.05
    c: float = 0.158
    k: float = 0.270
    count: float = 2 * math.pi * 0.0508 / 4096
    window: int = 10
    late: int = 1

    def measured_delay(self, dt: float) -> float:
        """The delay the encoder speed shows [s]: drive delay and the window's mean lag."""
        return self.delay + (self.window / 2 + self.late) * dt


def _belt_pieces(belt: Belt, schedule, t_end):
    """``[(t0, t1, u), ...]``: where the delayed drive is constant."""
    times = [t + belt.delay for t, _ in schedule[1:]] + [t_end]
    out, t0, u = [], 0.0, schedule[0][1]
    for (_, new_u), t1 in zip(schedule[1:] + [(None, None)], times):
        out.append((t0, t1, u))
        t0, u = t1, new_u
    return out


def belt_run(belt: Belt, schedule, t_end: float, dt: float = 1e-3, quantise: bool = True):
    """``(t, v_measured, u)``: the belt driven by ``schedule`` = ``[(0, U0), (t1, U1), ...]``
    (voltage ``U_i`` [V] from ``t_i`` [s]), starting settled at ``U0``, for ``t_end`` [s].

    Drive on (u > 0) the belt follows Eq. 2, drive off it coasts by Eq. 1 and stops at rest.
    ``v_measured[k]`` is the encoder speed at ``t_k = k dt``: the belt travel, in whole counts if
    ``quantise``, differenced over ``window`` samples, published ``late`` samples later.
    """
    t = np.arange(int(round(t_end / dt))) * dt
    v0 = belt.b / belt.a * schedule[0][1]
    state = np.array([v0, 0.0])          # speed [m/s], travel [m]
    pos = np.empty(t.size)

    def rhs(_t, x, u):
        if u > 0.0:
            return [-belt.a * x[0] + belt.b * u, x[0]]
        return [-belt.c * (x[0] + belt.k) if x[0] > 0.0 else 0.0, max(x[0], 0.0)]

    def stopped(_t, x, u):
        return x[0] if u <= 0.0 else 1.0
    stopped.terminal = True

    for t0, t1, u in _belt_pieces(belt, schedule, t_end):
        sel = np.flatnonzero((t >= t0) & (t < t1))
        sol = solve_ivp(rhs, (t0, t1), state, args=(u,), dense_output=True, events=stopped,
                        rtol=1e-11, atol=1e-13, method='DOP853')
        inside = t[sel] <= sol.t[-1]
        pos[sel[inside]] = sol.sol(t[sel[inside]])[1]
        state = sol.y[:, -1].copy()
        if sol.status == 1:               # stopped: at rest until the drive comes back
            state[0] = 0.0
            pos[sel[~inside]] = state[1]
    travel = np.floor(pos / belt.count + 1e-12) * belt.count if quantise else pos
    w = belt.window
    speed = np.full(t.size, v0)
    speed[w:] = (travel[w:] - travel[:-w]) / (w * dt)
    measured = np.concatenate([np.full(belt.late, v0), speed[:t.size - belt.late]])
    u = np.array([_level(schedule, x) for x in t])
    return t, measured, u


def _level(schedule, t):
    u = schedule[0][1]
    for ts, level in schedule[1:]:
        if t >= ts - 1e-12:
            u = level
    return u


def predicted_covariance(model, theta, sigma, columns=None, rel_step: float = 1e-5):
    """``B J^T Sigma J B`` at ``theta`` (module docstring) for the noise-free data
    ``model(theta)`` (a vector); ``columns``: extra Jacobian columns (nuisance parameters).
    """
    theta = np.asarray(theta, float)
    cols = []
    for i in range(theta.size):
        h = rel_step * max(abs(theta[i]), 1e-3)
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        cols.append((np.asarray(model(tp)) - np.asarray(model(tm))) / (2 * h))
    J = np.column_stack(cols + list(columns if columns is not None else []))
    B = np.linalg.inv(J.T @ J)
    return B @ J.T @ sigma @ J @ B


__all__ = ['Z_TEST', 'ou_noise', 'ou_covariance', 'Belt', 'belt_run', 'predicted_covariance']
