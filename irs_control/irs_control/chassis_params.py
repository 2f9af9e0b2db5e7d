"""Parameter table of the ``chassis_controller`` node (the torque car).

Defaults are the cores' (:mod:`.abs_control`, :mod:`.chassis_control`,
:mod:`.torque_car_control`). Writable at run time are the driver's inputs the core reads at
every step (speed target, brake and steer schedules, the pose timeout) and the stale timeout;
everything that builds the controllers is read-only.
"""
from irs_common.params import Param, core_values
from irs_common.start_gate import START_SUBSCRIBERS

from .abs_control import AbsParams
from .abs_peak import PeakSeekParams
from .chassis_control import ChassisParams
from .torque_car_control import ABS_REFERENCES, BRAKE_MODES, YAW_CONTROLS, TorqueCarConfig

_A, _C, _P = AbsParams(), ChassisParams(), PeakSeekParams()


def _one_of(name, choices):
    def check(value):
        if value not in choices:
            return f'{name} must be one of {list(choices)}, got {value!r}'
        return None
    return check


PARAMS = [
    Param('dt', 0.001, 'control period = encoder sample period', 's', 1e-5, 1.0),
    Param('input_sync', True,
          'lock-step: answer an encoder sample only once the pose, velocity and belt speed of '
          'the same stamp have arrived; false: the newest of each', '-',
          node_only=True,
          realtime_default=False),   # in real time pose and velocity come at 100 Hz (budget)
    Param('speed.target', 0.0, 'speed over the belt to hold; 0 = the belt speed measured at '
          'the start (or when set to 0), held: the treadmill regulator keeps the car in place; '
          'applied at the next step', 'm/s', 0.0, 5.0, writable=True),
    Param('speed.window', 10, 'samples of the arm-speed estimate (x differentiated + belt '
          'speed)', 'samples', 1, 1000),
    Param('speed.bandwidth', _C.speed_bandwidth, 'speed loop gain w_v', 'rad/s', 1e-6, 1e4),
    Param('speed.integral', _C.speed_integral, 'speed loop integral gain w_vi', '1/s', 0.0, 1e4),
    Param('brake.start_time', -1.0, 'brake from this time since the run started; < 0 = never; '
          'applied at the next step', 's', -1e9, 1e9, writable=True),
    Param('brake.duration', 0.0, 'release the brake after this long (a braking event); <= 0 = '
          'hold to the end (a stop); applied at the next step', 's', -1e9, 1e9, writable=True),
    Param('brake.torque', 0.3, 'brake demand per wheel (a magnitude; clipped to torque_limit); '
          'applied at the next step', 'N m', 1e-6, 10.0, writable=True),
    Param('brake.mode', 'abs', "'abs' (slip control to abs.slip_target), 'abs_peak' (slip "
          "control to the peak of an online Burckhardt fit per wheel), 'locked' (friction "
          "brakes lock every wheel) or 'open' (the demand, no ABS); applied at the next step",
          '-', writable=True, validator=_one_of('brake.mode', BRAKE_MODES)),
    Param('yaw_control', 'off', "yaw-rate control: 'off', 'rear_steer', 'differential' "
          "(left/right torque) or 'both'", '-', validator=_one_of('yaw_control', YAW_CONTROLS)),
    Param('yaw.bandwidth', _C.yaw_bandwidth, 'yaw-rate loop gain w_r', 'rad/s', 1e-6, 1e5),
    Param('yaw.integral', _C.yaw_integral, 'yaw-rate loop integral gain w_ri', '1/s', 0.0, 1e5),
    Param('yaw.differential_bandwidth', _C.differential_bandwidth,
          'w_d: while driving, the differential-torque share is scaled by w_d / w_r', 'rad/s',
          1e-6, 1e5),
    Param('steer.amplitude', 0.0, "the driver's front step steer (0 = straight); applied at the "
          'next step', 'rad', -0.2618, 0.2618, writable=True),
    Param('steer.start_time', 0.0, 'time since the run started of the front step steer; '
          'applied at the next step', 's', 0.0, 1e9, writable=True),
    Param('abs.slip_target', _A.slip_target, 'ABS slip target lambda* while braking', '1',
          -0.99, -0.001),
    Param('abs.bandwidth', _A.bandwidth, 'ABS slip loop pole w_c', 'rad/s', 1e-6, 1e5),
    Param('abs.integral_gain', _A.integral_gain, 'ABS integral gain K_i', 'N m/s', 0.0, 1e5),
    Param('abs.reference', 'wheels', "the ABS's speed: 'wheels' (encoders, applied torques and "
          "belt speed, as a car has) or 'arm' (the arm's pose differentiated plus the belt "
          'speed)', '-', validator=_one_of('abs.reference', ABS_REFERENCES)),
    Param('abs.peak.slip_min', _P.slip_min, "smallest slip target of 'abs_peak' (a magnitude)",
          '1', 0.001, 0.99),
    Param('abs.peak.slip_max', _P.slip_max, "largest slip target of 'abs_peak' (a magnitude)",
          '1', 0.001, 0.99),
    Param('abs.peak.gain_threshold', _P.gain_threshold, "'abs_peak' moves its target only for "
          'this predicted relative friction gain', '1', 0.0, 1.0),
    Param('abs.peak.forgetting', _P.forgetting, "'abs_peak' fit's forgetting factor per sample "
          '(0.98: 50 ms memory at 1 kHz)', '1', 0.5, 1.0),
    Param('abs.v_min', _A.v_min, 'speed below which ABS and the yaw reference stop', 'm/s', 1e-3,
          10.0),
    Param('torque_limit', _A.torque_limit, 'wheel torque limit (the hub motors)', 'N m', 1e-6,
          10.0),
    Param('pose_timeout', 0.2, 'age of the newest valid pose at an encoder sample (the '
          'difference of their stamps) beyond which zero torque and zero steer are commanded: '
          'the speed estimate differentiates the poses (0.2 s leaves the speed loop 32 deg of '
          'phase margin); applied at the next step', 's', 0.001, 10.0, writable=True),
    Param('stale_timeout', 0.05, 'encoder age after which zero torque and zero steer are '
          'commanded (applied at once)', 's', 0.001, 10.0, writable=True, node_only=True),
    Param('future_tolerance', 0.5, 'inputs stamped further ahead of the node clock are dropped',
          's', 0.0, 3600.0, node_only=True),
    Param('status_decimation', 10, 'publish chassis/status every this many steps (and on a '
          'change of reason or braking); 0 = on changes only', '1', 0, 1_000_000,
          node_only=True),
    START_SUBSCRIBERS,
]

#: run-time changes the node hands to the core: parameter -> TorqueCarConfig attribute
LIVE = {'speed.target': 'speed_target', 'brake.start_time': 'brake_start_time',
        'brake.duration': 'brake_duration',
        'brake.torque': 'brake_torque', 'brake.mode': 'brake_mode',
        'steer.amplitude': 'steer_amplitude', 'steer.start_time': 'steer_start_time',
        'pose_timeout': 'pose_timeout'}


def chassis_config(values: dict) -> TorqueCarConfig:
    """The torque-car controller's configuration from the node's flat parameters (the node's,
    or an experiment's for the offline twin), missing ones at their defaults.
    """
    return TorqueCarConfig.from_params(core_values(PARAMS, values, nested=False))
