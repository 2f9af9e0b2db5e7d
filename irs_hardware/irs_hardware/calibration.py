"""The rig's calibration: ADC counts to joint angles, steer angle to servo pulse, encoder counts
to belt travel, drive voltage to the drive's set-point register, and for the torque car wheel
encoder counts to wheel angle and wheel torque to motor command (no rclpy).

Models (SI; counts and microseconds where the devices speak them)::

    theta_i = wrap(gain_i (n_i - zero_i))            pots: n_i ADC counts -> rad, wrap to (-pi, pi]
    p       = centre + us_per_rad delta               servo: commanded steer [rad] -> pulse [us]
    s       = n_belt / counts_per_metre               belt encoder: counts -> belt travel [m]
    r       = round(10000 V / volts_full_scale)       drive: voltage [V] -> set-point [0.01 %]
    n_j     = e_j m_j                                 wheel j: raw counts m_j -> forward counts
    c_j     = round(1000 T_j / (s_j k_t I_fs))        wheel j: torque [N m] -> command [per-mille]

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
           'WheelCalibration', 'Calibration', 'fit_wheel_encoders', 'fit_pots', 'fit_servo',
           'fit_belt', 'load_calibration', 'save_calibration', 'wrap', 'CalibrationError',
           'SETPOINT_FULL_SCALE', 'MOTOR_FULL_SCALE']

#: Drive set-point register at full scale (0.01 % steps).
SETPOINT_FULL_SCALE = 10000
#: Motor command at the drivers' full scale (per-mille steps).
MOTOR_FULL_SCALE = 1000
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


def _signs(v):
    if any(s not in (-1, 1) for s in v):
        raise ValueError(f'each sign is 1 or -1, got {v}')
    return v


class WheelCalibration(_Strict):
    """The torque car's wheels FL, FR, RL, RR (module docstring's last two lines).

    ``counts_per_rev`` [counts] of each wheel's encoder (quadrature x4, through any gear);
    ``encoder_sign`` e_j: +1 where the counter counts up as the wheel rolls forward (a mirrored
    mounting counts down); ``motor_constant`` k_t [N m/A] at the wheel (the motor's torque
    constant times its gear ratio); ``driver_full_scale`` I_fs [A]: the motor drivers' current
    (torque mode) at a command of 1000 per-mille; ``motor_sign`` s_j: +1 where a positive
    command drives the wheel forward.
    """

    counts_per_rev: int = Field(gt=0)
    encoder_sign: list[int] = Field(min_length=4, max_length=4)
    motor_constant: float = Field(gt=0.0, allow_inf_nan=False)
    driver_full_scale: float = Field(gt=0.0, allow_inf_nan=False)
    motor_sign: list[int] = Field(min_length=4, max_length=4)

    @field_validator('encoder_sign', 'motor_sign')
    @classmethod
    def _sign(cls, v):
        return _signs(v)

    @property
    def torque_full_scale(self) -> float:
        """Wheel torque [N m] at a command of 1000 per-mille: ``k_t I_fs``."""
        return self.motor_constant * self.driver_full_scale

    def counts(self, raw) -> tuple:
        """Forward counts of four raw counter values (each times its encoder sign)."""
        return tuple(e * int(n) for e, n in zip(self.encoder_sign, raw))

    def command(self, torques) -> tuple:
        """Motor commands [per-mille] of four wheel torques [N m], clipped to +-1000."""
        full = self.torque_full_scale
        return tuple(int(min(MOTOR_FULL_SCALE, max(-MOTOR_FULL_SCALE,
                                                   round(MOTOR_FULL_SCALE * t / (s * full)))))
                     for s, t in zip(self.motor_sign, torques))

    def torque(self, commands) -> tuple:
        """Wheel torques [N m] of four motor commands [per-mille] (inverse of :meth:`command`)."""
        full = self.torque_full_scale
        return tuple(s * c * full / MOTOR_FULL_SCALE for s, c in zip(self.motor_sign, commands))


class Calibration(_Strict):
    """The whole calibration file (``config/calibration_emulated.yaml`` is one; the torque car's,
    ``config/calibration_emulated_torque_car.yaml``, adds ``wheels``).
    """

    pots: PotCalibration
    servo: ServoCalibration
    belt: BeltCalibration
    drive: DriveCalibration
    wheels: WheelCalibration | None = None

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
    Path(path).write_text(yaml.safe_dump(cal.model_dump(exclude_none=True), sort_keys=False))


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


def fit_wheel_encoders(count_delta, turns: float) -> tuple:
    """``(counts_per_rev, encoder_sign)`` from the raw count differences of the four wheels
    each turned forward ``turns`` whole revolutions by hand. CalibrationError if a wheel did not
    count, or the wheels disagree by more than half a count per revolution (a wrong encoder or
    a miscounted turn).
    """
    d = [int(v) for v in count_delta]
    if len(d) != 4 or not (math.isfinite(turns) and turns > 0.0) or 0 in d:
        raise CalibrationError(f'fit_wheel_encoders needs 4 non-zero count differences and '
                               f'turns > 0, got {d} over {turns} turns')
    per_rev = [abs(v) / turns for v in d]
    n = round(sum(per_rev) / 4.0)
    off = [abs(p - n) for p in per_rev]
    if max(off) > 0.5:
        raise CalibrationError(f'wheel encoders: {", ".join(f"{p:.1f}" for p in per_rev)} '
                               f'counts per revolution differ by more than 0.5 from {n}; turn '
                               'each wheel exactly the same whole number of turns')
    return n, [1 if v > 0 else -1 for v in d]
