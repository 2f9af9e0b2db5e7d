"""Step-response metrics for the Figure 10 comparison (pure numpy functions).

Signals are sampled arrays: ``t`` [s], lateral output ``y`` [m], reference-model output
``y_model`` [m], steer [rad]. A step goes from ``y0`` to ``setpoint`` at ``t_step``;
``delta = setpoint - y0`` (either sign).

* rise time: time between the first 10 % and first 90 % crossings of ``delta``
  (linear interpolation between samples);
* overshoot [%]: ``100 max(0, max((y - setpoint) sign(delta))) / |delta|``;
* settling time (2 %): first time after which ``|y - setpoint| <= 0.02 |delta|`` for good,
  measured from ``t_step``;
* oscillation count: set-point crossings after the first one;
* residual oscillation: peak-to-peak of ``y`` over ``t >= t_from`` [m];
* ISE vs model: ``int (y - y_model)^2 dt`` [m^2 s] (trapezoidal);
* peak |steer| [rad].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ['StepMetrics', 'rise_time', 'overshoot_percent', 'settling_time',
           'oscillation_count', 'residual_oscillation', 'ise_vs_model', 'peak_abs',
           'step_metrics']


def _arrays(*arrs):
    out = [np.asarray(a, dtype=float) for a in arrs]
    n = out[0].shape
    for a in out:
        if a.ndim != 1 or a.shape != n:
            raise ValueError('Metric inputs must be 1-D arrays of equal length.')
    return out


def _delta(setpoint, y0):
    d = float(setpoint) - float(y0)
    if d == 0.0:
        raise ValueError('The step size setpoint - y0 must be non-zero for step metrics.')
    return d


def _first_crossing(t, x, level):
    """First time the (normalised, rising) signal x reaches level; nan if never."""
    idx = np.nonzero(x >= level)[0]
    if idx.size == 0:
        return float('nan')
    i = int(idx[0])
    if i == 0:
        return float(t[0])
    x0, x1 = x[i - 1], x[i]
    return float(t[i - 1] + (level - x0) * (t[i] - t[i - 1]) / (x1 - x0))


def rise_time(t, y, setpoint, y0=0.0, lo=0.1, hi=0.9) -> float:
    """10-90 % rise time [s] (nan if the response never reaches ``hi``)."""
    t, y = _arrays(t, y)
    x = (y - y0) / _delta(setpoint, y0)
    return _first_crossing(t, x, hi) - _first_crossing(t, x, lo)


def overshoot_percent(y, setpoint, y0=0.0) -> float:
    """Percent overshoot beyond ``setpoint`` in the direction of the step."""
    (y,) = _arrays(y)
    d = _delta(setpoint, y0)
    return float(100.0 * max(0.0, np.max((y - setpoint) * np.sign(d))) / abs(d))


def settling_time(t, y, setpoint, y0=0.0, band=0.02, t_step=0.0) -> float:
    """Time [s] from ``t_step`` after which ``y`` stays within ``band |delta|`` (nan if never)."""
    t, y = _arrays(t, y)
    d = _delta(setpoint, y0)
    out = np.abs(y - setpoint) > band * abs(d)
    if out[-1]:
        return float('nan')
    idx = np.nonzero(out)[0]
    if idx.size == 0:
        return float(max(t[0] - t_step, 0.0))
    return float(t[idx[-1] + 1] - t_step)


def oscillation_count(y, setpoint) -> int:
    """Number of set-point crossings after the first one."""
    (y,) = _arrays(y)
    s = np.sign(y - setpoint)
    s = s[s != 0]
    crossings = int(np.count_nonzero(s[1:] != s[:-1]))
    return max(crossings - 1, 0)


def residual_oscillation(t, y, t_from) -> float:
    """Peak-to-peak of ``y`` [m] over ``t >= t_from`` (nan if no samples there)."""
    t, y = _arrays(t, y)
    sel = y[t >= t_from]
    return float(np.ptp(sel)) if sel.size else float('nan')


def ise_vs_model(t, y, y_model) -> float:
    """Integral of squared deviation from the reference-model response [m^2 s]."""
    t, y, y_model = _arrays(t, y, y_model)
    e2 = (y - y_model) ** 2
    return float(np.sum(0.5 * (e2[1:] + e2[:-1]) * np.diff(t)))


def peak_abs(x) -> float:
    """``max |x|`` (e.g. peak steer [rad])."""
    (x,) = _arrays(x)
    return float(np.max(np.abs(x)))


@dataclass(frozen=True)
class StepMetrics:
    """All Figure-10 metrics of one response (units as in the module docstring)."""

    rise_time: float
    overshoot_percent: float
    settling_time: float
    oscillation_count: int
    residual_oscillation: float
    ise_vs_model: float
    peak_steer: float


def step_metrics(t, y, setpoint, y_model=None, steer=None, y0=0.0, t_step=0.0,
                 residual_from=None) -> StepMetrics:
    """Compute :class:`StepMetrics`; ISE and peak steer are nan when not given.

    ``residual_from`` defaults to the last 25 % of the record.
    """
    t, y = _arrays(t, y)
    sel = t >= t_step
    ts, ys = t[sel], y[sel]
    if residual_from is None:
        residual_from = t[0] + 0.75 * (t[-1] - t[0])
    return StepMetrics(
        rise_time=rise_time(ts, ys, setpoint, y0),
        overshoot_percent=overshoot_percent(ys, setpoint, y0),
        settling_time=settling_time(ts, ys, setpoint, y0, t_step=t_step),
        oscillation_count=oscillation_count(ys, setpoint),
        residual_oscillation=residual_oscillation(t, y, residual_from),
        ise_vs_model=ise_vs_model(t, y, y_model) if y_model is not None else float('nan'),
        peak_steer=peak_abs(steer) if steer is not None else float('nan'),
    )
