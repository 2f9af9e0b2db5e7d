"""Parameter table of the ``arm_pose_estimator`` node (defaults from the cores, units here)."""
from dataclasses import asdict, dataclass
import math

from irs_common.params import Param, core_values, flatten, node_only, table_from_defaults
from irs_common.start_gate import START_SUBSCRIBERS
from irs_models.arm_kinematics import ArmGeometry

from .calibration import ArmCalibration, JointCalibration
from .pose_estimator import PoseEstimatorParams

INF = math.inf
_EST = {
    'ds': ('m', 0.0, 5.0, 'lateral sensor point ahead of the c.g. (y_s = y + ds sin psi)'),
    'joint_min': ('rad', None, None, 'lower mechanical limit of joints 1-3'),
    'joint_max': ('rad', None, None, 'upper mechanical limit of joints 1-3'),
    'belt_half_length': ('m', 0.0, INF, 'half of the belt length'),
    'belt_half_width': ('m', 0.0, INF, 'half of the belt width'),
    'off_belt_margin': ('m', 0.0, INF, 'reject a c.g. farther than this outside the belt'),
    'max_speed': ('m/s', 0.0, INF, 'plausibility bound on c.g. speed between samples'),
    'max_yaw_rate': ('rad/s', 0.0, INF, 'plausibility bound on yaw rate between samples'),
    'jump_margin': ('m', 0.0, INF, 'extra allowance on the position jump'),
    'jump_margin_psi': ('rad', 0.0, INF, 'extra allowance on the heading jump'),
    'stale_timeout': ('s', 0.0, INF,
                      'no valid reading for this long: input stale (writable: applied at once)'),
    'dt_tolerance': ('1', 0.0, INF,
                     'relative sample-period deviation that resets the differentiators'),
    'singular_tolerance': ('rad', 0.0, math.pi,
                           'near-singular arm when |theta2| or pi-|theta2| is below this'),
    'differentiator': (
        '-',
        None,
        None,
        "'savgol' (causal least-squares line fit) or 'lowpass' (backward difference + low pass)",
    ),
    'cutoff_hz': ('Hz', 0.0, INF, "low-pass cut-off ('lowpass')"),
    'window': ('samples', 2, 100000, "fit window ('savgol')"),
    'order': ('1', 0, 10, "polynomial order ('savgol')"),
    'geometry.l1': ('m', 0.0, INF, 'arm link 1 length'),
    'geometry.l2': ('m', 0.0, INF, 'arm link 2 length'),
    'geometry.base_x': ('m', -INF, INF, 'arm base (joint 1) x in the treadmill frame'),
    'geometry.base_y': ('m', -INF, INF, 'arm base (joint 1) y in the treadmill frame'),
    'geometry.attach_offset': ('m', -1.0, 1.0, 'arm tip attachment ahead of the c.g.'),
    'geometry.elbow': ('1', -1, 1, 'elbow branch: +1 theta2 in (0, pi), -1 in (-pi, 0)'),
}
_CAL = {
    'gain': ('rad/V', -INF, INF, 'angle per volt'),
    'offset': ('V', -INF, INF, 'reading at zero angle'),
    'raw_min': ('V', -INF, INF, 'lowest valid reading'),
    'raw_max': ('V', -INF, INF, 'highest valid reading'),
    'counts_per_volt': ('counts/V', 0.0, INF, 'ADC counts per volt; 0 = raw already in volts'),
    'counts_zero': ('counts', -INF, INF, 'ADC reading at 0 V'),
}
NODE = [
    Param('rate_hz', 1000.0, 'sampling rate of the arm potentiometers', 'Hz', 1.0, 100000.0,
          read_only=True),
    Param(
        'input',
        'angles',
        "'angles' (joint_states positions are angles) or 'raw' (volts/counts, "
        'calibrated with calibration.*)',
        '-',
        read_only=True,
    ),
]
#: The node's own parameters: frames, stamp tolerance, publication rate.
NODE += node_only([
    Param('frame_id', 'treadmill', 'frame of the published pose and sensor point', '-'),
    Param('child_frame_id', 'base_link', 'frame of the published velocity (car body)', '-'),
    Param(
        'future_tolerance',
        0.5,
        'readings stamped further ahead of the node clock are dropped (not answered, not stored)',
        's',
        0.0,
        3600.0,
        read_only=True,
    ),
    Param(
        'pose_decimation',
        1,
        'publish pose and velocity every this many readings (the '
        'treadmill loop needs less than the lateral loop); lateral_position goes every reading',
        '1',
        1,
        1_000_000,
        read_only=True,
        realtime_default=10,          # 100 Hz: the treadmill loop of the real-time budget
    ),
]) + [START_SUBSCRIBERS]


def estimator_parameter_table() -> list:
    """Every parameter of the node as a Param list."""
    est = asdict(PoseEstimatorParams())
    est.pop('dt')
    est['geometry'] = asdict(ArmGeometry())
    defaults = flatten(est)
    meta = dict(_EST)
    cal = asdict(JointCalibration())
    cal.pop('name')
    for j in ('joint1', 'joint2', 'joint3'):
        for key, value in cal.items():
            if value is None:  # counts_per_volt: None (= raw in volts) is 0.0 as a parameter
                value = 0.0
            defaults[f'calibration.{j}.{key}'] = value
            meta[f'calibration.{j}.{key}'] = _CAL[key]
    return NODE + table_from_defaults(defaults, meta, writable=('stale_timeout',))


@dataclass(frozen=True)
class EstimatorConfig:
    """What the estimator's cores take: the input kind, the calibration, the estimator."""

    input: str                      # 'angles' or 'raw' (volts/counts through ``calibration``)
    calibration: ArmCalibration
    params: PoseEstimatorParams


def estimator_config(values: dict) -> EstimatorConfig:
    """The cores' configuration from the node's flat parameters (the node's, or an
    experiment's for the offline twin); ``ValueError`` names a bad value.
    """
    nested = core_values(estimator_parameter_table(), values)
    kind = nested.pop('input')
    if kind not in ('angles', 'raw'):
        raise ValueError(f"input must be 'angles' or 'raw', got {kind!r}")
    calibration = ArmCalibration.from_dict(nested.pop('calibration'))
    return EstimatorConfig(kind, calibration, PoseEstimatorParams.from_ros_params(nested))
