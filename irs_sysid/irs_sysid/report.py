"""The identification report: identified against configured values, one line per parameter.

A :class:`Estimate` carries the identified value, its 95 % confidence half-width (from the fit's
covariance or its residuals; NaN when the method gives none), the value configured in the rig
(NaN when the bag does not say) and the tolerance the tests hold it to, relative or absolute.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ['Estimate', 'format_report']


@dataclass(frozen=True)
class Estimate:
    """One identified parameter.

    name : str        what it is, e.g. ``'pole a'``
    value : float     identified value, in ``unit``
    unit : str        SI unit, e.g. ``'1/s'``
    ci95 : float      95 % confidence half-width of ``value`` [unit]; NaN if unknown
    configured : float  the rig's configured value [unit]; NaN if unknown
    rel_tol : float   relative tolerance the tests hold ``value`` to (NaN: none)
    abs_tol : float   absolute tolerance [unit] (NaN: none); both given: either suffices
    """

    name: str
    value: float
    unit: str = ''
    ci95: float = math.nan
    configured: float = math.nan
    rel_tol: float = math.nan
    abs_tol: float = math.nan

    @property
    def error(self) -> float:
        """``value - configured`` [unit] (NaN without a configured value)."""
        return self.value - self.configured

    @property
    def relative_error(self) -> float:
        """``(value - configured) / |configured|`` (NaN without one, inf for a configured 0)."""
        if not math.isfinite(self.configured):
            return math.nan
        if self.configured == 0.0:
            return math.inf if self.value != 0.0 else 0.0
        return self.error / abs(self.configured)

    def within_tolerance(self) -> bool:
        """True when the configured value is known and ``value`` lies within a tolerance."""
        if not math.isfinite(self.configured):
            return False
        ok_rel = math.isfinite(self.rel_tol) and abs(self.relative_error) <= self.rel_tol
        ok_abs = math.isfinite(self.abs_tol) and abs(self.error) <= self.abs_tol
        return ok_rel or ok_abs


def _num(v: float) -> str:
    return '-' if not math.isfinite(v) else f'{v:.4g}'


def format_report(title: str, estimates) -> str:
    """A fixed-width table: name, identified, the half-width of its 95 % confidence interval (in
    the unit of the value), configured, error, tolerance, verdict.
    """
    lines = [title, f'{"parameter":28s} {"identified":>12s} {"+- CI95":>9s} {"configured":>11s} '
             f'{"error":>8s} {"tolerance":>10s}  unit']
    for e in estimates:
        rel = e.relative_error
        err = '-' if not math.isfinite(rel) else f'{100 * rel:+.1f}%'
        tol = (f'{100 * e.rel_tol:.0f}%' if math.isfinite(e.rel_tol)
               else _num(e.abs_tol) if math.isfinite(e.abs_tol) else '-')
        verdict = '' if not math.isfinite(e.configured) else (
            '  ok' if e.within_tolerance() else '  OUTSIDE')
        lines.append(f'{e.name:28s} {_num(e.value):>12s} {_num(e.ci95):>9s} '
                     f'{_num(e.configured):>11s} {err:>8s} {tol:>10s}  {e.unit}{verdict}')
    return '\n'.join(lines)
