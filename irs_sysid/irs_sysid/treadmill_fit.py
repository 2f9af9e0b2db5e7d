"""Treadmill belt identification from voltage steps and coast-downs (paper Sec. 3.1, Fig. 5).

No rclpy: arrays in, estimates out. The model is the rig's belt (:mod:`irs_vehicle_sim.belt`)::

    dV/dt = -a V + b u(t - T_d)        drive on, the linear branch (Eq. 2: b/(s + a))
    dV/dt = -c (V + k)                 drive off (coast), c = B/J [1/s], k = F/B [m/s]

with ``V`` the belt speed [m/s] and ``u`` the drive voltage [V].

Drive (Eq. 2, :func:`fit_drive`): ``a``, ``b`` and ``T_d`` by nonlinear least squares over all
step-ups. Friction (Eq. 1, :func:`fit_coast`): ``c`` and ``k`` by the paper's iterative
linear-regression search on ``ln(V + k)``, refined on the speed error.

Confidence: 95 % half-widths from the Jacobian of the final ``least_squares``, with the residual
modelled as an autoregressive process within each step or coast (:mod:`.intervals`): the
encoder's quantisation seen through a moving window and any slow noise are correlated in time,
and a white-noise interval is then wrong by several times. The series are thinned to one sample
per ``decimate`` steps (default 10: one encoder window) before fitting.

Tolerances the identification is held to: the tests derive them from the noise of their data
(``irs_sysid/test/test_sysid_treadmill_fit.py``); the graph test holds the rig's defaults
(1 ms steps, encoder of 77.9 um per count, 10-step window) to the CLI's ``TOLERANCES``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from .intervals import P_MAX, Z95, half_widths

__all__ = ['Segment', 'segments', 'DriveFit', 'fit_drive', 'CoastFit', 'fit_coast',
           'simulate_belt', 'driver_profile', 'Z95']


@dataclass(frozen=True)
class Segment:
    """A stretch of constant command: ``[start, end)`` [s], voltage ``u`` [V], the one before."""

    start: float
    end: float
    u: float
    u_before: float

    @property
    def kind(self) -> str:
        """'up' (a step up), 'coast' (0 V after a drive), 'down' (a step down to > 0 V)."""
        if self.u > self.u_before:
            return 'up'
        if self.u <= 0.0 < self.u_before:
            return 'coast'
        return 'down' if self.u < self.u_before else 'hold'


def segments(t, u, tol: float = 1e-9) -> list[Segment]:
    """Constant-command stretches of the command series ``u`` [V] at times ``t`` [s]."""
    t, u = np.asarray(t, float), np.asarray(u, float)
    if t.size < 2 or t.shape != u.shape:
        raise ValueError('the command series needs at least 2 samples, as many times as values')
    change = np.flatnonzero(np.abs(np.diff(u)) > tol) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [t.size]])
    out = []
    for i, (s, e) in enumerate(zip(starts, ends)):
        before = u[starts[i - 1]] if i > 0 else u[0]
        end_time = t[e] if e < t.size else t[-1] + (t[-1] - t[-2])
        out.append(Segment(float(t[s]), float(end_time), float(u[s]), float(before)))
    return out


def _settled_speed(t, v, t_end, span=0.1):
    """Median speed over the ``span`` s before ``t_end`` (the speed a step starts from)."""
    m = (t >= t_end - span) & (t < t_end)
    return float(np.median(v[m])) if np.any(m) else float(np.interp(t_end, t, v))


@dataclass(frozen=True)
class DriveFit:
    """Eq. 2 identified: pole ``a`` [1/s], gain ``b`` [m/s^2/V], delay ``T_d`` [s], 95 % CIs.

    ``steps`` holds ``(t_s, V0, U, t_end)`` of every step used, ``V0`` as fitted; ``noise_ar``
    the AR coefficients of the residual model behind the intervals (:mod:`.intervals`).
    """

    a: float
    b: float
    delay: float
    a_ci: float
    b_ci: float
    delay_ci: float
    rms: float            # residual RMS [m/s]
    steps: tuple          # (t_s, V0, U, t_end) of every step used
    noise_ar: tuple = ()

    @property
    def dc_gain(self) -> float:
        """Steady-state speed per volt ``b/a`` [m/s/V]."""
        return self.b / self.a


def _step_response(params, steps, t_list):
    """Eq. 2's step responses; ``params = (a, b, T_d, V0_1, ..., V0_n)``."""
    a, b, td, *v0s = params
    out = []
    for (ts, _v0, uu, _te), v0, t in zip(steps, v0s, t_list):
        vss = b * uu / a
        tau = np.clip(t - ts - td, 0.0, None)
        out.append(vss + (v0 - vss) * np.exp(-a * tau))
    return out


def fit_drive(t, v, u, decimate: int = 10, settle: float = 2.0,
              guess=(3.0, 2.0, 0.03), noise_order: int = P_MAX) -> DriveFit:
    """Fit ``a``, ``b``, ``T_d`` to every step up of ``u``.

    Parameters
    ----------
    t, v, u : array_like
        Time [s], measured belt speed [m/s] and commanded drive voltage [V] on one grid.
    decimate : int
        Keep one sample in ``decimate`` (the encoder window) for the fit.
    settle : float
        Longest stretch after each step used [s] (the response settles within 1 s; the
        settled part fixes the gain and tells the slow part of the noise from the response).
    guess : tuple
        Start of the search ``(a [1/s], b [m/s^2/V], T_d [s])``; each ``V0`` starts at the
        median speed of the 0.1 s before its step.
    noise_order : int
        Largest order of the residual's AR model behind the intervals (:mod:`.intervals`);
        0: a white residual assumed.

    Raises
    ------
    ValueError
        No step up in ``u``.

    Every step **up** of the command from a speed ``V0`` gives, after the delay, ``V(t) = V_ss +
    (V0 - V_ss) exp(-a (t - t_s - T_d))`` with ``V_ss = b U / a``, ``U`` the new voltage, ``t_s``
    the step time. ``a`` [1/s], ``b`` [m/s^2/V], ``T_d`` [s] and one ``V0`` per step are fitted
    jointly over all step-ups by nonlinear least squares (``scipy.optimize.least_squares``), as the
    paper fitted the gain by least squares and the pole from the step responses. ``T_d`` is the
    delay *seen in the measured speed*: the drive's transport delay plus the encoder estimate's lag
    (``(window_samples/2 + delay_samples) dt``, 6 ms at the rig's defaults), which is what the
    configured value is compared with.
    """
    t, v, u = (np.asarray(x, float) for x in (t, v, u))
    steps, t_list, v_list = [], [], []
    for seg in segments(t, u):
        if seg.kind != 'up' or seg.start <= t[0]:
            continue
        te = min(seg.end, seg.start + settle)
        v0 = _settled_speed(t, v, seg.start)
        m = (t >= seg.start - 0.05) & (t < te)
        idx = np.flatnonzero(m)[::decimate]
        steps.append((seg.start, v0, seg.u, te))
        t_list.append(t[idx])
        v_list.append(v[idx])
    if not steps:
        raise ValueError('no step up of the drive voltage to fit the drive (Eq. 2) to')
    data = np.concatenate(v_list)
    ends = np.cumsum([len(x) for x in t_list])
    bounds = list(zip(np.r_[0, ends[:-1]], ends))

    def residuals(p):
        return np.concatenate(_step_response(p, steps, t_list)) - data

    n = len(steps)
    res = least_squares(residuals, [*guess, *(s[1] for s in steps)],
                        bounds=([1e-3, 1e-3, 0.0] + [-np.inf] * n, [1e3, 1e3, 1.0] + [np.inf] * n),
                        x_scale=[1.0, 1.0, 0.01] + [0.1] * n, method='trf')
    ci, noise = half_widths(res.jac, res.fun, bounds, noise_order)
    a, b, td, *v0s = res.x
    steps = tuple((ts, float(v0), uu, te) for (ts, _v, uu, te), v0 in zip(steps, v0s))
    return DriveFit(float(a), float(b), float(td), *map(float, ci[:3]),
                    float(np.sqrt(np.mean(res.fun ** 2))), steps, tuple(noise.phi))


@dataclass(frozen=True)
class CoastFit:
    """Eq. 1 friction identified: ``B/J`` [1/s], ``F/B`` [m/s], 95 % CIs, the coasts used;
    ``noise_ar`` the AR coefficients of the residual model behind the intervals.
    """

    b_over_j: float
    f_over_b: float
    b_over_j_ci: float
    f_over_b_ci: float
    rms: float             # residual RMS [m/s]
    coasts: tuple          # (t0, V0 fitted, t_end) of every coast-down used
    noise_ar: tuple = ()


def _coast_data(t, v, u, skip, v_min, decimate):
    out = []
    for seg in segments(t, u):
        if seg.kind != 'coast':
            continue
        m = (t >= seg.start + skip) & (t < seg.end) & (v > v_min)
        idx = np.flatnonzero(m)
        gaps = np.flatnonzero(np.diff(idx) > 1)
        if gaps.size:                     # the first contiguous stretch above v_min
            idx = idx[:gaps[0] + 1]
        if idx.size < 3 * decimate:
            continue
        idx = idx[::decimate]
        out.append((t[idx], v[idx]))
    return out


def _regress(coasts, k):
    """Linear regression of ln(V + k) on t: one intercept per coast, a common slope."""
    n = sum(len(tc) for tc, _ in coasts)
    X = np.zeros((n, len(coasts) + 1))
    y = np.empty(n)
    row = 0
    for i, (tc, vc) in enumerate(coasts):
        X[row:row + len(tc), i] = 1.0
        X[row:row + len(tc), -1] = tc - tc[0]
        y[row:row + len(tc)] = np.log(vc + k)
        row += len(tc)
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    return beta[:-1], -beta[-1]         # ln(V0 + k) per coast, c


def _coast_model(intercepts, c, k, coasts):
    return [np.exp(lnv0 - c * (tc - tc[0])) - k for lnv0, (tc, _vc) in zip(intercepts, coasts)]


def fit_coast(t, v, u, skip: float = 0.15, v_min: float = 0.1, decimate: int = 10,
              k_bounds=(1e-4, 10.0), noise_order: int = P_MAX) -> CoastFit:
    """Fit ``B/J`` and ``F/B`` to every coast-down.

    Parameters
    ----------
    t, v, u : array_like
        Time [s], measured belt speed [m/s] and commanded drive voltage [V] on one grid.
    skip : float
        Time after the drive is cut before a coast is used [s] (the drive's delay, the encoder
        window): 0.15 s.
    v_min : float
        Speeds at or below this are not used [m/s] (near standstill the encoder's quantum is a
        large fraction of the speed, and the belt stops).
    decimate : int
        Keep one sample in ``decimate``.
    k_bounds : tuple
        Search interval of ``F/B`` [m/s].
    noise_order : int
        Largest order of the residual's AR model behind the intervals; 0: white.

    Raises
    ------
    ValueError
        No coast-down in the data.

    On every coast-down (command 0 V after a drive) the solution is ``V(t) = (V0 + k) exp(-c (t -
    t0)) - k``, i.e. ``ln(V + k)`` is linear in ``t`` with slope ``-c``. The paper's "iterative,
    linear-regression search": an outer scalar search over ``k``
    (``scipy.optimize.minimize_scalar``, bounded) and, for each ``k``, a linear regression of
    ``ln(V + k)`` on ``t`` (``numpy.linalg.lstsq``: one intercept per coast-down, one common slope
    ``-c``); the outer search minimises the squared speed error of the regressed curves. Its
    optimum starts a final ``least_squares`` on the speed error itself, whose optimum is reported
    (the log-regression weighs the slow end of a coast more than its noise warrants).
    """
    t, v, u = (np.asarray(x, float) for x in (t, v, u))
    coasts = _coast_data(t, v, u, skip, v_min, decimate)
    if not coasts:
        raise ValueError('no coast-down (drive cut to 0 V after a drive) to fit the friction '
                         '(Eq. 1) to')
    data = np.concatenate([vc for _tc, vc in coasts])

    def sse(k):
        intercepts, c = _regress(coasts, k)
        return float(np.sum((np.concatenate(_coast_model(intercepts, c, k, coasts)) - data)
                            ** 2))

    # The outer search, on ln(k) (k spans decades between the readings of the paper's units).
    best = minimize_scalar(lambda lk: sse(np.exp(lk)), bounds=np.log(k_bounds),
                           method='bounded', options={'xatol': 1e-6})
    k = float(np.exp(best.x))
    intercepts, c = _regress(coasts, k)

    # The search's optimum of the log-regressions refined to the least-squares optimum of the
    # speed error (the estimate the interval belongs to), the interval from its Jacobian.
    def residuals(p):
        cc, kk, *lnv0 = p
        return np.concatenate(_coast_model(lnv0, cc, kk, coasts)) - data

    res = least_squares(residuals, [c, k, *intercepts], method='lm')
    ends = np.cumsum([len(tc) for tc, _ in coasts])
    ci, noise = half_widths(res.jac, res.fun, list(zip(np.r_[0, ends[:-1]], ends)), noise_order)
    c, k, *intercepts = res.x
    coast_info = tuple((float(tc[0]), float(np.exp(lv) - k), float(tc[-1]))
                       for (tc, _), lv in zip(coasts, intercepts))
    return CoastFit(float(c), float(k), float(ci[0]), float(ci[1]),
                    float(np.sqrt(np.mean(res.fun ** 2))), coast_info, tuple(noise.phi))


def simulate_belt(u, dt: float, params, v0: float = 0.0, measured: bool = False):
    """Belt speed [m/s] driven by the command series ``u`` [V] (one value per step of ``dt``).

    ``params`` is an :class:`irs_vehicle_sim.belt.BeltParams`; the result has ``len(u)`` samples,
    sample ``i`` the speed at the start of step ``i`` (the rig's convention). ``measured``: the
    encoder estimate instead of the true speed.
    """
    from irs_vehicle_sim.belt import TreadmillBelt
    belt = TreadmillBelt(params)
    belt.reset(v0)
    out = np.empty(len(u))
    for i, ui in enumerate(u):
        out[i] = belt.measured_speed if measured else belt.speed
        belt.step(float(ui), dt)
    return out


def driver_profile(t, v, tol: float = 0.002):
    """Breakpoints ``(times, speeds)`` of a linear profile within ``tol`` [m/s] of ``v(t)``.

    Greedy: a breakpoint is added where the straight line from the last one would leave the
    ``tol`` band. Used to make the car keep pace with the belt in an open-loop belt experiment
    (the driver commands the belt speed the model predicts).
    """
    t, v = np.asarray(t, float), np.asarray(v, float)
    times, speeds = [t[0]], [v[0]]
    i0 = 0
    i = 2
    while i < len(t):
        seg_t, seg_v = t[i0:i + 1], v[i0:i + 1]
        line = v[i0] + (v[i] - v[i0]) * (seg_t - t[i0]) / (t[i] - t[i0])
        if np.max(np.abs(line - seg_v)) > tol:
            i0 = i - 1
            times.append(t[i0])
            speeds.append(v[i0])
        i += 1
    times.append(t[-1])
    speeds.append(v[-1])
    return np.array(times), np.array(speeds)
