"""Calibration round trips and validation."""
import math

import pytest

from irs_sensing.calibration import (ArmCalibration, CalibrationError, JointCalibration,
                                     load_calibration_yaml)

CONFIG = __import__('pathlib').Path(__file__).resolve().parents[1] / 'config' / 'sensing.yaml'


def test_default_joint_mid_travel_is_zero_and_span():
    j = JointCalibration()
    assert j.to_angle(2.5) == pytest.approx(0.0)
    assert j.to_angle(4.5) == pytest.approx(math.radians(300.0) / 5.0 * 2.0)
    lo, hi = j.angle_range
    assert hi - lo == pytest.approx(math.radians(300.0) / 5.0 * 4.9)


@pytest.mark.parametrize('cal', [
    JointCalibration(gain=1.2, offset=2.4),
    JointCalibration(gain=-0.9, offset=2.6),
    JointCalibration(gain=2.0 * math.pi / 4096 * 0.95, offset=0.0, raw_min=-2000, raw_max=2000,
                     counts_per_volt=None),
    JointCalibration(gain=1.05, offset=0.1, raw_min=100, raw_max=4000, counts_per_volt=409.6,
                     counts_zero=2048.0),
])
def test_round_trip_raw_angle_raw(cal):
    import numpy as np
    for raw in np.linspace(cal.raw_min, cal.raw_max, 37):
        assert cal.to_raw(cal.to_angle(raw)) == pytest.approx(raw, abs=1e-9)
    lo, hi = cal.angle_range
    for a in np.linspace(lo, hi, 37):
        assert cal.to_angle(cal.to_raw(a)) == pytest.approx(a, abs=1e-12)


def test_counts_conversion():
    cal = JointCalibration(gain=1.0, offset=0.0, raw_min=0, raw_max=4095, counts_per_volt=409.6,
                           counts_zero=2048.0)
    assert cal.to_angle(2048 + 409.6) == pytest.approx(1.0)
    assert cal.raw_to_volts(2048) == 0.0


@pytest.mark.parametrize('raw', [float('nan'), 0.0, 5.0, -1.0, None])
def test_rejects_bad_raw(raw):
    with pytest.raises(CalibrationError):
        JointCalibration().to_angle(raw)


def test_rejects_unrepresentable_angle():
    with pytest.raises(CalibrationError):
        JointCalibration().to_raw(4.0)
    with pytest.raises(CalibrationError):
        JointCalibration().to_raw(float('inf'))


@pytest.mark.parametrize('kw', [dict(gain=0.0), dict(raw_min=3.0, raw_max=1.0),
                                dict(offset=float('nan')), dict(counts_per_volt=0.0)])
def test_parameter_validation(kw):
    with pytest.raises(ValueError):
        JointCalibration(**kw)


def test_arm_calibration_from_yaml_round_trip():
    arm = load_calibration_yaml(str(CONFIG))
    assert isinstance(arm, ArmCalibration)
    angles = (-1.2, 1.5, 0.3)
    raw = arm.to_raw(angles)
    assert arm.to_angles(raw) == pytest.approx(angles, abs=1e-12)
    with pytest.raises(CalibrationError):
        arm.to_angles((2.5, 2.5))


def test_from_dict_rejects_unknown_key():
    with pytest.raises(ValueError):
        ArmCalibration.from_dict({'joint1': {'gain': 1.0, 'ofset': 2.0}, 'joint2': {},
                                  'joint3': {}})


def test_sensing_yaml_units_and_estimator_params():
    import re

    import yaml

    from irs_sensing.pose_estimator import PoseEstimatorParams
    for line in CONFIG.read_text().splitlines():
        code = line.split('#')[0]
        if re.search(r':\s*\[?-?\d', code):
            assert re.search(r'#\s*\[', line), f'number without a unit comment: {line!r}'
    ros = yaml.safe_load(CONFIG.read_text())['arm_pose_estimator']['ros__parameters']
    p = PoseEstimatorParams.from_ros_params(ros)
    assert p.dt == pytest.approx(0.001)
    assert p.geometry.base_y == pytest.approx(0.85)
    # the joint-1 calibrated span equals the configured mechanical range
    arm = ArmCalibration.from_dict(ros['calibration'])
    lo, hi = arm.joints[0].angle_range
    assert (lo, hi) == pytest.approx((p.joint_min[0], p.joint_max[0]), abs=1e-3)
