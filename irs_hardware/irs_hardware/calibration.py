"""The rig's calibration: ADC counts to joint angles, steer angle to servo pulse, encoder counts
to belt travel, drive voltage to the drive's set-point register (no rclpy).

Models (SI; counts and microseconds where the devices speak them)::

    theta_i = wrap(gain_i (n_i - zero_i))            pots: n_i ADC counts -> rad, wrap to (-pi, pi]
    p       = centre + us_per_rad delta               servo: commanded steer [rad] -> pulse [us]
    s       = n_belt / counts_per_metre               belt encoder: counts -> belt travel [m]
    r       = round(10000 V / volts_full_scale)       drive: voltage [V] -> set-point [0.01 %]

Fits (:func:`fit_pots`, :func:`fit_servo`, :func:`fit_belt`) take what the calibration
procedure measures (docs/hardware.md): ADC counts at known arm poses, wheel angles at known
pulses, counts over a known belt travel. The servo's gain is the small-signal one (points within
``linear_range`` of the centre, where the linkage is linear), as the simulated rig's commanded
angle; the fit refuses a servo whose travel does not reach the steer limit. The file is YAML
(pydantic model :class:`Calibration`, strict: a wrong key or value is one sentence).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from irs_models.constants import STEER_LIMIT_DEG

__all__ = ['PotCalibration', 'ServoCalibration', 'BeltCalibration', 'DriveCalibration',
           'Calibration', 'fit_pots', 'fit_servo', 'fit_belt', 'load_calibration',
           'save_calibration', 'wrap', 'CalibrationError', 'SETPOINT_FULL_SCALE']

#: Drive set-point register at full scale (0.01 % steps).
SETPOINT_FULL_SCALE = 10000
STEER_LIMIT = math.radians(STEER_LIMIT_DEG)


class CalibrationError(ValueError):
    """A calibration file or fit that cannot be used (the message says what and why)."""


def wrap(angle):
    """Angle(s) [rad] wrapped to (-pi, pi]."""
    a = np.asarray(angle, dtype=float)
    w = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    return float(w) if w.ndim == 0 else w


class _Strict(BaseModel):
    model_config = ConfigDict(extra='forbid', strict=True, frozen=True)


def _finite(values):
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f'finite numbers expected, got {values}')
    return values


class PotCalibration(_Strict):
    """``theta_i = wrap(gain_i (n_i - zero_i))``: gain [rad/count] (sign = mounting), zero
    [counts] (the reading at theta = 0, possibly outside the ADC range).
    """

    gain: list[float] = Field(min_length=3, max_length=3)
    zero: list[float] = Field(min_length=3, max_length=3)

    @field_validator('gain')
    @classmethod
    def _gain(cls, v):
        _finite(v)
        if any(g == 0.0 for g in v):
            raise ValueError('a gain of 0 rad/count maps every reading to one angle')
        return v

    @field_validator('zero')
    @classmethod
    def _zero(cls, v):
        return _finite(v)

    def angles(self, counts) -> tuple:
        """Joint angles [rad] of three ADC readings."""
        return tuple(float(wrap(g * (n - z))) for g, n, z in zip(self.gain, counts, self.zero))


class ServoCalibration(_Strict):
    """``p = centre + us_per_rad delta`` clipped to the servo travel ``[min_us, max_us]``."""

    centre_us: float = Field(gt=500.0, lt=2500.0, allow_inf_nan=False)
    us_per_rad: float = Field(allow_inf_nan=False)
    min_us: float = Field(ge=500.0, allow_inf_nan=False)
    max_us: float = Field(le=2500.0, allow_inf_nan=False)

    @field_validator('us_per_rad')
    @classmethod
    def _gain(cls, v):
        if abs(v) < 100.0:
            raise ValueError(f'{v} us/rad: less than 100 us per rad of steer is no servo map')
        return v

    def pulse_us(self, steer: float) -> float:
        """Pulse width [us] for a commanded steer angle [rad], within the travel."""
        return min(self.max_us, max(self.min_us, self.centre_us + self.us_per_rad * steer))

    def steer(self, pulse_us: float) -> float:
        """Commanded steer angle [rad] of a pulse width [us] (inverse of :meth:`pulse_us`)."""
        return (pulse_us - self.centre_us) / self.us_per_rad


class BeltCalibration(_Strict):
    """``s = n / counts_per_metre`` [m] of the belt encoder."""

    counts_per_metre: float = Field(gt=0.0, allow_inf_nan=False)


class DriveCalibration(_Strict):
    """The drive's set-point register spans 0 .. ``volts_full_scale`` [V] in 0.01 % steps."""

    volts_full_scale: float = Field(gt=0.0, allow_inf_nan=False)

    def setpoint(self, voltage: float) -> int:
        """Set-point register value for a drive voltage [V] (clipped to the register's range)."""
        r = round(SETPOINT_FULL_SCALE * voltage / self.volts_full_scale)
        return int(min(SETPOINT_FULL_SCALE, max(0, r)))

    def voltage(self, setpoint: int) -> float:
        return setpoint * self.volts_full_scale / SETPOINT_FULL_SCALE


class Calibration(_Strict):
    """The whole calibration file (``config/calibration_emulated.yaml`` is one)."""

    pots: PotCalibration
    servo: ServoCalibration
    belt: BeltCalibration
    drive: DriveCalibration

    def check(self) -> 'Calibration':
        """The servo reaches the +-15 deg steer limit inside its travel; else CalibrationError."""
        lo, hi = sorted(self.servo.centre_us + self.servo.us_per_rad * s
                        for s in (-STEER_LIMIT, STEER_LIMIT))
        if lo < self.servo.min_us - 1e-9 or hi > self.servo.max_us + 1e-9:
            raise CalibrationError(
                f'servo: +-{STEER_LIMIT_DEG} deg of steer needs {lo:.1f}..{hi:.1f} us, outside '
                f'the travel {self.servo.min_us:.1f}..{self.servo.max_us:.1f} us')
        return self


def load_calibration(path) -> Calibration:
    """The checked calibration of a YAML file; one-sentence CalibrationError otherwise."""
    path = Path(path)
    try:
        doc = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise CalibrationError(f'{path}: cannot read ({exc.strerror})') from None
    except yaml.YAMLError as exc:
        raise CalibrationError(f'{path}: not YAML ({str(exc).splitlines()[0]})') from None
    try:
        return Calibration.model_validate(doc).check()
    except ValidationError as exc:
        err = exc.errors()[0]
        where = '.'.join(str(p) for p in err['loc']) or '(top level)'
        raise CalibrationError(f"{path}: {where}: {err['msg']}") from None
    except CalibrationError as exc:
        raise CalibrationError(f'{path}: {exc}') from None


def save_calibration(cal: Calibration, path) -> None:
    Path(path).write_text(yaml.safe_dump(cal.model_dump(), sort_keys=False))


def fit_pots(counts, angles) -> PotCalibration:
    """Least-squares ``theta = gain (n - zero)`` per joint from ``counts`` (m, 3) read at poses
    whose joint angles [rad] are ``angles`` (m, 3), m >= 2 distinct readings per joint. The
    angles are unwrapped around the first pose (a joint crossing +-pi stays continuous).
    """
    n = np.asarray(counts, dtype=float)
    a = np.asarray(angles, dtype=float)
    if n.shape != a.shape or n.ndim != 2 or n.shape[1] != 3 or n.shape[0] < 2:
        raise CalibrationError(f'fit_pots needs (m, 3) counts and angles with m >= 2, got '
                               f'{n.shape} and {a.shape}')
    gain, zero = [], []
    for j in range(3):
        if np.ptp(n[:, j]) == 0.0:
            raise CalibrationError(f'pot {j + 1}: every pose gave the same reading; move the '
                                   'joint between poses')
        rel = a[0, j] + wrap(a[:, j] - a[0, j])
        g, b = np.polyfit(n[:, j], rel, 1)
        gain.append(float(g))
        zero.append(float(-b / g))
    return PotCalibration(gain=gain, zero=zero)


def fit_servo(pulses_us, wheel_angles, linear_range: float = math.radians(5.0)
              ) -> ServoCalibration:
    """Servo map from wheel angles [rad] measured at pulses [us]: the gain and centre from the
    points within ``linear_range`` of straight ahead (least squares), the travel from the
    extreme pulses. CalibrationError if fewer than 2 small-angle points or the travel cannot
    reach the +-15 deg limit.
    """
    p = np.asarray(pulses_us, dtype=float)
    d = np.asarray(wheel_angles, dtype=float)
    small = np.abs(d) <= linear_range
    if small.sum() < 2 or np.ptp(p[small]) == 0.0:
        raise CalibrationError('fit_servo needs two or more distinct pulses whose wheel angle is '
                               f'within {math.degrees(linear_range):.1f} deg of straight ahead')
    us_per_rad, centre = np.polyfit(d[small], p[small], 1)
    cal = ServoCalibration(centre_us=float(centre), us_per_rad=float(us_per_rad),
                           min_us=float(p.min()), max_us=float(p.max()))
    Calibration(pots=PotCalibration(gain=[1.0] * 3, zero=[0.0] * 3), servo=cal,
                belt=BeltCalibration(counts_per_metre=1.0),
                drive=DriveCalibration(volts_full_scale=1.0)).check()
    return cal


def fit_belt(count_delta: int, travel_m: float) -> BeltCalibration:
    """Counts per metre from the count difference over a measured belt travel [m]."""
    if not (math.isfinite(travel_m) and travel_m > 0.0) or count_delta == 0:
        raise CalibrationError(f'fit_belt needs a travel > 0 m and counts, got {count_delta} '
                               f'counts over {travel_m} m')
    return BeltCalibration(counts_per_metre=abs(count_delta) / travel_m)
