"""Data generators for the identification tests that share no code with the fits they test.

Each generator is written here from the paper's equations with scipy and python-control, not
with the rig's models (``irs_vehicle_sim``) nor with the fits' own model functions, so that an
error in a fit's equations cannot cancel against the same error in its test data:

* :func:`belt_run`: Eq. 1-2 of the treadmill integrated by ``scipy.integrate.solve_ivp``
  (drive on: ``dV/dt = -a V + b u(t - T_d)``; drive off: ``dV/dt = -c (V + k)`` until rest),
  measured by a shaft encoder written here (counts of the belt travel differenced over a window,
  published late by whole samples);
* :func:`lag_and_delay`: a first-order lag behind a dead time of any length (the servo of
  paper Sec. 3.3), discretised exactly for a linearly interpolated input on a ten times finer
  grid, driven by a function of time such as :func:`swept_sine`;
* :func:`ou_noise`: Ornstein-Uhlenbeck noise, ``scipy.signal.lfilter`` of white noise;
* :func:`predicted_covariance`: the covariance a least-squares estimate has when its data carry
  noise of covariance ``Sigma``, ``B J^T Sigma J B`` with ``B = (J^T J)^-1``, ``J`` by central
  differences of a generator; :func:`band_covariance` the same for a fit on a frequency band
  (the tolerances of the tests are a multiple of their square roots: derived from the noise of
  the data, not tuned to pass).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import toeplitz
from scipy.signal import chirp, cont2discrete, lfilter

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


def jacobian_columns(model, theta, steps=None, rel_step: float = 1e-5) -> list:
    """``d model / d theta_i`` by central differences, ``steps[i]`` (default ``rel_step``
    times ``|theta_i|``). A dead time in :func:`lag_and_delay` needs a step of one point of its
    fine grid (the input's jumps move by whole points there).
    """
    theta = np.asarray(theta, float)
    cols = []
    for i in range(theta.size):
        h = steps[i] if steps is not None and steps[i] else rel_step * max(abs(theta[i]), 1e-3)
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        cols.append((np.asarray(model(tp)) - np.asarray(model(tm))) / (2 * h))
    return cols


def predicted_covariance(model, theta, sigma, columns=None, steps=None):
    """``B J^T Sigma J B`` at ``theta`` (module docstring) for the noise-free data
    ``model(theta)`` (a vector); ``columns``: extra Jacobian columns (nuisance parameters);
    ``steps``: of the differences (:func:`jacobian_columns`).
    """
    cols = jacobian_columns(model, theta, steps)
    J = np.column_stack(cols + list(columns if columns is not None else []))
    B = np.linalg.inv(J.T @ J)
    return B @ J.T @ sigma @ J @ B


__all__ = ['Z_TEST', 'ou_noise', 'ou_covariance', 'Belt', 'belt_run', 'predicted_covariance',
           'swept_sine', 'lag_and_delay', 'band_covariance', 'jacobian_columns', 'Car', 'pi_loop']


def swept_sine(amplitude: float, f0: float, f1: float, sweep: float, rest: float = 0.5):
    """``u(t)``: rest for ``rest`` s, a logarithmic sweep ``f0``-``f1`` [Hz] over ``sweep`` s
    (``scipy.signal.chirp``, starting at 0 with positive slope), rest again; a function of
    time [s] defined everywhere (0 outside the sweep).
    """
    def u(t):
        t = np.asarray(t, float)
        tau = t - rest
        inside = (tau >= 0.0) & (tau <= sweep)
        return np.where(inside, amplitude * chirp(np.clip(tau, 0.0, sweep), f0, sweep, f1,
                                                  method='logarithmic', phi=-90.0), 0.0)
    return u


def lag_and_delay(u, t, gain: float, pole_hz: float, delay: float, oversample: int = 10):
    """``y(t)`` of ``gain p / (s + p)``, ``p = 2 pi pole_hz``, driven by ``u(t - delay)`` (any
    delay, not whole samples), at the times ``t`` [s] (equally spaced, from 0): exact for an
    input interpolated linearly on a grid ``oversample`` times finer (``scipy.signal.
    cont2discrete``, first-order hold, then ``lfilter``), started at rest.
    """
    dt = (t[1] - t[0]) / oversample
    fine = np.arange(t.size * oversample) * dt
    p = 2 * math.pi * pole_hz
    num, den, _ = cont2discrete(([gain * p], [1.0, p]), dt, method='foh')
    return lfilter(np.ravel(num), den, u(fine - delay))[::oversample]


def band_covariance(model, theta, dt: float, f_lo: float, f_hi: float, noise_var: float,
                    steps=None):
    """Covariance of the best estimate of ``theta`` from the FFT bins in ``[f_lo, f_hi]`` [Hz]
    of the record ``model(theta) + n``, ``n`` white of variance ``noise_var``: the inverse of
    the Fisher information ``sum_k 2 Re(dY_k^H dY_k) / (N noise_var)`` (``dY_k`` the rfft of the
    record's derivative by central differences, ``N`` its length) -- what a fit on that band
    can reach at best.
    """
    cols = jacobian_columns(model, theta, steps)
    n = cols[0].size
    f = np.fft.rfftfreq(n, dt)
    sel = (f >= f_lo) & (f < f_hi)
    D = np.column_stack([np.fft.rfft(c)[sel] for c in cols])
    fisher = 2.0 * np.real(D.conj().T @ D) / (n * noise_var)
    return np.linalg.inv(fisher)


@dataclass(frozen=True)
class Car:
    """Eq. 6's structure: ``K (s^2 + c1 s + c0) / (s^2 (s^2 + d1 s + d0))`` [m/rad] behind a
    first-order lag of ``lag_hz`` [Hz] and a dead time of ``delay_steps`` samples of ``dt``;
    the default is Eq. 6 (K = b0 / 29, zeros -2.4, -4.8, poles 0, 0, -8, -20) at 1 kHz.
    """

    K: float = 363.394 / 29.0
    c1: float = 7.2
    c0: float = 11.52
    d1: float = 28.0
    d0: float = 160.0
    lag_hz: float = 4.6
    delay_steps: int = 17
    dt: float = 1e-3

    def continuous(self):
        """python-control transfer function of the plant without the dead time."""
        import control

        a = 2 * math.pi * self.lag_hz
        return control.tf(self.K * a * np.array([1.0, self.c1, self.c0]),
                          np.polymul([1.0, 0.0, 0.0], np.polymul([1.0, self.d1, self.d0],
                                                                 [1.0, a])))

    def discrete(self):
        """The plant held by a zero-order hold (``control.c2d``) with the dead time, as a
        state-space system of the input ``n`` samples ago: ``(A, B, C)`` and ``n``.
        """
        import control

        d = control.ss(control.c2d(self.continuous(), self.dt, 'zoh'))
        return d.A, d.B[:, 0], d.C[0], self.delay_steps

    def response(self, f):
        """The held, delayed plant's frequency response at ``f`` [Hz] seen from its samples."""
        import control

        d = control.c2d(self.continuous(), self.dt, 'zoh')
        z = np.exp(2j * math.pi * np.asarray(f) * self.dt)
        return np.array([complex(d(zk)) for zk in z]) * z ** -self.delay_steps


def pi_loop(car: Car, r, kp: float = 5.0, ki: float = 3.0, noise=None, lsb: float = 0.0):
    """``(u, y_measured)``: the car under the PI law ``u = (kp + ki/s)(r - y_measured)``
    (``control.c2d``, zero-order hold), ``y_measured = y + noise`` quantised to ``lsb`` [m] (the
    noise and quantisation fed back), one sample per ``car.dt``; a loop in Python.
    """
    import control

    A, B, C, n = car.discrete()
    ctl = control.ss(control.c2d(control.tf([kp, ki], [1.0, 0.0]), car.dt, 'zoh'))
    Ac, Bc, Cc, Dc = ctl.A, ctl.B[:, 0], ctl.C[0], float(ctl.D[0, 0])
    noise = np.zeros(len(r)) if noise is None else noise
    x, xc, fifo = np.zeros(A.shape[0]), np.zeros(Ac.shape[0]), [0.0] * n
    u, y = np.zeros(len(r)), np.zeros(len(r))
    for k in range(len(r)):
        ym = float(C @ x) + noise[k]
        if lsb > 0.0:
            ym = lsb * round(ym / lsb)
        e = r[k] - ym
        u[k] = float(Cc @ xc) + Dc * e
        xc = Ac @ xc + Bc * e
        fifo.append(u[k])
        x = A @ x + B * fifo.pop(0)
        y[k] = ym
    return u, y
