"""Parameters of the ``reference_generator`` node and the signal they describe (no rclpy).

Shared by the node and the offline closed loop, so both build the same reference.
"""
from irs_common.params import Param

from .reference import CONSOLE_LIMIT, from_dict


def _signal_type(value):
    return None if value in _FIELDS else f'expected one of {sorted(_FIELDS)}'


# The signal.* parameters are writable: the node rebuilds the signal at once (same time base).
PARAMS = [
    Param('source', 'function',
          "'function' (signal below) or 'console' (console/lateral_position)", '-',
          read_only=True),
    Param('signal.type', 'step', "'constant', 'step', 'square' or 'sine'", '-', writable=True,
          validator=_signal_type),
    Param('signal.amplitude', 0.1, 'amplitude (step height, square/sine amplitude)', 'm', -1.0,
          1.0, writable=True),
    Param('signal.offset', 0.0, 'offset (value before start_time)', 'm', -1.0, 1.0, writable=True),
    Param('signal.start_time', 1.0, 'time the signal starts', 's', 0.0, 1e6, writable=True),
    Param('signal.period', 8.0, 'period of square and sine', 's', 1e-3, 1e6, writable=True),
    Param(
        'console_limit',
        CONSOLE_LIMIT,
        "source 'console': values beyond +-this (and NaN, inf) "
        'are refused and the last valid reference is held',
        'm',
        1e-6,
        1.0,
        read_only=True,
    ),
    Param('rate', 1000.0, 'publication rate without sim time', 'Hz', 0.1, 10000.0, read_only=True),
]

_FIELDS = {'constant': ('offset',), 'step': ('amplitude', 'start_time', 'offset'),
           'square': ('amplitude', 'period', 'offset', 'start_time'),
           'sine': ('amplitude', 'period', 'offset', 'start_time')}


def signal_from_params(p: dict):
    """Reference signal from the flat ``signal.*`` parameters."""
    kind = p['signal.type']
    if kind not in _FIELDS:
        raise ValueError(f'signal.type must be one of {sorted(_FIELDS)}, got {kind!r}')
    if kind == 'constant':
        return from_dict({'type': 'constant', 'value': p['signal.offset']})
    return from_dict({'type': kind, **{f: p[f'signal.{f}'] for f in _FIELDS[kind]}})
