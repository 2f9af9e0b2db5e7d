r"""Confidence intervals of a least-squares fit whose residual is correlated in time; no rclpy.

A least-squares estimate with Jacobian ``J`` (n x k) at the optimum has, for a residual of
covariance ``Sigma``, the covariance (the sandwich; ``Sigma = s^2 I`` gives ``s^2 (J^T J)^-1``)::

    cov = B J^T Sigma J B,   B = (J^T J)^-1

The residual is modelled as a stationary autoregressive process of order p within each segment
(a step, a coast-down: one contiguous stretch of samples), the segments independent::

    e_t = phi_1 e_{t-1} + ... + phi_p e_{t-p} + w_t,   w white of variance sigma_w^2

p is chosen by BIC (0 to ``p_max``) on a conditional least-squares fit (``numpy.linalg.lstsq``).
A fit's residual is shorter-memoried than its noise (the parameters absorb the slow part), so
the autocovariances the model is fitted to are corrected for the fit's leverage: the expected
residual autocovariance under the model, ``tr(L_l (I - H) Sigma (I - H))`` with ``H = J B J^T``
and ``L_l`` the lag-l shift, is matched to the sample one by a few Yule-Walker iterations
(``scipy.linalg.solve_toeplitz``). ``Sigma`` is then the model's autocovariance (the impulse
response of ``1/A(z)`` by ``scipy.signal.lfilter``), applied with ``scipy.linalg.matmul_toeplitz``.

What the intervals assume: the residual is such an AR(p) process, the same in every segment, with
p at most ``p_max`` samples of memory beyond which it is white; a model error that does not
average out (a wrong structure) is not covered. White residual: p = 0 and the usual interval.
Coverage measured on Ornstein-Uhlenbeck noise: ``irs_bringup/test/test_sysid_intervals.py``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import matmul_toeplitz, solve_toeplitz
from scipy.signal import fftconvolve, lfilter

__all__ = ['Z95', 'P_MAX', 'ResidualModel', 'fit_residual_model', 'sandwich_covariance',
           'half_widths']

#: two-sided 95 % normal quantile
Z95 = 1.959963984540054
#: default largest AR order [samples] (an encoder's differenced quantisation, whose spectrum
#: vanishes at zero frequency, needs about 20)
P_MAX = 20


@dataclass(frozen=True)
class ResidualModel:
    """AR(p) model of a residual: ``phi`` (p coefficients), innovation variance ``sigma2``."""

    phi: np.ndarray
    sigma2: float

    @property
    def order(self) -> int:
        return int(self.phi.size)

    def autocovariance(self, n: int) -> np.ndarray:
        """Autocovariance at lags ``0..n-1`` [unit of the residual squared]."""
        a = np.r_[1.0, -self.phi]
        rho = float(np.max(np.abs(np.roots(a)))) if self.order else 0.0
        tail = int(math.ceil(math.log(1e-9) / math.log(rho))) if rho > 0.0 else 1
        m = n + min(tail, 200_000)
        h = lfilter([1.0], a, np.r_[1.0, np.zeros(m - 1)])
        return self.sigma2 * fftconvolve(h, h[::-1])[m - 1:m - 1 + n]


def _segments(bounds, n):
    out = [(int(a), int(b)) for a, b in (bounds if bounds is not None else [(0, n)])]
    if any(not 0 <= a < b <= n for a, b in out):
        raise ValueError(f'segment bounds must lie within 0..{n} and be non-empty, got {bounds}')
    return out


def _conditional_ls(resid, bounds, p, start):
    rows, target = [], []
    for a, b in bounds:
        e = resid[a:b]
        if e.size <= start:
            continue
        target.append(e[start:])
        rows.append(np.column_stack([e[start - k:e.size - k] for k in range(1, p + 1)])
                    if p else np.zeros((e.size - start, 0)))
    if not target:
        return np.zeros(p), math.nan, 0
    X, y = np.vstack(rows), np.concatenate(target)
    phi = np.linalg.lstsq(X, y, rcond=None)[0] if p else np.zeros(0)
    return phi, float(np.mean((y - X @ phi) ** 2)), y.size


def _lag_sums(x, y, bounds, p):
    """``sum_t x_t y_{t-l}`` within the segments, lags 0..p (x, y: vectors or matrices)."""
    return [sum(x[a + lag:b].T @ y[a:b - lag] for a, b in bounds if b - a > lag)
            for lag in range(p + 1)]


def _sigma_times(acov, X, bounds):
    out = np.empty_like(X)
    for a, b in bounds:
        c = acov[:b - a]
        out[a:b] = matmul_toeplitz((c, c), X[a:b], check_finite=False)
    return out


def _stationary(phi) -> bool:
    return phi.size == 0 or float(np.max(np.abs(np.roots(np.r_[1.0, -phi])))) < 1.0


def fit_residual_model(jac, resid, bounds=None, p_max: int = P_MAX,
                       iterations: int = 3) -> ResidualModel:
    """The AR model of the residual ``resid`` of a fit with Jacobian ``jac`` (module docstring).

    ``bounds``: ``[(start, end), ...]`` index ranges of the segments (default: one).
    """
    jac, resid = np.asarray(jac, float), np.asarray(resid, float)
    n, k = jac.shape
    bounds = _segments(bounds, n)
    p_max = max(0, min(int(p_max), min(b - a for a, b in bounds) // 4))
    best = None
    for p in range(p_max + 1):
        phi, s2, m = _conditional_ls(resid, bounds, p, p_max)
        if not (m > 0 and s2 > 0.0):
            break
        bic = m * math.log(s2) + p * math.log(m)
        if best is None or bic < best[0]:
            best = (bic, phi, s2)
    if best is None:
        return ResidualModel(np.zeros(0), float(np.mean(resid ** 2)) * n / max(1, n - k))
    _, phi, s2 = best
    p = phi.size
    if p == 0:
        return ResidualModel(phi, float(resid @ resid) / max(1, n - k))
    counts = np.array([sum(max(0, b - a - lag) for a, b in bounds) for lag in range(p + 1)])
    observed = np.array(_lag_sums(resid, resid, bounds, p))
    model = ResidualModel(phi, s2) if _stationary(phi) else None
    if model is None:       # Yule-Walker on the raw autocovariances: always stationary
        r = observed / counts
        phi = solve_toeplitz(r[:-1], r[1:])
        model = ResidualModel(phi, float(r[0] - phi @ r[1:]))
    B = np.linalg.pinv(jac.T @ jac)
    nmax = max(b - a for a, b in bounds)
    for _ in range(iterations):
        acov = model.autocovariance(nmax)
        SJ = _sigma_times(acov, jac, bounds)
        JSJ = jac.T @ SJ
        # E sum_t r_t r_{t-l} = tr(L Sigma) - tr(B J^T L Sigma J) - tr(B J^T Sigma L J)
        #                       + tr(B J^T Sigma J B J^T L J)
        jl, sjl, jsl = _lag_sums(jac, jac, bounds, p), _lag_sums(SJ, jac, bounds, p), \
            _lag_sums(jac, SJ, bounds, p)
        shrink = np.array([np.trace(B @ (sjl[lag] + jsl[lag])) - np.trace(B @ JSJ @ B @ jl[lag])
                           for lag in range(p + 1)])
        r = (observed + shrink) / counts
        phi = solve_toeplitz(r[:-1], r[1:])
        if not (_stationary(phi) and r[0] - phi @ r[1:] > 0.0):
            break
        model = ResidualModel(phi, float(r[0] - phi @ r[1:]))
    return model


def sandwich_covariance(jac, resid, bounds=None, p_max: int = P_MAX):
    """``(cov, model)``: the parameter covariance under the fitted residual model."""
    jac, resid = np.asarray(jac, float), np.asarray(resid, float)
    bounds = _segments(bounds, jac.shape[0])
    model = fit_residual_model(jac, resid, bounds, p_max)
    B = np.linalg.pinv(jac.T @ jac)
    acov = model.autocovariance(max(b - a for a, b in bounds))
    meat = jac.T @ _sigma_times(acov, jac, bounds)
    return B @ meat @ B, model


def half_widths(jac, resid, bounds=None, p_max: int = P_MAX):
    """``(95 % half-widths of the parameters, model)`` (NaN where the fit is singular)."""
    cov, model = sandwich_covariance(jac, resid, bounds, p_max)
    d = np.diag(cov)
    return np.where(np.isfinite(d), Z95 * np.sqrt(np.clip(d, 0.0, None)), np.nan), model
