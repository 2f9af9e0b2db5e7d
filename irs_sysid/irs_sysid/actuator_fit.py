"""Steering-actuator identification (paper Sec. 3.3, Fig. 6-7): ROS-free fits on sampled data.

Frequency domain (Fig. 6).  From a swept sine ``u(t)`` (commanded steer angle) and the achieved
angle ``y(t)``, the H1 estimate of the frequency response and its coherence, averaged over
log-spaced frequency bands of one FFT of the record (:func:`frequency_response`)::

    H(f) = P_uy(f) / P_uu(f),    gamma^2(f) = |P_uy|^2 / (P_uu P_yy)

For a non-linear servo this is the describing function of the fundamental, which is what the
paper's HP dynamic signal analyser measured.  Each amplitude's response is fitted with a
first-order lag and a dead time (the paper's model of the servo)::

    G(j w) = K p / (j w + p) * exp(-j w T),   p = 2 pi f_p

by :func:`scipy.optimize.least_squares` on the complex log ratio ``log(G / H)`` (real part: log
magnitude error, imaginary part: phase error [rad], so both panels of a Bode plot weigh alike).
One dead time ``T`` is shared by all amplitudes (it is a transport delay, the same at any
amplitude); gain ``K_i`` and pole ``f_p,i`` are per amplitude.  Each band is weighted by
``sqrt(gamma^2)`` and has at least ``min_bins`` bins (narrower log bands are merged with the
next).

95 % confidence half-widths from the heteroscedasticity-consistent sandwich over the bands
(:func:`.intervals.grouped_sandwich`, Student's t): right whatever the weights, if the bands'
errors are independent (one FFT of a record that starts and ends at rest: neighbouring bands
share no bin) and the linearisation holds (errors small against the parameters); the noise may
have any colour.  Coverage measured: ``irs_sysid/test/test_sysid_actuator_fit.py``.

Time domain (Fig. 7).  Steps are found as jumps of the command.  For each: its size, the dead
time (from the jump to the first sample where the response has moved by more than
``move_fraction`` of the step), the slew rate (slope of a straight line through the 20-80 % part
of the transition, :func:`numpy.polyfit`) and, for steps that settle, a first-order + dead-time
fit of the response (least squares again).  A step is *rate limited* when the 20-80 % part is a
straight line: its slope is then the rate limit [rad/s].

Units: rad, s, Hz, rad/s.  No rclpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.fft import rfft, rfftfreq
from scipy.optimize import least_squares

from .intervals import grouped_sandwich, half_widths, student95

__all__ = ['FrequencyResponse', 'FirstOrderFit', 'StepResult', 'first_order_delay',
           'frequency_response', 'fit_first_order_delay', 'find_steps', 'analyse_step',
           'fit_step']


@dataclass
class FrequencyResponse:
    """An estimated frequency response (H1) with its coherence.

    f : ndarray       frequencies [Hz]
    h : ndarray       complex response, achieved / commanded [rad/rad]
    coherence : ndarray   magnitude-squared coherence in [0, 1]
    amplitude : float     command amplitude of the excitation [rad]
    bins : ndarray    FFT bins in each band (None: unknown)
    spread : tuple    per band, the bins' frequencies [Hz] and their share of the command's
                      power (None: unknown)
    """

    f: np.ndarray
    h: np.ndarray
    coherence: np.ndarray
    amplitude: float = math.nan
    bins: np.ndarray | None = None
    spread: tuple | None = None

    def band_average(self, response, keep=None) -> np.ndarray:
        """What the estimate measures of a system whose response is ``response(f)`` (complex,
        f [Hz]): each band's ``sum G(f_k) |U_k|^2 / sum |U_k|^2`` (noise-free ``Y_k = G_k U_k``
        in the H1 ratio), or ``G`` at the band frequencies without :attr:`spread`. ``keep``:
        a mask of the bands.
        """
        keep = np.ones(self.f.size, bool) if keep is None else np.asarray(keep)
        if self.spread is None:
            return response(self.f[keep])
        return np.array([np.dot(w, response(fk)) for (fk, w), k in zip(self.spread, keep) if k])

    def weights(self) -> np.ndarray:
        """Per-band weights of the fit, ``sqrt(gamma^2)``: a band the servo's non-linearity or
        the noise makes incoherent counts less.  Not the inverse standard deviation of a band's
        estimate, which on a noise-free, slew-limited servo would follow the distortion and fit
        the low bands at the cost of the roll-off; the intervals do not rest on the weights.
        """
        return np.sqrt(self.coherence)


@dataclass
class FirstOrderFit:
    """First-order lag + dead time fitted to one or several responses (shared dead time).

    gains, poles_hz : ndarray   K_i [rad/rad] and f_p,i [Hz], one per response
    delay : float               dead time T [s]
    gains_ci95, poles_ci95 : ndarray; delay_ci95 : float   95 % half-widths
    rms : float                 rms of the complex log residual (dimensionless)
    """

    gains: np.ndarray
    poles_hz: np.ndarray
    delay: float
    gains_ci95: np.ndarray
    poles_ci95: np.ndarray
    delay_ci95: float
    rms: float


@dataclass
class StepResult:
    """One step of the command and what the response did.

    t_step : float    time of the command jump [s]
    size : float      command jump [rad]
    dead_time : float [s] jump to the first clear movement of the response
    rate : float      |slope| of the 20-80 % part of the transition [rad/s]
    linearity : float coefficient of determination of that straight line (1 = a ramp)
    rise_time : float 10-90 % rise time [s]
    """

    t_step: float
    size: float
    dead_time: float
    rate: float
    linearity: float
    rise_time: float


def first_order_delay(f, gain: float, pole_hz: float, delay: float) -> np.ndarray:
    """``K p / (j w + p) exp(-j w T)`` at the frequencies ``f`` [Hz] (complex array)."""
    w = 2.0 * np.pi * np.asarray(f, dtype=float)
    p = 2.0 * np.pi * pole_hz
    return gain * p / (1j * w + p) * np.exp(-1j * w * delay)


def frequency_response(t, u, y, f_lo: float, f_hi: float, bands: int = 40,
                       amplitude: float = math.nan, min_bins: int = 3) -> FrequencyResponse:
    """H1 estimate achieved/commanded in ``bands`` log-spaced bands of ``[f_lo, f_hi]`` [Hz]
    (bands of fewer than ``min_bins`` FFT bins merged with the next).

    One FFT of the whole record (:func:`scipy.fft.rfft`, means removed; a swept sine excites
    each frequency once, so segment averaging would only cut the record), then the H1 ratio
    averaged over the bins of each band::

        H = sum(Y conj(U)) / sum(|U|^2),   gamma^2 = |sum(Y conj(U))|^2 / (sum|U|^2 sum|Y|^2)

    at the power-weighted mean frequency of the band (the fit compares a model averaged over
    the band the same way, :meth:`FrequencyResponse.band_average`).  A last band short of
    ``min_bins`` is left out.  Raises ``ValueError`` for unusable input.
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if not (t.ndim == 1 and t.shape == u.shape == y.shape and t.size >= 16):
        raise ValueError('frequency_response needs three equal 1-D arrays of 16 samples or more')
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise ValueError('frequency_response: command and response must be finite')
    dt = float(np.median(np.diff(t)))
    if not dt > 0.0 or np.max(np.abs(np.diff(t) - dt)) > 0.01 * dt:
        raise ValueError('frequency_response needs equally spaced, increasing sample times')
    if not 0.0 < f_lo < f_hi:
        raise ValueError(f'need 0 < f_lo < f_hi, got [{f_lo}, {f_hi}] Hz')
    f = rfftfreq(t.size, dt)
    uf = rfft(u - u.mean())
    yf = rfft(y - y.mean())
    edges = np.geomspace(f_lo, f_hi, bands + 1)
    fs, hs, cs, ns, spread = [], [], [], [], []
    lo = edges[0]
    for hi in edges[1:]:
        sel = (f >= lo) & (f < hi)
        if np.count_nonzero(sel) < max(1, min_bins):
            continue                      # too few bins: the band grows into the next
        lo = hi
        puu = float(np.sum(np.abs(uf[sel]) ** 2))
        if puu <= 0.0:
            continue
        puy = complex(np.sum(yf[sel] * np.conj(uf[sel])))
        pyy = float(np.sum(np.abs(yf[sel]) ** 2))
        fs.append(float(np.sum(f[sel] * np.abs(uf[sel]) ** 2)) / puu)
        hs.append(puy / puu)
        cs.append(abs(puy) ** 2 / (puu * pyy) if pyy > 0.0 else 0.0)
        ns.append(int(np.count_nonzero(sel)))
        spread.append((f[sel], np.abs(uf[sel]) ** 2 / puu))
    if not fs:
        raise ValueError(f'no frequency of the estimate lies in [{f_lo}, {f_hi}] Hz')
    return FrequencyResponse(np.array(fs), np.array(hs), np.array(cs), amplitude,
                             np.array(ns), tuple(spread))


def _ci_bands(jac: np.ndarray, resid: np.ndarray, groups) -> np.ndarray:
    """95 % half-widths from :func:`.intervals.grouped_sandwich` over the bands (the real and
    imaginary residual of one band a group), Student's t.
    """
    cov, dof = grouped_sandwich(jac, resid, groups)
    return student95(dof) * np.sqrt(np.clip(np.diag(cov), 0.0, None))


def fit_first_order_delay(responses, delay0: float = 0.02, min_coherence: float = 0.5,
                          fixed_delay: float | None = None) -> FirstOrderFit:
    """Fit ``K_i p_i / (s + p_i) exp(-s T)`` to every response, ``T`` shared (or fixed).

    ``responses``: a :class:`FrequencyResponse` or a list of them.  Points with coherence below
    ``min_coherence`` are left out; the others are weighted by :meth:`FrequencyResponse.weights`.
    """
    if isinstance(responses, FrequencyResponse):
        responses = [responses]
    data = []
    for r in responses:
        keep = (r.coherence >= min_coherence) & np.isfinite(r.h) & (np.abs(r.h) > 0.0)
        if np.count_nonzero(keep) < 3:
            raise ValueError('fewer than 3 usable frequencies (coherence too low or no data)')
        data.append((r.f[keep], r.h[keep], r.weights()[keep], r, keep))
    n = len(data)
    free_delay = fixed_delay is None

    def unpack(x):
        gains = np.exp(x[:n])
        poles = np.exp(x[n:2 * n])
        delay = x[2 * n] if free_delay else fixed_delay
        return gains, poles, delay

    def resid(x):
        gains, poles, delay = unpack(x)
        out = []
        for (_f, h, w, fr, keep), k, p in zip(data, gains, poles):
            g = fr.band_average(lambda fk: first_order_delay(fk, k, p, delay), keep)
            r = np.log(g / h)
            r = r.real + 1j * np.angle(np.exp(1j * r.imag))  # phase error wrapped to (-pi, pi]
            out.append(w * r.real)
            out.append(w * r.imag)
        return np.concatenate(out)

    g0 = [math.log(max(1e-6, float(np.median(np.abs(h[:3]))))) for _, h, *_ in data]
    p0 = [math.log(3.0)] * n
    x0 = np.array(g0 + p0 + ([delay0] if free_delay else []))
    sol = least_squares(resid, x0, method='lm', x_scale='jac')
    gains, poles, delay = unpack(sol.x)
    sizes = [f.size for f, *_ in data]
    offsets = np.cumsum([0] + [2 * m for m in sizes[:-1]])
    groups = [(o + i, o + m + i) for o, m in zip(offsets, sizes) for i in range(m)]
    ci = _ci_bands(sol.jac, sol.fun, groups)
    # log-parameters: half-width on the parameter by the delta method, d exp(x) = exp(x) dx
    return FirstOrderFit(gains=gains, poles_hz=poles, delay=float(delay),
                         gains_ci95=gains * ci[:n], poles_ci95=poles * ci[n:2 * n],
                         delay_ci95=float(ci[2 * n]) if free_delay else 0.0,
                         rms=float(np.sqrt(np.mean(sol.fun ** 2))))


def find_steps(t, u, min_size: float = 1e-6, min_gap: float = 0.0):
    """Indices ``k`` where the command jumps (``u[k] != u[k-1]`` by more than ``min_size``).

    Jumps closer than ``min_gap`` [s] to the previous one are ignored (a chirp is not a step).
    """
    t = np.asarray(t, dtype=float)
    du = np.abs(np.diff(np.asarray(u, dtype=float)))
    idx = np.flatnonzero(du > min_size) + 1
    out = []
    for k in idx:
        if not out or t[k] - t[out[-1]] >= min_gap:
            out.append(int(k))
    return out


def analyse_step(t, u, y, k: int, k_end: int, move_fraction: float = 0.02) -> StepResult:
    """The step of the command at sample ``k``, the response observed until ``k_end``."""
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if not 0 < k < k_end <= len(t):
        raise ValueError('analyse_step: need 0 < k < k_end <= number of samples')
    size = float(u[k] - u[k - 1])
    y0 = float(y[k - 1])
    seg_t, seg_y = t[k:k_end] - t[k], y[k:k_end]
    y1 = float(seg_y[-1])
    travel = y1 - y0
    if travel == 0.0:
        raise ValueError(f'the response did not move after the step at t = {t[k]:.3f} s')
    frac = (seg_y - y0) / travel
    moved = np.flatnonzero(np.abs(frac) > move_fraction)
    dead = float(seg_t[moved[0]]) if moved.size else math.nan

    def first(level):
        i = np.flatnonzero(frac >= level)
        return float(seg_t[i[0]]) if i.size else math.nan

    mid = (frac >= 0.2) & (frac <= 0.8)
    rate, r2 = math.nan, math.nan
    if np.count_nonzero(mid) >= 3:
        slope, icpt = np.polyfit(seg_t[mid], seg_y[mid], 1)
        fit = slope * seg_t[mid] + icpt
        ss = float(np.sum((seg_y[mid] - seg_y[mid].mean()) ** 2))
        r2 = 1.0 - float(np.sum((seg_y[mid] - fit) ** 2)) / ss if ss > 0 else math.nan
        rate = abs(float(slope))
    return StepResult(t_step=float(t[k]), size=size, dead_time=dead, rate=rate, linearity=r2,
                      rise_time=first(0.9) - first(0.1))


def fit_step(t, y, t_step: float, y0: float, y1: float, tau0: float = 0.03,
             delay0: float = 0.02):
    """First-order + dead-time fit of one step response (the paper's time-domain fit).

    ``y(t) = y0 + (y1 - y0) (1 - exp(-(t - t_step - T) / tau))`` for ``t > t_step + T``; returns
    ``(tau, T, tau_ci95, T_ci95)`` [s].  ``t``, ``y`` are the samples after the step.  The
    intervals model the residual as an autoregressive process (:mod:`.intervals`): a step's
    noise and the servo's unmodelled detail are correlated from sample to sample.
    """
    t = np.asarray(t, dtype=float) - t_step
    y = np.asarray(y, dtype=float)

    def model(x):
        tau, delay = math.exp(x[0]), x[1]
        s = np.clip(t - delay, 0.0, None)
        return y0 + (y1 - y0) * (1.0 - np.exp(-s / tau))

    sol = least_squares(lambda x: (model(x) - y) / abs(y1 - y0),
                        np.array([math.log(tau0), delay0]), method='trf', x_scale=[1.0, 0.01])
    ci, _noise = half_widths(sol.jac, sol.fun)
    tau = math.exp(sol.x[0])
    return tau, float(sol.x[1]), tau * ci[0], float(ci[1])
