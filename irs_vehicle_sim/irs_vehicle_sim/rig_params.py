"""Parameter table of the ``vehicle_sim`` node: name, default, unit, range, description.

Defaults are taken from the core dataclasses (:class:`~irs_vehicle_sim.rig.RigConfig` and its
sections), so this table cannot drift from the code; units and descriptions live here, once.
The node declares every entry with a descriptor; ``RigConfig.from_dict`` takes the values.
"""
import math
from dataclasses import asdict

from irs_common.params import Param, core_values, node_only, table_from_defaults
from irs_common.start_gate import start_subscribers_problem
from irs_models.arm_kinematics import ArmGeometry
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .actuator import ActuatorParams
from .arm_sensor import ArmSensorParams
from .belt import BeltParams
from .car_on_belt import CarParams
from .rig import PLANTS, RigConfig, _bicycle_defaults
from .rig_torque_car import encoder_defaults, surface_defaults, two_track_defaults
from .surface import SURFACE_KINDS
from .tyre import MU_MAX, MU_MIN

INF = math.inf

# name: (unit, low, high, description)
_RIG = {
    'dt': ('s', 1e-5, 0.05, 'fixed simulation step (1 kHz default)'),
    'seed': ('1', 0, 2**31 - 1,
             "seed of the arm-sensor noise and of the steering radio frames' phases"),
    'plant': ('-', None, None,
              "plant: 'identified' (paper Eq. 6), 'bicycle' (physical preset) or 'two_track' "
              '(the torque car: wheel torques in, encoders out; the driver speed is ignored)'),
    'ds': ('m', 0.0, 5.0, 'sensor point ahead of the c.g. (paper: 0.33 m)'),
    'steer_reject': ('rad', 0.0, math.pi, '|steer command| above this is rejected and 0 rad used'),
    'speed_cmd_max': ('m/s', 0.0, 20.0, 'driver speed commands outside [0, this] are rejected'),
    'x0': ('m', -BELT_HALF_LENGTH, BELT_HALF_LENGTH, 'initial c.g. x in the treadmill frame'),
    'y0': ('m', -BELT_HALF_WIDTH, BELT_HALF_WIDTH, 'initial c.g. y in the treadmill frame'),
    'u0': ('m/s', 0.0, 20.0,
           'initial car speed over the belt (and the driver command until one arrives)'),
    'belt_speed0': ('m/s', 0.0, 6.7056, 'initial belt speed'),
}
_ACT = {
    'lag_hz': ('Hz', 0.01, 1000.0,
               "bandwidth K/(2 pi) of the servo's proportional loop (4.4 Hz: fits of 4.6 Hz at "
               '5-8 deg)'),
    'rate_limit': ('rad/s', 0.0, INF,
                   'slew limit of the servo horn (at the wheel: rate_limit / gear_ratio)'),
    'delay': ('s', 0.0, 1.0,
              'mean transport delay of the command (frame off: a FIFO quantised to dt)'),
    'backlash': ('rad', 0.0, 0.1, 'total width of the steering backlash (0.175 deg default)'),
    'limit': ('rad', 0.0, math.pi / 2, 'hard limit of the steer angle at the wheel (15 deg)'),
    'enable_lag': ('-', None, None, 'simulate the servo loop (off: the horn jumps to its target)'),
    'enable_rate_limit': ('-', None, None, 'simulate the rate limit'),
    'enable_delay': ('-', None, None, 'simulate the transport delay (and the radio frame)'),
    'enable_backlash': ('-', None, None, 'simulate the backlash'),
    'enable_saturation': ('-', None, None, 'simulate the saturation and the end stops'),
    'gear_ratio': ('rad/rad', 0.01, 100.0,
                   "servo-horn angle per steer angle at the centre (the paper's reference gain)"),
    'friction_deadband': ('rad', 0.0, 0.5,
                          'half-width of the servo dead zone in horn angle (linkage friction)'),
    'min_drive': ('rad/s', 0.0, INF,
                  "horn speed just outside the dead zone (the amplifier's minimum drive; "
                  '0 = none)'),
    'radio_frame': ('s', 0.0, 1.0, "period of the transmitter's frame (sample and hold)"),
    'enable_friction': ('-', None, None, 'simulate the friction dead zone of the servo loop'),
    'enable_linkage_geometry': ('-', None, None,
                                'wheel = asin(sin(horn) / gear_ratio) (off: horn / gear_ratio)'),
    'enable_linkage_compensation': ('-', None, None,
                                    'horn reference asin(gear_ratio sin(u)): the wheel holds the '
                                    'command, the limit holds at the wheel (off: gear_ratio u)'),
    'enable_radio_frame': ('-', None, None,
                           'sample and hold the command once a radio frame, random phase '
                           '(seeded by seed)'),
}
_IDENT = {
    'gain': ('m/s^2/rad', 0.0, INF, 'K of the identified G(s); 0 = paper reconstruction'),
    'speed': ('m/s', 0.01, 20.0, 'identification speed U (heading = v_s / U)'),
    'ds': ('m', -1.0, 5.0, 'sensor distance of the identified model; negative = use ds'),
    'numerator': ('1/s, 1/s^2', -1e6, 1e6,
                  '[n1, n0]: the zeros are the roots of s^2 + n1 s + n0 (real or complex)'),
    'denominator': ('1/s, 1/s^2', -1e6, 1e6,
                    '[d1, d0]: the non-origin poles are the roots of s^2 + d1 s + d0 (stable)'),
    'heading': ('-', None, None,
                "'kinematic' (psi = v_s / U, not physical) or 'bicycle' (psi, r, v of the "
                'bicycle with this G(s); refused if none, as for Eq. 6)'),
}
_BICYCLE = {
    'preset': ('-', None, None,
               "vehicle preset from irs_models/config/presets.yaml; '' = use the fields below"),
    'mass': ('kg', 0.0, INF, 'vehicle mass (preset empty only)'),
    'yaw_inertia': ('kg m^2', 0.0, INF, 'yaw inertia about the c.g. (preset empty only)'),
    'lf': ('m', 0.0, INF, 'c.g. to front axle (preset empty only)'),
    'lr': ('m', 0.0, INF, 'c.g. to rear axle (preset empty only)'),
    'c_f': ('N/rad', 0.0, INF, 'front axle cornering stiffness (preset empty only)'),
    'c_r': ('N/rad', 0.0, INF, 'rear axle cornering stiffness (preset empty only)'),
    'track': ('m', 0.0, INF, 'track width (preset empty only)'),
    'wheel_radius': ('m', 0.0, INF, 'wheel rolling radius (preset empty only)'),
    'speed': ('m/s', 0.01, 20.0, 'forward speed the bicycle model is linearised at'),
}
_CAR = {
    'tau_u': ('s', 0.0, INF, 'time constant of the car speed response to the driver command'),
    'length': ('m', 0.0, 2.0, 'body length (off-belt margin)'),
    'width': ('m', 0.0, 1.0, 'body width (off-belt margin)'),
    'lf': ('m', 0.0, 1.0, 'c.g. to front axle (wheel kinematics)'),
    'lr': ('m', 0.0, 1.0, 'c.g. to rear axle (wheel kinematics)'),
    'track': ('m', 0.0, 1.0, 'track width (wheel kinematics)'),
    'wheel_radius': ('m', 0.0, 1.0, 'wheel rolling radius (wheel kinematics)'),
}
_ARM = {
    'l1': ('m', 0.0, INF, 'arm link 1 length'),
    'l2': ('m', 0.0, INF, 'arm link 2 length'),
    'base_x': ('m', -INF, INF, 'arm base (joint 1) x in the treadmill frame'),
    'base_y': ('m', -INF, INF, 'arm base (joint 1) y in the treadmill frame'),
    'attach_offset': ('m', -1.0, 1.0, 'arm tip attachment ahead of the c.g.'),
    'elbow': ('1', -1, 1, 'inverse-kinematics branch: +1 theta2 in (0, pi), -1 in (-pi, 0)'),
    'noise_std': ('rad', 0.0, 1.0, 'potentiometer noise standard deviation per joint'),
    'enable_noise': ('-', None, None, 'add potentiometer noise'),
    'adc_bits': ('bit', 1, 32, 'ADC resolution'),
    'adc_range': ('rad', 0.0, INF, 'angle spanned by the ADC range'),
    'lsb': ('rad', 0.0, 1.0, 'quantisation step; 0 = adc_range / 2^adc_bits'),
    'enable_quantization': ('-', None, None, 'quantise the angles'),
}
_BELT = {
    'gain': ('m/s^2/V', 0.0, INF, 'belt drive gain (Eq. 2 numerator 2.38)'),
    'pole': ('1/s', 0.0, INF, 'belt drive pole (Eq. 2: 4.5)'),
    'b_over_j': ('1/s', 0.0, INF, 'viscous friction B/J (0.158)'),
    'f_over_b': ('m/s', 0.0, INF, 'sliding/viscous friction ratio F/B (0.270)'),
    'v_top': ('m/s', 0.0, 20.0, 'belt top speed (15 mph)'),
    'u_max': ('V', 0.0, 100.0, 'drive voltage range [0, u_max]'),
    'delay': ('s', 0.0, 1.0, 'drive transport delay (assumed)'),
    'counts_per_rev': ('count/rev', 1, 2**31 - 1, 'shaft encoder resolution'),
    'roller_radius': ('m', 0.0, 1.0, 'drive roller radius'),
    'gear_ratio': ('1', 0.0, INF, 'encoder revolutions per roller revolution'),
    'window_samples': ('1', 1, 100000, 'samples in the encoder speed-estimate window'),
    'delay_samples': ('1', 0, 100000, 'samples of encoder speed-estimate delay'),
}
_TWO_TRACK = {
    'mass': ('kg', 0.0, INF, 'torque car mass (irs_iwt preset: 2.86)'),
    'yaw_inertia': ('kg m^2', 0.0, INF, 'yaw inertia about the c.g. (irs_iwt: 0.07113)'),
    'lf': ('m', 0.0, 1.0, 'c.g. to front axle (irs_iwt: 0.15)'),
    'lr': ('m', 0.0, 1.0, 'c.g. to rear axle (irs_iwt: 0.15)'),
    'track': ('m', 0.0, 1.0, 'track width (irs_iwt: 0.17)'),
    'wheel_radius': ('m', 0.0, 1.0, 'effective rolling radius (irs_iwt: 0.033)'),
    'c_f': ('N/rad', 0.0, INF, 'front axle cornering stiffness at the static load (rubber '
            '1:10 tyres, 4.95 /rad per unit load: irs_models.torque_car)'),
    'c_r': ('N/rad', 0.0, INF, 'rear axle cornering stiffness at the static load (rubber '
            '1:10 tyres, 5.72 /rad per unit load)'),
    'cg_height': ('m', 0.0, 1.0, 'c.g. height for the load transfer (assumed 0.04)'),
    'wheel_inertia': ('kg m^2', 0.0, INF,
                      'spin inertia of wheel, tyre and hub-motor rotor (assumed 5e-5)'),
    'rolling_resistance': ('1', 0.0, 1.0, 'rolling resistance coefficient f_r (assumed 0.02)'),
    'rr_speed': ('m/s', 0.0, INF, 'speed over which rolling resistance builds up (tanh)'),
    'c_kappa': ('1', 0.0, INF, 'tyre longitudinal slip stiffness per unit load (assumed 10)'),
    'peak_slip_x': ('1', 0.0, INF, 'tyre longitudinal slip of the force peak at mu_ref (TMeasy '
                    's_M; 0.16)'),
    'peak_slip_y': ('1', 0.0, INF, 'tyre lateral slip (tan of the slip angle) of the force peak '
                    'at mu_ref (0.33: 18.3 deg)'),
    'sliding_slip_x': ('1', 0.0, INF, 'tyre longitudinal slip from which the force slides '
                       '(TMeasy s_S; 1.0: a locked wheel)'),
    'sliding_slip_y': ('1', 0.0, INF, 'tyre lateral slip from which the force slides (1.0)'),
    'sliding_ratio_x': ('1', 0.0, 1.0, 'tyre longitudinal sliding / peak force (0.65: '
                        "Burckhardt's locked / peak)"),
    'sliding_ratio_y': ('1', 0.0, 1.0, 'tyre lateral sliding / peak force (0.65)'),
    'mu_ref': ('1', 0.0, 2.0, 'friction at which the tyre slips are given (0.8)'),
    'slip_mu_exponent': ('1', 0.0, 1.0, 'tyre slips scale as (mu / mu_ref)^q (0.56: '
                         "Burckhardt's peaks; 1 = Rill's)"),
    'relaxation_length': ('m', 0.0, 1.0, 'tyre longitudinal relaxation length sigma'),
    'v_low': ('m/s', 0.0, INF, 'slip regularisation speed near standstill'),
    'low_speed_damping': ('s/m', 0.0, INF,
                          'tyre low-speed slip damping per unit load k_Vlow0/F_z (0 = off)'),
    'v_low_damping': ('m/s', 0.0, INF, 'speed below which the low-speed damping fades in'),
    'relaxation_length_min': ('m', 0.0, 1.0,
                              'shortest relaxation length of a saturated tyre near standstill'),
    'torque_limit': ('N m', 0.0, INF,
                     'motor torque limit per wheel; commands are clipped to +-this'),
}
_SURFACE = {
    'kind': ('-', None, None, "surface friction map: 'uniform', 'patch', 'split' or 'step'"),
    'mu': ('1', MU_MIN, MU_MAX,
           'friction coefficient (uniform; outside the patch; before the step)'),
    'mu_patch': ('1', MU_MIN, MU_MAX, 'friction on the patch x_start <= x <= x_end (patch)'),
    'x_start': ('m', -INF, INF, 'patch start along the treadmill x (patch)'),
    'x_end': ('m', -INF, INF, 'patch end along the treadmill x, > x_start (patch)'),
    'mu_left': ('1', MU_MIN, MU_MAX, 'friction for y >= 0 (split)'),
    'mu_right': ('1', MU_MIN, MU_MAX, 'friction for y < 0 (split)'),
    'mu_after': ('1', MU_MIN, MU_MAX, 'friction from t_step on (step)'),
    't_step': ('s', 0.0, INF, 'time of the friction step (step)'),
}
_ENCODERS = {
    'counts_per_rev': ('count/rev', 1, 2**31 - 1,
                       'torque car wheel encoder counts per revolution (quadrature x4)'),
    'window': ('1', 1, 100000, 'samples in the wheel encoder velocity window'),
}


def _check_plant(value):
    return None if value in PLANTS else f'plant must be one of {list(PLANTS)}'


def _check_surface_kind(value):
    return (None if value in SURFACE_KINDS
            else f'surface.kind must be one of {sorted(SURFACE_KINDS)}')


def _section_defaults():
    cfg = RigConfig()
    arm = {**asdict(ArmGeometry()), **asdict(ArmSensorParams())}
    arm.pop('seed')
    ident = {'gain': 0.0, 'speed': cfg.identified.speed, 'ds': -1.0,
             'numerator': [round(v, 12) for v in cfg.identified.numerator()],
             'denominator': [round(v, 12) for v in cfg.identified.denominator()],
             'heading': cfg.identified.heading}
    return {
        'actuator_front': (asdict(ActuatorParams()), _ACT),
        'actuator_rear': (asdict(ActuatorParams()), _ACT),
        'identified': (ident, _IDENT),
        'bicycle': (_bicycle_defaults(), _BICYCLE),
        'car': (asdict(CarParams()), _CAR),
        'arm': (arm, _ARM),
        'belt': (asdict(BeltParams()), _BELT),
        'two_track': (two_track_defaults(), _TWO_TRACK),
        'surface': (surface_defaults(), _SURFACE),
        'encoders': (encoder_defaults(), _ENCODERS),
    }


def rig_parameter_table() -> list:
    """Every rig parameter as a :class:`~irs_common.params.Param` (dotted names for sections)."""
    cfg = RigConfig()
    defaults = {k: getattr(cfg, k) for k in _RIG}
    meta = dict(_RIG)
    for section, (values, section_meta) in _section_defaults().items():
        for key, value in values.items():
            defaults[f'{section}.{key}'] = value
        meta.update({f'{section}.{key}': m for key, m in section_meta.items()})
    return table_from_defaults(
        defaults, meta, read_only=('dt',),
        validators={'plant': _check_plant, 'surface.kind': _check_surface_kind})


#: The node's own parameters: clock, inputs, topics and their rates (``node_only``: the
#: offline twin of the graph leaves them out).
NODE_PARAMS = node_only([
    Param(
        'clock_mode',
        'realtime',
        "'realtime' (wall timer, latest commands) or 'lockstep' "
        '(publishes /clock, waits for the commands of each step)',
        '-',
        read_only=True,
    ),
    Param(
        'lockstep_inputs',
        ['steering'],
        'inputs whose command for step k must arrive before '
        "step k+1 in lockstep mode: any of 'steering', 'drive', 'driver', 'wheels' "
        '(wheels: plant two_track only)',
        '-',
        read_only=True,
    ),
    Param(
        'lockstep_resend_period',
        1.0,
        'wall time without progress after which the outputs of '
        'the current step are published again (lockstep)',
        's',
        0.01,
        3600.0,
        writable=True,
    ),
    Param(
        'command_timeout',
        0.1,
        'real time: a steering or drive command older than this is late and its last value is '
        'held (rig/status SAFE_HOLDING) for up to stall_grace; a wheel torque command older '
        'than this is stale (torques 0 N m); the driver speed is held',
        's',
        0.001,
        3600.0,
        writable=True,
    ),
    Param(
        'stall_grace',
        0.5,
        'real time: a steering or drive command older than this (silent, or answering a '
        'sample this old) or a treadmill fault brings the rig to a controlled stop (the rig '
        'steers to the centre line, the belt coasts, the car speed follows the belt; '
        'docs/safety.md); at least '
        'command_timeout (the larger of the two applies)',
        's',
        0.001,
        3600.0,
        writable=True,
    ),
    Param('future_tolerance', 0.5,
          "commands stamped further ahead of the rig's time are dropped and counted as rejected",
          's', 0.0, 3600.0, read_only=True),
    Param('default_drive_voltage', 0.0,
          'drive voltage used until the first drive command arrives (0 = belt coasts)', 'V', 0.0,
          100.0),
    Param('frame_id', 'treadmill', 'fixed frame of poses and points', '-'),
    Param('child_frame_id', 'base_link', 'car body frame (ground-truth odometry)', '-'),
    Param('publish_wheel_speeds', False,
          'publish the four wheel speeds (independent-wheel-torque car encoders)', '-'),
    Param(
        'autostart',
        True,
        'start by itself: lock-step at once; real time once every input in '
        'start_inputs has delivered a command (the car is held at its start pose until then). '
        'false: wait for a call of the rig/start service (std_srvs/Trigger)',
        '-',
        read_only=True,
    ),
    Param(
        'start_inputs',
        ['steering', 'drive'],
        "real time with autostart: inputs ('steering', "
        "'drive', 'driver', 'wheels') that must have delivered a command before the car is "
        "released; "
        "[''] = none",
        '-',
        read_only=True,
    ),
    Param(
        'ground_truth_decimation',
        1,
        'publish ground_truth/odom and ground_truth/sensor_point '
        'every this many steps (0 = never)',
        '1',
        0,
        1_000_000,
        read_only=True,
        realtime_default=10,          # 100 Hz: the real-time message budget
    ),
    Param(
        'belt_speed_decimation',
        1,
        'publish belt/speed every this many steps (the treadmill '
        'regulator may run slower than the lateral loop)',
        '1',
        1,
        1_000_000,
        read_only=True,
        realtime_default=10,          # 100 Hz: the treadmill loop of the real-time budget
    ),
    Param('actuator_state_decimation', 1,
          'publish steering/state every this many steps (0 = never)', '1', 0, 1_000_000,
          read_only=True, realtime_default=10),
    Param('status_period', 0.1,
          'rig/status is published on a change and at least this often (simulated time)', 's',
          0.001, 3600.0, read_only=True),
    Param(
        'start_subscribers',
        '',
        'lock-step: before publishing step 0, wait until these of the '
        "rig's topics have matched this many subscriptions ('topic=count,...'; at most 10 s; "
        'the experiment runner sets it), so no consumer misses the first step',
        '-',
        read_only=True,
        validator=start_subscribers_problem,
    ),
    Param('max_steps', 0, 'stop stepping after this many steps (0 = run until shut down)', '1', 0,
          2**62),
])


def vehicle_sim_parameter_table() -> list:
    """Every parameter of the ``vehicle_sim`` node: its own, then the rig core's."""
    return NODE_PARAMS + rig_parameter_table()


def rig_config(values: dict) -> RigConfig:
    """The rig core's configuration from the node's flat parameters (``vehicle_sim``'s, or an
    experiment's for the offline twin): the table's defaults, without the node-only ones.
    """
    return RigConfig.from_dict(core_values(vehicle_sim_parameter_table(), values))
