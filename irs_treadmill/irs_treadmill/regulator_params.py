"""Parameter table of the ``treadmill_regulator`` node (defaults from the cores, units here)."""
from dataclasses import asdict, dataclass
import math

from irs_common.params import Param, core_values, flatten, node_only, table_from_defaults
from irs_common.start_gate import START_SUBSCRIBERS
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .regulator import RegulatorParams
from .safety import SafetyParams

INF = math.inf
#: The belt's top speed (15 mph) [m/s] and the drive voltage that reaches it [V].
V_TOP = RegulatorParams().v_top
U_MAX = RegulatorParams().u_max
#: Ranges: finite bounds on every gain (docs/treadmill.md, "Parameter bounds"): the position
#: loop is kept well below the 1 kHz sample rate and the 0.05 s drive delay (k_x <= 50 1/s;
#: the default 2 1/s gives poles at -3 and -6 1/s), the drive within the belt's range
#: (u_max <= 12.7 V, the belt's 15 mph), speeds within the belt's top speed.
_META = {
    'regulator.x_ref': ('m', -BELT_HALF_LENGTH, BELT_HALF_LENGTH,
                        'longitudinal set point of the car c.g. on the belt'),
    'regulator.k_x': ('1/s', 0.0, 50.0, 'position gain (outer loop)'),
    'regulator.k_i': ('1/s^2', 0.0, 50.0, 'position integral gain (conditional integration)'),
    'regulator.integral_limit': ('m/s', 0.0, V_TOP,
                                 'bound on k_i times the integral of the position error'),
    'regulator.k_v': ('1', 0.0, 100.0,
                      'inner belt-speed proportional gain relative to the feed-forward'),
    'regulator.belt_gain': ('m/s/V', 0.01, 10.0,
                            'belt DC gain 2.38/4.5 (paper Eq. 2) for the feed-forward'),
    'regulator.u_max': ('V', 0.0, U_MAX,
                        'drive voltage upper limit (lower limit 0 V: no reversing; at most the '
                        "belt drive's 12.7 V)"),
    'regulator.slew_rate': ('V/s', 0.0, 1e4, 'drive voltage slew limit'),
    'regulator.v_top': ('m/s', 0.0, V_TOP, 'belt top speed (15 mph)'),
    'regulator.xdot_cutoff_hz': ('Hz', 0.0, 500.0,
                                 'cut-off of the internal car-velocity filter (below the 500 Hz '
                                 'Nyquist frequency of the 1 kHz loop)'),
    'safety.belt_half_length': ('m', 0.0, BELT_HALF_LENGTH, 'half of the belt length'),
    'safety.belt_half_width': ('m', 0.0, BELT_HALF_WIDTH, 'half of the belt width'),
    'safety.end_margin': ('m', 0.0, BELT_HALF_LENGTH,
                          'fault when the c.g. is closer than this to a belt end'),
    'safety.edge_margin': ('m', 0.0, BELT_HALF_WIDTH,
                           'fault when the c.g. is closer than this to a belt edge'),
    'safety.stop_decel': ('m/s^2', 0.01, 100.0,
                          "deceleration of the car over the ground in the rig's stop, for the "
                          'end check of a moving car'),
    'safety.stop_delay': ('s', 0.0, 10.0,
                          "time before the rig's stop acts, for the end check of a moving car"),
    'safety.stale_timeout': ('s', 0.0, 10.0, 'fault when no valid position for this long (the '
                             'grace of a stalled pose input: the last drive stays in effect)'),
}
NODE = [
    Param('rate_hz', 1000.0, 'control rate = pose rate', 'Hz', 1.0, 100000.0, read_only=True,
          realtime_default=100.0),    # one step per pose at the estimator's pose_decimation
    Param(
        'use_velocity_input',
        True,
        "feed the estimator's car velocity (topic velocity) forward "
        'instead of the internal filter',
        '-',
        read_only=True,
    ),
    Param('enabled', True, 'regulate (false: drive held at 0 V, belt coasts)', '-', writable=True),
]
#: The node's own parameters: input pairing, stamp tolerance, status rate.
NODE += node_only([
    Param(
        'sync_belt_speed',
        True,
        'pair each pose with the belt speed of the same stamp (lock-step '
        'and rig-synchronous sampling); false: latest belt speed',
        '-',
        read_only=True,
        realtime_default=False,       # belt speed and pose come at their own times
    ),
    Param('future_tolerance', 0.5, 'poses stamped further ahead of the node clock are dropped',
          's', 0.0, 3600.0, read_only=True),
    Param(
        'state_decimation',
        10,
        'publish treadmill/state every this many steps (and on a mode '
        'change); 0 = on mode changes only',
        '1',
        0,
        1_000_000,
        read_only=True,
    ),
]) + [START_SUBSCRIBERS]


#: Regulator parameters the node applies while running (``ros2 param set``).
WRITABLE = ('regulator.x_ref', 'regulator.k_x', 'regulator.k_i', 'regulator.k_v',
            'regulator.integral_limit')


def _positive(v):
    return None if v > 0 else 'must be > 0'


def regulator_parameter_table() -> list:
    defaults = flatten({'regulator': asdict(RegulatorParams()), 'safety': asdict(SafetyParams())})
    return NODE + table_from_defaults(defaults, _META, writable=WRITABLE,
                                      validators={'regulator.k_x': _positive})


@dataclass(frozen=True)
class RegulatorConfig:
    """What the regulator's cores take: the regulator, the safety monitor and how they run."""

    regulator: RegulatorParams
    safety: SafetyParams
    rate_hz: float                  # [Hz] control rate = pose rate
    use_velocity_input: bool        # feed the estimator's velocity forward (else a filter)
    enabled: bool                   # regulate (false: 0 V, the belt coasts)


def regulator_config(values: dict) -> RegulatorConfig:
    """The cores' configuration from the node's flat parameters (the node's, or an
    experiment's for the offline twin).
    """
    nested = core_values(regulator_parameter_table(), values)
    return RegulatorConfig(RegulatorParams.from_dict(nested['regulator']),
                           SafetyParams.from_dict(nested['safety']), nested['rate_hz'],
                           nested['use_velocity_input'], nested['enabled'])
