"""Reference (lateral set-point) signals as pure functions of time.

Every signal is a frozen dataclass with ``__call__(t) -> float`` (t in s, value in m) and
``from_dict(spec)`` builds one from a YAML-style mapping, e.g.::

    {type: square, amplitude: 0.1, period: 4.0, offset: 0.0, start_time: 1.0}

Signals: ``constant``, ``step``, ``square``, ``sine``, ``schedule`` (piecewise constant) and
``chirp`` (logarithmic swept sine, ``scipy.signal.chirp``); their definitions are in
:func:`from_dict`. ``schedule`` and ``chirp`` also serve as system-identification excitations
(in V or rad for the ``excitation`` node). :func:`console_reference` screens values typed at the
driver console (finite and within 0.5 m, else refused). They exist so that the reference
generator, the offline twin and the studies evaluate the very same set point at the same time.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, fields

import numpy as np

__all__ = ['Constant', 'Step', 'Square', 'Sine', 'Schedule', 'Chirp', 'from_dict', 'SIGNALS',
           'console_reference', 'CONSOLE_LIMIT']

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


def _finite_sequence(name, seq) -> tuple:
    if isinstance(seq, (str, bytes)) or not hasattr(seq, '__iter__'):
        raise ValueError(f"Reference parameter '{name}' must be a list of finite numbers; "
                         f'got {seq!r}.')
    seq = tuple(seq)
    if not seq:
        raise ValueError(f"Reference parameter '{name}' must not be empty.")
    for v in seq:
        _finite(name, v)
    return tuple(float(v) for v in seq)


@dataclass(frozen=True)
class Schedule:
    """Piecewise constant: ``values[i]`` from ``times[i]`` [s] on, ``offset`` before ``times[0]``.

    ``times`` strictly increasing, one per value; the last value holds after the last time.
    """

    times: tuple = (0.0,)
    values: tuple = (0.0,)
    offset: float = 0.0

    def __post_init__(self):
        times = _finite_sequence('times', self.times)
        values = _finite_sequence('values', self.values)
        _finite('offset', self.offset)
        if len(times) != len(values):
            raise ValueError(f'Schedule needs one value per time; got {len(times)} times and '
                             f'{len(values)} values.')
        if any(b <= a for a, b in zip(times, times[1:])):
            raise ValueError(f'Schedule times must be strictly increasing seconds; got '
                             f'{list(times)}.')
        object.__setattr__(self, 'times', times)
        object.__setattr__(self, 'values', values)

    def __call__(self, t: float) -> float:
        i = bisect.bisect_right(self.times, t) - 1
        return float(self.offset if i < 0 else self.values[i])


@dataclass(frozen=True)
class Chirp(_FiniteFields):
    """Logarithmic swept sine ``f0`` -> ``f1`` [Hz] over ``sweep_time`` [s] from ``start_time``.

    ``offset + amplitude sin(phi(t - start_time))`` during the sweep (``phi`` in the module
    docstring, from :func:`scipy.signal.chirp`), ``offset`` before and after it.
    """

    amplitude: float = 0.1
    f0: float = 0.1
    f1: float = 10.0
    sweep_time: float = 60.0
    start_time: float = 0.0
    offset: float = 0.0

    def __post_init__(self):
        super().__post_init__()
        if self.f0 <= 0 or self.f1 <= 0:
            raise ValueError(f'Chirp frequencies f0 and f1 must be positive Hz (a logarithmic '
                             f'sweep); got f0={self.f0}, f1={self.f1}.')
        if self.sweep_time <= 0:
            raise ValueError(f'Chirp sweep_time must be positive seconds; got {self.sweep_time}.')

    def frequency(self, t: float) -> float:
        """Instantaneous frequency [Hz] at ``t`` [s] (NaN outside the sweep)."""
        tau = t - self.start_time
        if not 0.0 <= tau <= self.sweep_time:
            return math.nan
        return float(self.f0 * (self.f1 / self.f0) ** (tau / self.sweep_time))

    def __call__(self, t: float) -> float:
        tau = t - self.start_time
        if not 0.0 <= tau <= self.sweep_time:
            return float(self.offset)
        if self.f0 == self.f1:        # scipy's logarithmic formula divides by ln(f1/f0)
            return float(self.offset + self.amplitude * math.sin(2.0 * math.pi * self.f0 * tau))
        # imported here: scipy.signal costs 0.7 s of CPU at a node's start, and only chirps need it
        from scipy.signal import chirp as scipy_chirp
        wave = scipy_chirp(np.float64(tau), self.f0, self.sweep_time, self.f1,
                           method='logarithmic', phi=-90.0)
        return float(self.offset + self.amplitude * wave)


SIGNALS = {'constant': Constant, 'step': Step, 'square': Square, 'sine': Sine,
           'schedule': Schedule, 'chirp': Chirp}


def from_dict(spec: dict):
    """Build a reference signal from a mapping with a ``type`` key.

    Definitions (``t0`` = ``start_time``; before ``t0`` every signal except ``constant`` returns
    its ``offset``):

    * ``constant``: ``r = value``
    * ``step``: ``r = offset + amplitude`` for ``t >= t0``
    * ``square``: ``r = offset + amplitude`` in the first half of each period after ``t0``,
      ``offset - amplitude`` in the second half (``duty`` changes the first-half fraction)
    * ``sine``: ``r = offset + amplitude sin(2 pi (t - t0)/period + phase)``
    * ``schedule``: piecewise constant: ``r = values[i]`` for ``times[i] <= t < times[i+1]`` (the
      last value holds for ever), ``offset`` before ``times[0]``; ``times`` [s] strictly
      increasing, as many as ``values``
    * ``chirp``: logarithmic swept sine from ``f0`` to ``f1`` [Hz] over ``sweep_time`` [s]: ``r =
      offset + amplitude sin(phi(t - t0))`` for ``t0 <= t <= t0 + sweep_time`` with ``phi(tau) = 2
      pi f0 T/ln(f1/f0) ((f1/f0)^(tau/T) - 1)``, ``T`` = ``sweep_time`` (``scipy.signal.chirp``,
      ``method='logarithmic'``, ``phi=-90`` degrees so it starts at 0 with a positive slope);
      ``offset`` before and after the sweep

    ``schedule`` and ``chirp`` are system-identification excitations (voltage steps of the paper's
    Fig. 5, the swept sines of its Fig. 6 and 8); their values are in the unit of whatever they
    drive (m for the lateral reference, V or rad for ``irs_bringup``'s ``excitation`` node).

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

    Used by ``source: console`` of ``reference_generator``; it screens each value typed at the
    driver console. A value is accepted when it is a finite number with ``|value| <= limit``
    (default :data:`CONSOLE_LIMIT` = 0.5 m: the belt half width 0.6096 m less the treadmill
    safety's 0.10 m edge margin); anything else (NaN, +-inf, 1e308, a value beyond the belt) is
    **refused**: the last valid value stays in force and a reason is returned. Refusing rather than
    clamping, because an absurd value is a typing or transport error, not a request to drive to the
    belt edge. The result is always finite.

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
