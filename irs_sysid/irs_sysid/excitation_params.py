"""Parameters of the ``excitation`` node (no rclpy): what it drives, the signal, the limit.

The signal is one of :mod:`irs_control.reference`'s (``schedule`` for the paper's voltage steps
of Fig. 5, ``chirp`` for the swept sines of Fig. 6 and 8, ``step``, ``square``, ``sine``,
``constant``), in the unit of the target: rad of front steer angle or V of belt drive.

Limits: ``limit`` never exceeds the target's own (the servo's ``STEER_LIMIT`` = 15 deg at the
wheel, the drive's ``[0, u_max]`` = [0, 12.7] V), and the signal's whole range (offset,
offset + amplitude, +-amplitude around the offset, the schedule's values) lies within the
output bounds: :func:`excitation_problem` refuses the rest, at start-up and for every
``ros2 param set``.
"""
from __future__ import annotations

import math

from irs_common.params import Param
from irs_common.start_gate import START_SUBSCRIBERS
from irs_control.reference_params import signal_from_params, signal_params, signal_range
from irs_models.constants import STEER_LIMIT

#: ``target`` -> (topic, unit, the default limit): the steer limit of the rig's servos
#: (irs_models.constants, 15 deg) and the belt drive's voltage range (rig.yaml ``belt.u_max``).
TARGETS = {'steering': ('steering/command', 'rad', STEER_LIMIT),
           'drive': ('treadmill/drive', 'V', 12.7)}


def _target(value):
    return None if value in TARGETS else f'expected one of {sorted(TARGETS)}'


PARAMS = [
    Param('target', 'steering', "'steering' (steering/command front_angle, rear 0 rad) or "
          "'drive' (treadmill/drive voltage)", '-', read_only=True, validator=_target),
    Param('limit', 0.0, "output clipped to +-limit (steering) or [0, limit] (drive, which "
          "cannot reverse); 0 = the target's own: 0.2618 rad or 12.7 V, never more", 'rad | V',
          0.0, 12.7, read_only=True),
    *signal_params('rad | V', 12.7, default_type='schedule', amplitude=0.0, start_time=0.0),
    Param('rate', 1000.0, 'publication rate without sim time', 'Hz', 0.1, 10000.0,
          read_only=True),
    START_SUBSCRIBERS,
]


def output_limit(p: dict) -> tuple[float, float]:
    """``(low, high)`` bounds of the published value from ``target`` and ``limit`` (never
    beyond the target's own limit).
    """
    own = TARGETS[p['target']][2]
    limit = min(p['limit'], own) if p['limit'] > 0.0 else own
    return (0.0, limit) if p['target'] == 'drive' else (-limit, limit)


def excitation_problem(p: dict):
    """``None``, or the sentence that says why ``p``'s limit or signal exceeds the target's."""
    target = p['target']
    if target not in TARGETS:
        return f'target must be one of {sorted(TARGETS)}, got {target!r}'
    topic, unit, own = TARGETS[target]
    if p['limit'] > own:
        return (f'limit {p["limit"]:g} {unit} exceeds the limit of {topic} ({own:g} {unit})')
    low, high = signal_range(p)
    bounds = output_limit(p)
    if low < bounds[0] or high > bounds[1]:
        return (f'the signal spans [{low:g}, {high:g}] {unit}, beyond the output bounds '
                f'[{bounds[0]:g}, {bounds[1]:g}] {unit} of {topic}')
    return None


def excitation_value(signal, t: float, bounds: tuple[float, float]) -> float:
    """The signal at ``t`` [s] clipped to ``bounds``; a non-finite value gives the safe 0."""
    v = float(signal(t))
    if not math.isfinite(v):
        return 0.0
    return min(bounds[1], max(bounds[0], v))


__all__ = ['PARAMS', 'TARGETS', 'output_limit', 'excitation_value', 'excitation_problem',
           'signal_range', 'signal_from_params']
