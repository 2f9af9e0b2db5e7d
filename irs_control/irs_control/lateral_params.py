"""Parameter table of the ``lateral_controller`` node (no rclpy).

The design and control-law parameters take their defaults from
:data:`~irs_control.controller_factory.CONTROLLER_DEFAULTS`, so the table cannot drift from the
core; the node's own parameters (stale timeout, reference pairing, status rate) are marked
``node_only``: the offline twin of the graph leaves them out.
"""
from irs_common.params import Param, core_values, node_only
from irs_common.start_gate import START_SUBSCRIBERS
from irs_models.constants import STEER_LIMIT

from .controller_factory import CONTROLLER_DEFAULTS
from .discrete_rst import anti_windup_mode

D = CONTROLLER_DEFAULTS


def _anti_windup_problem(value):
    try:
        anti_windup_mode(value)
    except ValueError as exc:
        return str(exc)
    return None


#: The control laws of ``mode``.
MODES = ('mrc', 'pi')


def _mode_problem(value):
    return None if value in MODES else f"expected one of {', '.join(MODES)}, got {value!r}"


PARAMS = [
    Param(
        'mode', D['mode'], "control law: 'mrc' (RST model reference) or 'pi'", '-', read_only=True,
        validator=_mode_problem,
    ),
    Param('dt', D['dt'], 'controller period = measurement period', 's', 1e-5, 1.0, read_only=True),
    Param('plant', D['plant'], "design plant: 'identified' (paper Eq. 6), a vehicle preset name "
          "or 'custom' (plant_num/plant_den)", '-', read_only=True),
    Param('speed', D['speed'], 'forward speed the design assumes (presets only)', 'm/s', 0.01,
          50.0, read_only=True),
    Param('ds', D['ds'], 'sensor distance ahead of the c.g. the design assumes (presets only)',
          'm', 0.0, 10.0, read_only=True),
    Param(
        'plant_gain',
        D['plant_gain'],
        'high-frequency gain b0 of the identified plant with '
        'actuator; 0 = paper reconstruction 363.394',
        'm/(rad s^3)',
        0.0,
        1e9,
        read_only=True,
    ),
    Param('plant_num', D['plant_num'], "plant 'custom': vehicle numerator (steer -> y_s, "
          'without the actuator lag), highest power first', 'm/(rad s^k)', read_only=True),
    Param('plant_den', D['plant_den'], "plant 'custom': vehicle denominator, monic, highest "
          'power first', '1/s^k', read_only=True),
    Param('include_actuator', D['include_actuator'], 'design with the actuator lag in the plant',
          '-', read_only=True),
    Param('actuator_pole', D['actuator_pole'], 'actuator lag pole magnitude (4.6 Hz ~ 29)',
          'rad/s', 0.01, 1e4, read_only=True),
    Param('reference_model_num', D['reference_model_num'],
          'reference model Bm(s), highest power first (paper Eq. 21)', '1/s^k', read_only=True),
    Param('reference_model_den', D['reference_model_den'],
          'reference model Am(s), monic, highest power first (paper Eq. 21)', '1/s^k',
          read_only=True),
    Param(
        'observer',
        D['observer'],
        'observer polynomial Ao(s), highest power first; [0.0] = '
        'paper choice ((s+12)^2 with actuator, s+12 without)',
        '1/s^k',
        read_only=True,
    ),
    Param('cancel_zeros', D['cancel_zeros'], "plant zeros to cancel: 'stable' or 'none'", '-',
          read_only=True),
    Param('kp', D['kp'], 'PI proportional gain', 'rad/m', 0.0, 1e6, read_only=True),
    Param('ki', D['ki'], 'PI integral gain', 'rad/(m s)', 0.0, 1e6, read_only=True),
    Param('steer_limit', D['steer_limit'], "steer command limit (at most the servo's 15 deg)",
          'rad', 0.0, STEER_LIMIT, read_only=True),
    Param('anti_windup', D['anti_windup'],
          "anti-windup (the paper describes none): 'back_calculation' (controller state driven "
          "by the applied, saturated steer; RST: Astrom-Wittenmark polynomial form, PI: tracking "
          "time kp/ki) or 'clip' (no anti-windup, the output only is clipped)", '-',
          validator=_anti_windup_problem),
    Param('check_plant', D['check_plant'],
          "plant model the design is checked against at start-up (closed-loop poles, margins; "
          "with the actuator lag): 'identified' (paper Eq. 6, the rig's default plant) or a "
          'vehicle preset name (at speed and ds)', '-'),
    Param('check_delay', D['check_delay'],
          'transport delay of the steer in the start-up check (the rig: 17 ms mean); a design '
          'with a negative delay margin is refused', 's', 0.0, 1.0, read_only=True),
    Param('allow_unstable_design', D['allow_unstable_design'],
          'start even when the design is unstable on check_plant (a warning instead of the '
          'refusal)', '-'),
]

#: The node's own parameters: its input timing, reference pairing and status rate.
PARAMS += node_only([
    Param(
        'stale_timeout',
        0.05,
        'measurement age after which zero steer is commanded (and the '
        'controller restarts from rest)',
        's',
        0.001,
        10.0,
        writable=True,
    ),
    Param('reference_sync', False,
          'pair each measurement with the reference of the same stamp (lock-step runs)', '-',
          read_only=True),
    Param(
        'default_reference',
        0.0,
        'reference used until one arrives (set at run time: used at '
        'once, until the next lateral/reference message; not with reference_sync)',
        'm',
        -1.0,
        1.0,
        writable=True,
    ),
    Param('future_tolerance', 0.5, 'inputs stamped further ahead of the node clock are dropped',
          's', 0.0, 3600.0, read_only=True),
    Param(
        'status_decimation',
        10,
        'publish lateral/status every this many steps (and on a state '
        'change); 0 = on state changes only',
        '1',
        0,
        1_000_000,
        read_only=True,
    ),
]) + [START_SUBSCRIBERS]


def controller_config(values: dict) -> dict:
    """The design parameters :func:`~irs_control.controller_factory.make_controller` takes, from
    the node's flat parameters (the node's, or an experiment's for the offline twin).
    """
    return core_values(PARAMS, values)
