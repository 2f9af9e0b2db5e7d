"""Calibration round trips and validation."""
import sys

# pytest's --import-mode=importlib registers the repository folders (e.g. ./irs_sensing) as
# namespace packages named like the real packages; drop them so the real packages import.
for _name in ("irs_sensing", "irs_vehicle_sim", "irs_treadmill"):
    if _name in sys.modules and getattr(sys.modules[_name], "__file__", None) is None:
        del sys.modules[_name]

import math

import pytest

from irs_sensing.calibration import (ArmCalibration, CalibrationError, JointCalibration,
                                     load_calibration_yaml)

CONFIG = __import__("pathlib").Path(__file__).resolve().parents[1] / "config" / "sensing.yaml"


def test_default_joint_mid_travel_is_zero_and_span():
    j = JointCalibration()
    assert j.to_angle(2.5) == pytest.approx(0.0)
    assert j.to_angle(4.5) == pytest.approx(math.radians(300.0) / 5.0 * 2.0)
    lo, hi = j.angle_range
    assert hi - lo == pytest.approx(math.radians(300.0) / 5.0 * 4.9)


@pytest.mark.parametrize("cal", [
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


@pytest.mark.parametrize("raw", [float("nan"), 0.0, 5.0, -1.0, None])
def test_rejects_bad_raw(raw):
    with pytest.raises(CalibrationError):
        JointCalibration().to_angle(raw)


def test_rejects_unrepresentable_angle():
    with pytest.raises(CalibrationError):
        JointCalibration().to_raw(4.0)
    with pytest.raises(CalibrationError):
        JointCalibration().to_raw(float("inf"))


@pytest.mark.parametrize("kw", [dict(gain=0.0), dict(raw_min=3.0, raw_max=1.0),
                                dict(offset=float("nan")), dict(counts_per_volt=0.0)])
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
        ArmCalibration.from_dict({"joint1": {"gain": 1.0, "ofset": 2.0}, "joint2": {},
                                  "joint3": {}})
