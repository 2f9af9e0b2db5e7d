"""Reference (lateral set-point) signals as pure functions of time.

Every signal is a frozen dataclass with ``__call__(t) -> float`` (t in s, value in m) and
``from_dict(spec)`` builds one from a YAML-style mapping, e.g.::

    {type: square, amplitude: 0.1, period: 4.0, offset: 0.0, start_time: 1.0}

Definitions (``t0`` = ``start_time``; before ``t0`` every signal except ``constant``
returns its ``offset``):

* ``constant``: ``r = value``
* ``step``: ``r = offset + amplitude`` for ``t >= t0``
* ``square``: ``r = offset + amplitude`` in the first half of each period after ``t0``,
  ``offset - amplitude`` in the second half (``duty`` changes the first-half fraction)
* ``sine``: ``r = offset + amplitude sin(2 pi (t - t0)/period + phase)``

Console reference (``source: console`` of ``reference_generator``): :func:`console_reference`
screens each value typed at the driver console. A value is accepted when it is a finite number
with ``|value| <= limit`` (default :data:`CONSOLE_LIMIT` = 0.5 m: the belt half width 0.6096 m
less the treadmill safety's 0.10 m edge margin); anything else (NaN, +-inf, 1e308, a value
beyond the belt) is **refused**: the last valid value stays in force and a reason is returned.
Refusing rather than clamping, because an absurd value is a typing or transport error, not a
request to drive to the belt edge. The result is always finite.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ['Constant', 'Step', 'Square', 'Sine', 'from_dict', 'SIGNALS', 'console_reference',
           'CONSOLE_LIMIT']

#: Default bound on a console reference [m] (belt half width 0.6096 m less a 0.10 m margin).
CONSOLE_LIMIT = 0.5


def _finite(name, v):
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        raise ValueError(f"Reference parameter '{name}' must be a finite number; got {v!r}.")


class _FiniteFields:
    """Every field of a signal is a finite number (checked when it is made)."""

    def __post_init__(self):
        for f in fields(self):
            _finite(f.name, getattr(self, f.name))


@dataclass(frozen=True)
class Constant(_FiniteFields):
    """Constant set-point ``value`` [m]."""

    value: float = 0.0

    def __call__(self, t: float) -> float:
        return float(self.value)


@dataclass(frozen=True)
class Step(_FiniteFields):
    """Step of ``amplitude`` [m] at ``start_time`` [s] on top of ``offset`` [m]."""

    amplitude: float = 0.1
    start_time: float = 0.0
    offset: float = 0.0

    def __call__(self, t: float) -> float:
        return float(self.offset + (self.amplitude if t >= self.start_time else 0.0))


@dataclass(frozen=True)
class Square(_FiniteFields):
    """Square wave: ``offset +- amplitude`` [m], ``period`` [s] > 0, ``duty`` in (0, 1)."""

    amplitude: float = 0.1
    period: float = 4.0
    offset: float = 0.0
    start_time: float = 0.0
    duty: float = 0.5

    def __post_init__(self):
        super().__post_init__()
        if self.period <= 0:
            raise ValueError(f'Square wave period must be positive seconds; got {self.period}.')
        if not 0.0 < self.duty < 1.0:
            raise ValueError(f'Square wave duty must be in (0, 1); got {self.duty}.')

    def __call__(self, t: float) -> float:
        if t < self.start_time:
            return float(self.offset)
        phase = ((t - self.start_time) / self.period) % 1.0
        return float(self.offset + (self.amplitude if phase < self.duty else -self.amplitude))


@dataclass(frozen=True)
class Sine(_FiniteFields):
    """Sine ``offset + amplitude sin(2 pi (t - t0)/period + phase)``; period [s], phase [rad]."""

    amplitude: float = 0.1
    period: float = 4.0
    offset: float = 0.0
    start_time: float = 0.0
    phase: float = 0.0

    def __post_init__(self):
        super().__post_init__()
        if self.period <= 0:
            raise ValueError(f'Sine period must be positive seconds; got {self.period}.')

    def __call__(self, t: float) -> float:
        if t < self.start_time:
            return float(self.offset)
        return float(self.offset + self.amplitude * math.sin(
            2.0 * math.pi * (t - self.start_time) / self.period + self.phase))


SIGNALS = {'constant': Constant, 'step': Step, 'square': Square, 'sine': Sine}


def from_dict(spec: dict):
    """Build a reference signal from a mapping with a ``type`` key.

    Raises
    ------
    ValueError
        Unknown type, unknown keys, or invalid values (message names them).
    """
    if not isinstance(spec, dict) or 'type' not in spec:
        raise ValueError(
            f"A reference spec must be a mapping with a 'type' key (one of {sorted(SIGNALS)}); "
            f"got {spec!r}."
        )
    kind = spec['type']
    if kind not in SIGNALS:
        raise ValueError(f'Unknown reference type {kind!r}; expected one of {sorted(SIGNALS)}.')
    cls = SIGNALS[kind]
    allowed = {f.name for f in fields(cls)}
    params = {k: v for k, v in spec.items() if k != 'type'}
    unknown = set(params) - allowed
    if unknown:
        raise ValueError(
            f'Unknown parameter(s) {sorted(unknown)} for reference type {kind!r}; allowed: '
            f'{sorted(allowed)}.'
        )
    return cls(**params)


def console_reference(value, last_valid: float = 0.0, limit: float = CONSOLE_LIMIT):
    """Screen one console reference value [m]; returns ``(reference [m], reason or None)``.

    Accepted (``reason`` None): ``value`` is a finite real number with ``|value| <= limit``; the
    reference is ``float(value)``. Refused: the reference stays ``last_valid`` and ``reason``
    says why; a non-finite ``last_valid`` (or one beyond ``limit``) is replaced by 0 m so that the
    result is always finite and within the limit.

    Parameters
    ----------
    value : float
        The console's value [m] (std_msgs/Float64 ``data``).
    last_valid : float
        The reference in force before this value [m].
    limit : float
        Largest accepted ``|value|`` [m] (> 0).

    Raises
    ------
    ValueError
        ``limit`` not a positive finite number (a configuration error).
    """
    from irs_common.input_checks import abs_limit_problem

    if isinstance(limit, bool) or not isinstance(limit, (int, float)) or \
            not (math.isfinite(limit) and limit > 0):
        raise ValueError(f'The console reference limit must be a positive finite distance in m; '
                         f'got {limit!r}.')
    if abs_limit_problem('last_valid', last_valid, limit) is not None:
        last_valid = 0.0
    problem = abs_limit_problem('console reference', value, limit, 'm')
    if problem is None:
        return float(value), None
    return float(last_valid), f'{problem}: refused, keeping {float(last_valid):.6g} m'
