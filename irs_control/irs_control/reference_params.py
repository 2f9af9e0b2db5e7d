"""Parameters of the ``reference_generator`` node and the signal they describe (no rclpy).

Shared by the node and the offline closed loop, so both build the same reference.
"""
from irs_common.params import Param, core_values, node_only
from irs_common.start_gate import START_SUBSCRIBERS
from irs_models.constants import BELT_HALF_WIDTH

from .reference import CONSOLE_LIMIT, from_dict


_FIELDS = {'constant': ('offset',), 'step': ('amplitude', 'start_time', 'offset'),
           'square': ('amplitude', 'period', 'offset', 'start_time'),
           'sine': ('amplitude', 'period', 'offset', 'start_time'),
           'schedule': ('times', 'values', 'offset'),
           'chirp': ('amplitude', 'f0', 'f1', 'sweep_time', 'start_time', 'offset')}


def _signal_type(value):
    return None if value in _FIELDS else \
        f"expected one of {', '.join(sorted(_FIELDS))}, got {value!r}"


def signal_params(unit: str, limit: float, default_type: str = 'step',
                  amplitude: float = 0.1, start_time: float = 1.0) -> list:
    """The ``signal.*`` parameters (all writable) of a node that publishes a :mod:`.reference`.

    ``unit`` is the unit of the signal's values (``amplitude``, ``offset``, ``values``),
    ``limit`` the largest magnitude accepted for each of them. Shared by ``reference_generator``
    (m) and ``irs_bringup``'s ``excitation`` node (rad or V).
    """
    return [
        Param('signal.type', default_type, f'one of {", ".join(sorted(_FIELDS))}', '-',
              writable=True, validator=_signal_type),
        Param('signal.amplitude', amplitude,
              'amplitude (step height, square/sine/chirp amplitude)', unit, -limit, limit,
              writable=True),
        Param('signal.offset', 0.0, 'offset (value before start_time, before the first schedule '
              'time, after a chirp)', unit, -limit, limit, writable=True),
        Param('signal.start_time', start_time, 'time the signal starts (not schedule)', 's', 0.0,
              1e6, writable=True),
        Param('signal.period', 8.0, 'period of square and sine', 's', 1e-3, 1e6, writable=True),
        Param('signal.times', [0.0], 'schedule: times the values start, strictly increasing (set '
              'times and values together)', 's', 0.0, 1e6, writable=True),
        Param('signal.values', [0.0], 'schedule: one value per time, held until the next time',
              unit, -limit, limit, writable=True),
        Param('signal.f0', 0.1, 'chirp: start frequency (logarithmic sweep)', 'Hz', 1e-4, 1e4,
              writable=True),
        Param('signal.f1', 10.0, 'chirp: end frequency', 'Hz', 1e-4, 1e4, writable=True),
        Param('signal.sweep_time', 60.0, 'chirp: sweep duration from start_time', 's', 1e-3, 1e6,
              writable=True),
    ]


#: The largest lateral reference the generator publishes [m]: the belt's half width (a reference
#: beyond its edge is none for a car on it; the controller's own input limit is 2 m).
REFERENCE_LIMIT = BELT_HALF_WIDTH

# The signal.* parameters are writable: the node rebuilds the signal at once (same time base).
PARAMS = [*signal_params('m', REFERENCE_LIMIT)] + node_only([
    Param('source', 'function',
          "'function' (signal below) or 'console' (console/lateral_position)", '-',
          read_only=True),
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
    Param('rate', 100.0, 'publication rate without sim time (real time; with sim time: one '
          'reference per /clock tick)', 'Hz', 0.1, 10000.0, read_only=True),
]) + [START_SUBSCRIBERS]

def signal_from_params(p: dict):
    """Reference signal from the flat ``signal.*`` parameters.

    Raises ``ValueError`` naming the problem (e.g. a schedule with more times than values).
    """
    kind = p['signal.type']
    if kind not in _FIELDS:
        raise ValueError(f'signal.type must be one of {sorted(_FIELDS)}, got {kind!r}')
    if kind == 'constant':
        return from_dict({'type': 'constant', 'value': p['signal.offset']})
    return from_dict({'type': kind, **{f: p[f'signal.{f}'] for f in _FIELDS[kind]}})


def signal_range(p: dict) -> tuple[float, float]:
    """``(low, high)``: the smallest and largest value the signal of the flat ``signal.*``
    parameters ``p`` can take (constant: the offset; step: offset and offset + amplitude;
    schedule: the offset and the values; square, sine, chirp: offset -+ amplitude).
    """
    kind = p['signal.type']
    offset, amplitude = float(p['signal.offset']), float(p['signal.amplitude'])
    values = [offset]
    if kind == 'step':
        values.append(offset + amplitude)
    elif kind == 'schedule':
        values += [float(v) for v in p['signal.values']]
    elif kind != 'constant':
        values += [offset - abs(amplitude), offset + abs(amplitude)]
    return min(values), max(values)




def reference_problem(values: dict):
    """``None``, or why the generator's signal would leave +-``REFERENCE_LIMIT``."""
    low, high = signal_range(values)
    if low < -REFERENCE_LIMIT or high > REFERENCE_LIMIT:
        return (f"the reference spans [{low:g}, {high:g}] m, beyond the belt's edges at "
                f'+-{REFERENCE_LIMIT:g} m')
    return None


def reference_signal(values: dict):
    """The reference generator's signal from its flat parameters (the node's, or an
    experiment's for the offline twin), missing ones at their defaults.
    """
    return signal_from_params(core_values(PARAMS, values, nested=False))
