"""Per-joint calibration of the sensing-arm potentiometers (paper Sec. 3.2).

Model (per joint, linear)::

    volts = (raw - counts_zero) / counts_per_volt     if the raw reading is in ADC counts
    volts = raw                                       if the raw reading is already in volts
    theta = gain * (volts - offset)                   [rad]

and the exact inverse ``volts = offset + theta / gain``, ``raw = counts_zero + counts_per_volt
* volts``.  ``gain`` [rad/V] may be negative (pot mounted reversed).  The angle is *not* wrapped,
so the calibration is a bijection on the valid raw range ``[raw_min, raw_max]``; wrapping is
done by the kinematics.

Default joint: single-turn pot with 300 deg electrical travel over 0..5 V,
``gain = (300 deg / 5 V) = 1.0472 rad/V``, zero angle at mid travel (``offset = 2.5 V``),
raw in volts, valid raw range [0.05, 4.95] V (rails excluded: a broken wiper or lead
reads the rail).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Sequence, Tuple

__all__ = ['CalibrationError', 'JointCalibration', 'ArmCalibration', 'load_calibration_yaml']


class CalibrationError(ValueError):
    """Raised for a raw reading (or angle) that cannot be converted: NaN or out of range."""


def _finite(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f'{name} must be a finite number, got {v!r}.')
    return float(v)


@dataclass(frozen=True)
class JointCalibration:
    """Linear raw -> angle calibration of one joint.

    Parameters
    ----------
    gain : float
        Angle per volt [rad/V], non-zero.
    offset : float
        Voltage at zero angle [V].
    raw_min, raw_max : float
        Valid raw input range [V or counts]; readings outside are rejected.
    counts_per_volt : float or None
        ADC scale [counts/V]; ``None`` means the raw reading is in volts.
    counts_zero : float
        ADC reading at 0 V [counts] (e.g. 2048 for a bipolar 12-bit converter).
    name : str
        Label used in error messages.
    """

    gain: float = math.radians(300.0) / 5.0
    offset: float = 2.5
    raw_min: float = 0.05
    raw_max: float = 4.95
    counts_per_volt: Optional[float] = None
    counts_zero: float = 0.0
    name: str = 'joint'

    def __post_init__(self) -> None:
        for n in ('gain', 'offset', 'raw_min', 'raw_max', 'counts_zero'):
            object.__setattr__(self, n, _finite(f'JointCalibration({self.name}).{n}',
                                                getattr(self, n)))
        if self.gain == 0.0:
            raise ValueError(f'JointCalibration({self.name}).gain must be non-zero rad/V.')
        if not self.raw_min < self.raw_max:
            raise ValueError(f'JointCalibration({self.name}) expected raw_min < raw_max, got '
                             f'{self.raw_min} >= {self.raw_max}.')
        if self.counts_per_volt is not None:
            c = _finite(f'JointCalibration({self.name}).counts_per_volt', self.counts_per_volt)
            if c == 0.0:
                raise ValueError(
                    f'JointCalibration({self.name}).counts_per_volt must be non-zero.'
                )
            object.__setattr__(self, 'counts_per_volt', c)

    # ------------------------------------------------------------------ conversions
    def raw_to_volts(self, raw: float) -> float:
        """Raw reading -> volts [V] (identity when the raw reading is in volts)."""
        if self.counts_per_volt is None:
            return float(raw)
        return (raw - self.counts_zero) / self.counts_per_volt

    def volts_to_raw(self, volts: float) -> float:
        """Volts [V] -> raw reading [V or counts] (unrounded)."""
        if self.counts_per_volt is None:
            return float(volts)
        return self.counts_zero + self.counts_per_volt * volts

    def to_angle(self, raw: float) -> float:
        """Raw reading -> joint angle [rad]; :class:`CalibrationError` if NaN or out of range."""
        if raw is None or isinstance(raw, bool) or not isinstance(raw, (int, float)) \
                or math.isnan(raw):
            raise CalibrationError(f'{self.name}: expected a numeric raw reading, got {raw!r}.')
        if not self.raw_min <= raw <= self.raw_max:
            raise CalibrationError(f'{self.name}: raw reading {raw} outside the valid range '
                                   f'[{self.raw_min}, {self.raw_max}].')
        return self.gain * (self.raw_to_volts(raw) - self.offset)

    def to_raw(self, angle: float) -> float:
        """Joint angle [rad] -> raw reading; :class:`CalibrationError` if not representable."""
        if not isinstance(angle, (int, float)) or not math.isfinite(angle):
            raise CalibrationError(f'{self.name}: expected a finite angle in rad, got {angle!r}.')
        raw = self.volts_to_raw(self.offset + angle / self.gain)
        tol = 1e-9 * max(1.0, abs(self.raw_max - self.raw_min))
        if not self.raw_min - tol <= raw <= self.raw_max + tol:
            raise CalibrationError(f'{self.name}: angle {angle:.4f} rad maps to raw {raw:.4f}, '
                                   f'outside [{self.raw_min}, {self.raw_max}].')
        return min(self.raw_max, max(self.raw_min, raw))  # absorb round-off at the range ends

    @property
    def angle_range(self) -> Tuple[float, float]:
        """(min, max) angle [rad] reachable from the valid raw range."""
        a = self.gain * (self.raw_to_volts(self.raw_min) - self.offset)
        b = self.gain * (self.raw_to_volts(self.raw_max) - self.offset)
        return (min(a, b), max(a, b))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], name: str = 'joint') -> "JointCalibration":
        """Build from a mapping with keys gain, offset, raw_min, raw_max and optionally
        counts_per_volt (0 or absent: raw in volts) and counts_zero.
        """
        allowed = {'gain', 'offset', 'raw_min', 'raw_max', 'counts_per_volt', 'counts_zero'}
        unknown = set(d) - allowed
        if unknown:
            raise ValueError(f'{name}: unknown calibration keys {sorted(unknown)}; expected a '
                             f'subset of {sorted(allowed)}.')
        kw = dict(d)
        if kw.get('counts_per_volt', None) in (None, 0, 0.0):
            kw['counts_per_volt'] = None
        return cls(name=name, **kw)


@dataclass(frozen=True)
class ArmCalibration:
    """Calibration of the three arm joints (theta1, theta2, theta3)."""

    joints: Tuple[JointCalibration, JointCalibration, JointCalibration] = field(
        default_factory=lambda: (JointCalibration(name='joint1'), JointCalibration(name='joint2'),
                                 JointCalibration(name='joint3')))

    def __post_init__(self) -> None:
        if len(self.joints) != 3 or not all(isinstance(j, JointCalibration) for j in self.joints):
            raise ValueError('ArmCalibration expected exactly three JointCalibration objects.')
        object.__setattr__(self, 'joints', tuple(self.joints))

    def to_angles(self, raw: Sequence[float]) -> Tuple[float, float, float]:
        """Three raw readings -> (theta1, theta2, theta3) [rad]."""
        if len(raw) != 3:
            raise CalibrationError(f'expected three raw readings, got {len(raw)}.')
        return tuple(j.to_angle(r) for j, r in zip(self.joints, raw))  # type: ignore[return-value]

    def to_raw(self, angles: Sequence[float]) -> Tuple[float, float, float]:
        """(theta1, theta2, theta3) [rad] -> three raw readings."""
        if len(angles) != 3:
            raise CalibrationError(f'expected three angles, got {len(angles)}.')
        return tuple(j.to_raw(a) for j, a in zip(self.joints, angles))  # type: ignore[return-value]

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "ArmCalibration":
        """Build from ``{'joint1': {...}, 'joint2': {...}, 'joint3': {...}}``."""
        missing = [k for k in ('joint1', 'joint2', 'joint3') if k not in d]
        if missing:
            raise ValueError(f'calibration mapping is missing {missing}; expected joint1..joint3.')
        return cls(tuple(JointCalibration.from_dict(d[k], name=k)
                         for k in ('joint1', 'joint2', 'joint3')))  # type: ignore[arg-type]


def load_calibration_yaml(path: str, node_name: str = 'arm_pose_estimator') -> ArmCalibration:
    """Load ``<node_name>.ros__parameters.calibration`` from a ROS 2 parameter YAML file."""
    import yaml

    with open(path, 'r', encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    try:
        cal = doc[node_name]['ros__parameters']['calibration']
    except (KeyError, TypeError) as exc:
        raise ValueError(f'{path}: expected {node_name}.ros__parameters.calibration.') from exc
    return ArmCalibration.from_dict(cal)
