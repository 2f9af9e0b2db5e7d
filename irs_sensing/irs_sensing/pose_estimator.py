"""Arm pose estimator core: joint angles -> validated pose and velocities (paper Sec. 3.2).

Each reading is screened (finite, within the joint ranges, stamp not in the future nor older
than the last), turned into the c.g. pose by the arm's forward kinematics, screened again (on
the belt, no implausible jump) and differentiated (:mod:`irs_sensing.differentiator`); the
pipeline is :meth:`PoseEstimator.update`. It exists so that one bad potentiometer reading never
becomes a pose, in the node and offline alike.

Velocities: ``xdot, ydot`` [m/s] in the ``treadmill`` frame, ``r`` [rad/s].  The velocity over
the belt surface is ``(xdot + V_b, ydot)`` (the surface moves at ``-V_b`` along x, see
conventions.md); rotated into the car frame::

    u = (xdot + V_b) cos(psi) + ydot sin(psi)      (longitudinal, car frame)
    v = -(xdot + V_b) sin(psi) + ydot cos(psi)     (lateral, car frame)

so that ``dx/dt = u cos(psi) - v sin(psi) - V_b`` holds.  ``V_b`` is an optional input
(default 0, i.e. velocities relative to the treadmill frame).

A rejected sample returns ``(None, reason)``; nothing computed from it is kept (no state update).
``stale(now)`` is True when no sample has been accepted for ``stale_timeout`` [s].
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any, Optional, Tuple

from irs_common.field_checks import check_numbers
from irs_models.arm_kinematics import (ArmGeometry, forward_kinematics, sensor_point,
                                      singularity_margin, wrap_angle)
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .differentiator import make_differentiator

__all__ = ['PoseEstimatorParams', 'PoseEstimate', 'PoseEstimator', 'reading_problem',
           'ANGLE_LIMIT', 'BELT_SPEED_LIMIT', 'DEFAULT_FUTURE_TOLERANCE']

#: Largest |joint angle| [rad] that is a reading at all (16 turns; wrapped or unwrapped pots).
ANGLE_LIMIT = 100.0
#: Largest |belt speed| [m/s] that is a reading at all (top speed 6.7 m/s).
BELT_SPEED_LIMIT = 20.0
#: Default ``future_tolerance`` [s] of :class:`PoseEstimator`.
DEFAULT_FUTURE_TOLERANCE = 0.5


def _real(v) -> bool:
    return type(v) is float or (isinstance(v, numbers.Real) and not isinstance(v, bool))


def reading_problem(theta1, theta2, theta3, stamp, belt_speed=0.0) -> Optional[str]:
    """Value checks (step 1 of :meth:`PoseEstimator.update`): ``None`` or why a reading is bad.

    Pure function, no state: a node may call it before its own stamp bookkeeping so that a NaN
    reading is reported as such whatever its stamp.
    """
    if type(theta1) is float and type(theta2) is float and type(theta3) is float and \
            type(stamp) is float and type(belt_speed) is float and \
            abs(theta1) <= ANGLE_LIMIT and abs(theta2) <= ANGLE_LIMIT and \
            abs(theta3) <= ANGLE_LIMIT and abs(belt_speed) <= BELT_SPEED_LIMIT and \
            math.isfinite(stamp):   # the common case, answered first (NaN fails the bounds)
        return None
    for i, a in enumerate((theta1, theta2, theta3)):
        if a is None or not _real(a) or not math.isfinite(a):
            return f'joint {i + 1} angle is not a finite number ({a!r})'
        if abs(a) > ANGLE_LIMIT:
            return f'joint {i + 1} angle {a:.6g} rad is beyond +-{ANGLE_LIMIT:g} rad'
    if stamp is None or not _real(stamp) or not math.isfinite(stamp):
        return f'time stamp is not a finite number ({stamp!r})'
    if belt_speed is None or not _real(belt_speed) or not math.isfinite(belt_speed):
        return f'belt speed is not a finite number ({belt_speed!r})'
    if abs(belt_speed) > BELT_SPEED_LIMIT:
        return f'belt speed {belt_speed:.6g} m/s is beyond +-{BELT_SPEED_LIMIT:g} m/s'
    return None


@dataclass(frozen=True)
class PoseEstimatorParams:
    """Parameters of :class:`PoseEstimator` (units in brackets).

    dt [s] nominal sample period; ds [m] sensor point ahead of the c.g.;
    joint_min / joint_max [rad] mechanical joint ranges (theta1, theta2, theta3);
    belt_half_length, belt_half_width [m]; off_belt_margin [m];
    max_speed [m/s] and max_yaw_rate [rad/s] plausibility bounds, jump_margin [m] and
    jump_margin_psi [rad] allowances on top; stale_timeout [s]; dt_tolerance [-] relative;
    singular_tolerance [rad] elbow-angle margin below which ``near_singular`` is flagged;
    differentiator 'lowpass' | 'savgol', cutoff_hz [Hz], window [samples], order [-].
    """

    dt: float = 0.001
    ds: float = 0.33
    joint_min: Tuple[float, float, float] = (-math.pi, -math.pi, -math.pi)
    joint_max: Tuple[float, float, float] = (math.pi, math.pi, math.pi)
    belt_half_length: float = BELT_HALF_LENGTH
    belt_half_width: float = BELT_HALF_WIDTH
    off_belt_margin: float = 0.10
    max_speed: float = 10.0
    max_yaw_rate: float = 10.0
    jump_margin: float = 0.02
    jump_margin_psi: float = 0.05
    stale_timeout: float = 0.05
    dt_tolerance: float = 0.5
    singular_tolerance: float = math.radians(5.0)
    differentiator: str = 'savgol'
    cutoff_hz: float = 10.0
    window: int = 20
    order: int = 1
    geometry: ArmGeometry = field(default_factory=ArmGeometry)

    def __post_init__(self) -> None:
        check_numbers(self, ('dt', 'belt_half_length', 'belt_half_width', 'max_speed',
                             'max_yaw_rate', 'stale_timeout', 'dt_tolerance', 'cutoff_hz'),
                      above=0.0)
        check_numbers(self, ('ds',))
        check_numbers(self, ('off_belt_margin', 'jump_margin', 'jump_margin_psi',
                             'singular_tolerance'), at_least=0.0)
        if len(self.joint_min) != 3 or len(self.joint_max) != 3 or any(
                not lo < hi for lo, hi in zip(self.joint_min, self.joint_max)):
            raise ValueError('PoseEstimatorParams.joint_min/joint_max must be three (min < max) '
                             'angle pairs in rad.')
        object.__setattr__(self, 'joint_min', tuple(float(v) for v in self.joint_min))
        object.__setattr__(self, 'joint_max', tuple(float(v) for v in self.joint_max))
        if not isinstance(self.geometry, ArmGeometry):
            raise ValueError('PoseEstimatorParams.geometry must be an ArmGeometry.')
        make_differentiator(self.differentiator, self.dt, self.cutoff_hz, self.window, self.order)

    @classmethod
    def from_ros_params(cls, d):
        """Build from the ``arm_pose_estimator.ros__parameters`` mapping of ``sensing.yaml``
        (keys ``rate_hz`` -> ``dt``, ``geometry`` -> :class:`ArmGeometry`; ``calibration`` is
        ignored here, see :func:`irs_sensing.calibration.ArmCalibration.from_dict`).
        """
        import dataclasses
        kw = dict(d)
        kw.pop('calibration', None)
        if 'rate_hz' in kw:
            rate = kw.pop('rate_hz')
            if not isinstance(rate, (int, float)) or not rate > 0:
                raise ValueError(f'rate_hz must be a rate > 0 Hz, got {rate!r}.')
            kw['dt'] = 1.0 / rate
        if 'geometry' in kw:
            kw['geometry'] = ArmGeometry(**kw['geometry'])
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(kw) - names
        if unknown:
            raise ValueError(f'PoseEstimatorParams: unknown parameters {sorted(unknown)}.')
        for key in ('joint_min', 'joint_max'):
            if key in kw:
                kw[key] = tuple(kw[key])
        return cls(**kw)


@dataclass(init=False)
class PoseEstimate:
    """Validated pose [m, rad] and velocities [m/s, rad/s] at time ``stamp`` [s].

    ``velocity_valid`` is False while the differentiators settle after a (re)start; the
    velocity fields are then NaN.
    """

    stamp: float
    x_cg: float
    y_cg: float
    psi: float
    x_s: float
    y_s: float
    xdot: float
    ydot: float
    yaw_rate: float
    u: float
    v: float
    velocity_valid: bool
    near_singular: bool

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, stamp: float, x_cg: float, y_cg: float, psi: float, x_s: float, y_s: float,
                       xdot: float, ydot: float, yaw_rate: float, u: float, v: float,
                       velocity_valid: bool, near_singular: bool) -> None:
        self.stamp = stamp
        self.x_cg = x_cg
        self.y_cg = y_cg
        self.psi = psi
        self.x_s = x_s
        self.y_s = y_s
        self.xdot = xdot
        self.ydot = ydot
        self.yaw_rate = yaw_rate
        self.u = u
        self.v = v
        self.velocity_valid = velocity_valid
        self.near_singular = near_singular


def _joint_ranges(p: PoseEstimatorParams) -> tuple:
    """Per joint ``(low, high, wraps)``: ``wraps`` if the range spans less than 2 pi."""
    return tuple((lo, hi, hi - lo < 2.0 * math.pi) for lo, hi in zip(p.joint_min, p.joint_max))


def _joint_range_problem(angles, ranges: tuple) -> Optional[str]:
    """``None`` if each joint angle [rad] lies in its mechanical range (:func:`_joint_ranges`)
    modulo 2 pi (FK only sees the angle modulo 2 pi: the reading is valid if some
    ``a + 2 pi k`` lies in ``[joint_min, joint_max]``), else a sentence.
    """
    for i, (a, (lo, hi, wraps)) in enumerate(zip(angles, ranges)):
        if wraps:
            shifted = lo + math.fmod(a - lo, 2.0 * math.pi)
            if shifted < lo:
                shifted += 2.0 * math.pi
        else:
            shifted = lo
        if not lo <= shifted <= hi:
            return (f'joint {i + 1} angle {a:.4f} rad outside mechanical range '
                    f'[{lo:.4f}, {hi:.4f}] rad')
    return None


class PoseEstimator:
    """Stateful pose estimator (pipeline: :meth:`update`; velocities: the module docstring).

    ``future_tolerance`` [s] (>= 0): how far ahead of the clock passed as ``now`` to
    :meth:`update` a stamp may be.
    """

    def __init__(self, params: Optional[PoseEstimatorParams] = None,
                 future_tolerance: float = DEFAULT_FUTURE_TOLERANCE) -> None:
        if not _real(future_tolerance) or not (math.isfinite(future_tolerance)
                                                and future_tolerance >= 0):
            raise ValueError(f'future_tolerance must be a finite time >= 0 s, got '
                             f'{future_tolerance!r}.')
        self.future_tolerance = float(future_tolerance)
        self.params = params if params is not None else PoseEstimatorParams()
        p = self.params
        self._diff = [make_differentiator(p.differentiator, p.dt, p.cutoff_hz, p.window, p.order)
                      for _ in range(3)]
        self._ranges_of: Any = None
        self.reset()

    def reset(self) -> None:
        """Forget all history (next valid sample restarts the differentiators)."""
        for d in self._diff:
            d.reset()
        self._last: Any = None     # (t, x, y, psi) of the last accepted sample, or None
        self._psi_unwrapped = 0.0
        self.last_reason = 'no sample yet'

    @property
    def last_valid_stamp(self) -> Optional[float]:
        """Stamp [s] of the last accepted sample, or None."""
        return None if self._last is None else self._last[0]

    def stale(self, now: float) -> bool:
        """True if no sample was accepted within ``stale_timeout`` [s] before ``now`` [s]."""
        return self._last is None or (now - self._last[0]) > self.params.stale_timeout

    def stale_reason(self, now: float) -> str:
        """Empty string if fresh, else a sentence."""
        if self._last is None:
            return 'stale: no valid arm reading received yet'
        age = now - self._last[0]
        if age > self.params.stale_timeout:
            return (f'stale: no valid arm reading for {age:.3f} s '
                    f'(timeout {self.params.stale_timeout:.3f} s)')
        return ''

    def _reject(self, reason: str) -> Tuple[None, str]:
        self.last_reason = reason
        return None, reason

    def update(self, theta1: float, theta2: float, theta3: float, stamp: float,
               belt_speed: float = 0.0,
               now: Optional[float] = None) -> Tuple[Optional[PoseEstimate], str]:
        """Process one reading of the joint angles [rad] taken at ``stamp`` [s].

        Pipeline per sample:

        1. Reject bad values first (:func:`reading_problem`): an angle that is not a finite number
           or beyond ``+-ANGLE_LIMIT`` (100 rad, 16 turns: no potentiometer reads that), a stamp
           that is not a finite number, a belt speed that is not finite or beyond
           ``+-BELT_SPEED_LIMIT`` (20 m/s). Values come before stamps, so a NaN reading is always
           rejected *as a NaN reading* with its reason, whatever its stamp (also a zero stamp, or
           one that repeats the last). Then stamps: with the node's clock ``now`` [s] given, a
           stamp more than ``future_tolerance`` [s] ahead of it is rejected and **never stored**
           (otherwise one reading stamped a day ahead, or at the largest time, makes every later
           reading "not increasing" and hides staleness); then a stamp not later than the last
           accepted one is rejected.
        2. Reject joint angles outside the configured mechanical ranges ``[joint_min, joint_max]``,
           compared modulo 2 pi (a reading ``a`` is accepted if some ``a + 2 pi k`` lies in the
           range), so wrapped (-pi, pi] angles and unwrapped potentiometer angles are treated
           alike.
        3. Forward kinematics (:func:`irs_models.arm_kinematics.forward_kinematics`).
        4. Reject a c.g. off the belt by more than ``off_belt_margin`` [m].
        5. Reject an implausible jump from the last accepted pose: distance > ``max_speed * (t -
           t_last) + jump_margin`` or heading change > ``max_yaw_rate * (t - t_last) +
           jump_margin_psi``.  The bound grows with the elapsed time, so after a genuine fast move
           (e.g. after a stale period) a reading is eventually accepted.
        6. Differentiate ``x_cg, y_cg`` and the *unwrapped* heading with the configured
           :mod:`irs_sensing.differentiator`.  The differentiators assume the nominal period
           ``dt``; if the gap to the last accepted sample differs from ``dt`` by more than
           ``dt_tolerance`` (relative), they are reset and velocities are reported invalid until
           they have settled.

        ``now`` [s] is the node's clock (sim time in lock-step); None skips the future-stamp
        check (offline use). Never raises for bad data.

        Returns ``(PoseEstimate, "")`` or ``(None, reason)``.
        """
        p = self.params
        angles = (theta1, theta2, theta3)
        problem = reading_problem(theta1, theta2, theta3, stamp, belt_speed)
        if problem is not None:
            return self._reject(problem)
        if now is not None and _real(now) and math.isfinite(now) and \
                stamp - now > self.future_tolerance:
            return self._reject(f'time stamp {stamp:.9g} s is {stamp - now:.3g} s ahead of the '
                                f'clock ({now:.9g} s; tolerance {self.future_tolerance:.3g} s)')
        if self._last is not None and stamp <= self._last[0]:
            return self._reject(f'time stamp {stamp:.6f} s does not increase '
                                f'(last {self._last[0]:.6f} s)')
        if self._ranges_of is not p:   # the node may replace its params
            self._ranges_of, self._ranges = p, _joint_ranges(p)
        problem = _joint_range_problem(angles, self._ranges)
        if problem is not None:
            return self._reject(problem)
        pose = forward_kinematics(theta1, theta2, theta3, p.geometry)
        if abs(pose.x_cg) > p.belt_half_length + p.off_belt_margin or \
                abs(pose.y_cg) > p.belt_half_width + p.off_belt_margin:
            return self._reject(
                f'pose ({pose.x_cg:.3f}, {pose.y_cg:.3f}) m is off the belt by more than '
                f'{p.off_belt_margin:.3f} m')
        gap = None
        if self._last is not None:
            t0, x0, y0, psi0 = self._last
            gap = stamp - t0
            dist = math.hypot(pose.x_cg - x0, pose.y_cg - y0)
            lim = p.max_speed * gap + p.jump_margin
            if dist > lim:
                return self._reject(f'implausible jump of {dist:.3f} m in {gap:.4f} s '
                                    f'(limit {lim:.3f} m)')
            dpsi = abs(wrap_angle(pose.psi - psi0))
            lim_psi = p.max_yaw_rate * gap + p.jump_margin_psi
            if dpsi > lim_psi:
                return self._reject(f'implausible heading jump of {dpsi:.3f} rad in {gap:.4f} s '
                                    f'(limit {lim_psi:.3f} rad)')
        # ---- accepted: update state
        if gap is None or abs(gap - p.dt) > p.dt_tolerance * p.dt:
            for d in self._diff:
                d.reset()
            self._psi_unwrapped = pose.psi
        else:
            self._psi_unwrapped += wrap_angle(pose.psi - self._last[3])
        self._last = (float(stamp), pose.x_cg, pose.y_cg, pose.psi)
        d_x, d_y, d_psi = self._diff
        xdot = d_x.update(pose.x_cg)
        ydot = d_y.update(pose.y_cg)
        r = d_psi.update(self._psi_unwrapped)
        valid = d_x.ready and d_y.ready and d_psi.ready
        c, s = math.cos(pose.psi), math.sin(pose.psi)
        if valid:
            ub = xdot + belt_speed
            u = ub * c + ydot * s
            v = -ub * s + ydot * c
        else:
            xdot = ydot = r = u = v = math.nan
        xs, ys = sensor_point(pose, p.ds)
        self.last_reason = ''
        est = PoseEstimate(stamp=float(stamp), x_cg=pose.x_cg, y_cg=pose.y_cg, psi=pose.psi,
                           x_s=xs, y_s=ys, xdot=xdot, ydot=ydot, yaw_rate=r, u=u, v=v,
                           velocity_valid=valid,
                           near_singular=singularity_margin(theta2) < p.singular_tolerance)
        return est, ''
