"""Friction coefficient of the belt surface over its length, its width and time (ROS-free).

The belt's top surface moves in -x at the belt speed; a patch painted (or wetted) on the belt
moves with it, but the simulator's surfaces are given in the **treadmill frame** (the frame the
car stays in): a wet patch at ``x in [x_start, x_end]`` is the stretch of the treadmill bed under
which the belt's surface is wet, e.g. a water spray bar, so a car held in place by the regulator
stays on it.  That is what a lab can build quickly and what "the roadway can be varied quickly"
means here (paper sec. 2).  Kinds (``mu(x, y, t)`` [-] at a tyre's contact point ``(x, y)`` [m],
time ``t`` [s])::

    uniform : mu = mu
    patch   : mu = mu_patch  if x_start <= x <= x_end  else mu
    split   : mu = mu_left   if y >= 0                 else mu_right      (split-mu, left/right)
    step    : mu = mu        if t <  t_step            else mu_after      (a step in time)

Default values (used when a key is left out): ``mu = 0.8`` -- assumed, because rubber on a
dry treadmill belt grips like rubber on dry asphalt, whose peak friction Pacejka (2012, sec. 1)
and Rajamani (2012, sec. 13) put at 0.8-1.0 for car tyres; a wet or soaped patch / the low side
of a split-mu: ``0.3`` (wet asphalt to packed snow in the same sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from .tyre import MU_MAX, MU_MIN

__all__ = ['SurfaceSpec', 'SURFACE_KINDS']

#: Accepted kinds and the keys each one reads (besides ``kind``).
SURFACE_KINDS = {
    'uniform': ('mu',),
    'patch': ('mu', 'mu_patch', 'x_start', 'x_end'),
    'split': ('mu_left', 'mu_right'),
    'step': ('mu', 'mu_after', 't_step'),
}


@dataclass(frozen=True)
class SurfaceSpec:
    """A friction map ``mu(x, y, t)`` (module docstring).

    Attributes
    ----------
    kind : str
        ``uniform``, ``patch``, ``split`` or ``step``.
    mu : float
        Base friction [-] (uniform, outside the patch, before the step).
    mu_patch : float
        Friction on the patch [-].
    x_start, x_end : float
        Patch extent along the treadmill x [m], ``x_start < x_end``.
    mu_left, mu_right : float
        Split-mu frictions for ``y >= 0`` (left) and ``y < 0`` (right) [-].
    mu_after : float
        Friction after the step [-].
    t_step : float
        Time of the step [s].
    """

    kind: str = 'uniform'
    mu: float = 0.8
    mu_patch: float = 0.3
    x_start: float = -0.3
    x_end: float = 0.3
    mu_left: float = 0.8
    mu_right: float = 0.3
    mu_after: float = 0.3
    t_step: float = 1.0

    def __post_init__(self):
        if self.kind not in SURFACE_KINDS:
            raise ValueError(f'surface kind must be one of {sorted(SURFACE_KINDS)}, '
                             f'got {self.kind!r}.')
        for f in fields(self):
            if f.name == 'kind':
                continue
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f'surface.{f.name} must be a finite number, got {v!r}.')
            if f.name.startswith('mu') and not MU_MIN <= v <= MU_MAX:
                raise ValueError(f'surface.{f.name} must be a friction coefficient in '
                                 f'[{MU_MIN}, {MU_MAX}], got {v!r}.')
        if self.kind == 'patch' and not self.x_start < self.x_end:
            raise ValueError(f'surface patch needs x_start < x_end [m], got '
                             f'{self.x_start!r} and {self.x_end!r}.')

    @classmethod
    def from_dict(cls, d) -> 'SurfaceSpec':
        """Build from e.g. ``{'kind': 'split', 'mu_left': 0.8, 'mu_right': 0.3}``.

        Keys the kind does not read are refused (a typo must not silently give the default).
        """
        if d is None:
            return cls()
        if not isinstance(d, dict):
            raise ValueError(f'surface must be a mapping with a kind, got {type(d).__name__}.')
        kind = d.get('kind', 'uniform')
        if kind not in SURFACE_KINDS:
            raise ValueError(f'surface kind must be one of {sorted(SURFACE_KINDS)}, '
                             f'got {kind!r}.')
        extra = sorted(set(d) - {'kind'} - set(SURFACE_KINDS[kind]))
        if extra:
            raise ValueError(f'surface kind {kind!r} reads only {list(SURFACE_KINDS[kind])}, '
                             f'got also {extra}.')
        return cls(**d)

    def mu_at(self, x: float, y: float, t: float) -> float:
        """Friction coefficient [-] at treadmill position (x, y) [m] and time t [s]."""
        k = self.kind
        if k == 'uniform':
            return self.mu
        if k == 'patch':
            return self.mu_patch if self.x_start <= x <= self.x_end else self.mu
        if k == 'split':
            return self.mu_left if y >= 0.0 else self.mu_right
        return self.mu if t < self.t_step else self.mu_after

    def _frictions(self) -> list:
        return [getattr(self, k) for k in SURFACE_KINDS[self.kind] if k.startswith('mu')]

    @property
    def mu_max(self) -> float:
        """Largest friction coefficient anywhere on this surface [-]."""
        return max(self._frictions())

    @property
    def mu_min(self) -> float:
        """Smallest friction coefficient anywhere on this surface [-]."""
        return min(self._frictions())
