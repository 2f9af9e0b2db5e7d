r"""Confidence intervals of a least-squares fit whose residual is correlated in time; no rclpy.

A least-squares estimate with Jacobian ``J`` (n x k) at the optimum has, for a residual of
covariance ``Sigma``, the covariance (the sandwich; ``Sigma = s^2 I`` gives ``s^2 (J^T J)^-1``)::

    cov = B J^T Sigma J B,   B = (J^T J)^-1

The residual is modelled as a stationary autoregressive process of order p within each segment
(a step, a coast-down: one contiguous stretch of samples), the segments independent::

    e_t = phi_1 e_{t-1} + ... + phi_p e_{t-p} + w_t,   w white of variance sigma_w^2

p is chosen by BIC (0 to ``p_max``), with the autocovariances corrected for the fit's leverage
(:func:`fit_residual_model`, which also says what the intervals assume).

Frequency-domain fits (one point per band of FFT bins) have residuals that are independent
from band to band but of unequal variance; :func:`grouped_sandwich` gives their covariance
without assuming the variances known (HC3, the real and imaginary residual of a band a group).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import matmul_toeplitz, solve_toeplitz
from scipy.signal import fftconvolve, lfilter

__all__ = ['Z95', 'P_MAX', 'ResidualModel', 'fit_residual_model', 'sandwich_covariance',
           'quantile95', 'half_widths', 'grouped_sandwich', 'student95']

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

    def memory(self) -> float:
        """Long-run over short-run variance, ``sigma_w^2 / A(1)^2 / gamma_0`` [-]: how many
        samples one independent sample is worth (at least 1: a negatively correlated residual
        is counted as white).
        """
        if not self.order:
            return 1.0
        lrv = self.sigma2 / float(1.0 - np.sum(self.phi)) ** 2
        return max(1.0, lrv / float(self.autocovariance(1)[0]))

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


def _conditional_ls(resid, bounds, p_max):
    """Conditional least-squares AR fits of every order 0..p_max on the same rows (from sample
    p_max of each segment): ``[(phi, innovation variance), ...]``, rows used. The normal
    equations of the lag matrix X give all orders: ``G[:p, :p] phi = g[:p]`` with ``G = X^T X``,
    ``g = X^T y``, residual ``|y|^2 - phi . g[:p]`` (``numpy.linalg.solve``).
    """
    rows, target = [], []
    for a, b in bounds:
        e = resid[a:b]
        if e.size > p_max:
            target.append(e[p_max:])
            rows.append(np.column_stack([e[p_max - k:e.size - k] for k in range(1, p_max + 1)])
                        if p_max else np.zeros((e.size - p_max, 0)))
    if not target:
        return [], 0
    X, y = np.vstack(rows), np.concatenate(target)
    G, g, yy = X.T @ X, X.T @ y, float(y @ y)
    out = []
    for p in range(p_max + 1):
        try:
            phi = np.linalg.solve(G[:p, :p], g[:p]) if p else np.zeros(0)
        except np.linalg.LinAlgError:
            break
        out.append((phi, (yy - float(phi @ g[:p])) / y.size))
    return out, y.size


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
    """The AR model of the residual ``resid`` of a fit with Jacobian ``jac``.

    ``bounds``: ``[(start, end), ...]`` index ranges of the segments (default: one).

    p is chosen by BIC (0 to ``p_max``) on a conditional least-squares fit
    (``numpy.linalg.lstsq``). A fit's residual is shorter-memoried than its noise (the parameters
    absorb the slow part), so the autocovariances the model is fitted to are corrected for the
    fit's leverage: the expected residual autocovariance under the model, ``tr(L_l (I - H) Sigma (I
    - H))`` with ``H = J B J^T`` and ``L_l`` the lag-l shift, is matched to the sample one by a few
    Yule-Walker iterations (``scipy.linalg.solve_toeplitz``). ``Sigma`` is then the model's
    autocovariance (the impulse response of ``1/A(z)`` by ``scipy.signal.lfilter``), applied with
    ``scipy.linalg.matmul_toeplitz``.

    What the intervals assume: the residual is such an AR(p) process, the same in every segment,
    with p at most ``p_max`` samples of memory beyond which it is white; a model error that does
    not average out (a wrong structure) is not covered. White residual: p = 0 and the usual
    interval. Coverage measured on Ornstein-Uhlenbeck noise:
    ``irs_sysid/test/test_sysid_intervals.py``.
    """
    jac, resid = np.asarray(jac, float), np.asarray(resid, float)
    n, k = jac.shape
    bounds = _segments(bounds, n)
    p_max = max(0, min(int(p_max), min(b - a for a, b in bounds) // 4))
    fits, m = _conditional_ls(resid, bounds, p_max)
    best = None
    for phi, s2 in fits:
        if not s2 > 0.0:
            break
        bic = m * math.log(s2) + phi.size * math.log(m)
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


def quantile95(n: int, k: int, model: ResidualModel) -> float:
    """Two-sided 95 % quantile of Student's t with the residual's effective degrees of freedom,
    ``n / memory - k`` (at least 1): the interval's variance is itself estimated from the
    residual, from fewer independent samples the longer its memory (``scipy.stats.t``).
    """
    from scipy.stats import t as student_t

    return float(student_t.ppf(0.975, max(1.0, n / model.memory() - k)))


def half_widths(jac, resid, bounds=None, p_max: int = P_MAX):
    """``(95 % half-widths of the parameters, model)`` (NaN where the fit is singular):
    :func:`quantile95` times the square roots of :func:`sandwich_covariance`'s diagonal.
    """
    cov, model = sandwich_covariance(jac, resid, bounds, p_max)
    d = np.diag(cov)
    q = quantile95(*np.shape(jac), model)
    return np.where(np.isfinite(d), q * np.sqrt(np.clip(d, 0.0, None)), np.nan), model


def student95(dof: float) -> float:
    """Two-sided 95 % quantile of Student's t with ``dof`` degrees of freedom (at least 1)."""
    from scipy.stats import t as student_t

    return float(student_t.ppf(0.975, max(1.0, dof)))


def grouped_sandwich(jac, resid, groups):
    """``(cov, dof)``: the heteroscedasticity-consistent (HC3) covariance of a least-squares
    estimate whose residuals are independent between ``groups`` (index tuples) but not of one
    variance: ``B (sum_g J_g^T r~_g r~_g^T J_g) B``, ``B = (J^T J)^-1``, ``r~_g = (I - H_gg)^-1
    r_g`` with ``H = J B J^T`` (the leverage correction of MacKinnon and White); ``dof`` =
    groups - parameters, for Student's t.
    """
    jac, resid = np.asarray(jac, float), np.asarray(resid, float)
    B = np.linalg.pinv(jac.T @ jac)
    meat = np.zeros_like(B)
    for g in groups:
        g = list(g)
        jg = jac[g]
        rg = np.linalg.solve(np.eye(len(g)) - jg @ B @ jg.T, resid[g])
        v = jg.T @ rg
        meat += np.outer(v, v)
    return B @ meat @ B, max(1, len(groups) - jac.shape[1])
