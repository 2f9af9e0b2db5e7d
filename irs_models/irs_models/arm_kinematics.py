"""Planar two-link position-sensing arm of the IRS (paper Sec. 3.2, Fig. 3, Eq. 3).

Eq. 3 (reconstructed from the OCR: :func:`forward_kinematics`) with the project's frames, base
offset and attach offset (``docs/conventions.md``); the third potentiometer gives the car axis
relative to link 2::

    x_tip = base_x + L1 cos(theta1) + L2 cos(theta1 + theta2)
    y_tip = base_y + L1 sin(theta1) + L2 sin(theta1 + theta2)
    psi   = theta1 + theta2 + theta3
    x_cg  = x_tip - attach_offset cos(psi),   y_cg = y_tip - attach_offset sin(psi)

All angles are in rad, CCW positive, wrapped to (-pi, pi]; lengths in m.

The arm exists because the car on the belt carries no position sensor: the estimator turns the
three potentiometer angles into the car's pose (:func:`forward_kinematics`), and the rig's
simulated sensor does the reverse (:func:`inverse_kinematics`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

__all__ = [
    'ArmGeometry',
    'ArmPose',
    'ArmReachError',
    'wrap_angle',
    'forward_kinematics',
    'inverse_kinematics',
    'singularity_margin',
    'is_near_singular',
    'tip_jacobian_determinant',
    'sensor_point',
]


class ArmReachError(ValueError):
    """Raised when a requested c.g. pose puts the arm tip outside the arm's reachable annulus."""


def wrap_angle(angle: float) -> float:
    """Wrap an angle [rad] to the half-open interval (-pi, pi].

    ``wrap(a) = pi - ((pi - a) mod 2 pi)``; ``wrap(pi) = wrap(-pi) = pi``.
    """
    a = float(angle)
    w = math.pi - math.fmod(math.pi - a, 2.0 * math.pi)
    if w > math.pi:  # fmod keeps the sign of the dividend
        w -= 2.0 * math.pi
    if w <= -math.pi:
        w += 2.0 * math.pi
    return w


@dataclass(frozen=True)
class ArmGeometry:
    """Geometry of the sensing arm (see ``docs/conventions.md``).

    Parameters
    ----------
    l1 : float
        Length of link 1 (base to elbow) [m], > 0.
    l2 : float
        Length of link 2 (elbow to tip / joint 3) [m], > 0.
    base_x, base_y : float
        Position of joint 1 in the ``treadmill`` frame [m].
    attach_offset : float
        Distance of the arm tip (joint 3) ahead of the car's c.g. along the car axis [m].
    elbow : int
        Inverse-kinematics branch: +1 selects theta2 in (0, pi), -1 selects theta2 in (-pi, 0).
    """

    l1: float = 1.0
    l2: float = 1.0
    base_x: float = 0.0
    base_y: float = 0.85
    attach_offset: float = 0.0
    elbow: int = 1

    def __post_init__(self) -> None:
        for name in ('l1', 'l2', 'base_x', 'base_y', 'attach_offset'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(
                    f'ArmGeometry.{name} must be a real number in metres, got {value!r}.'
                )
            if not math.isfinite(value):
                raise ValueError(f'ArmGeometry.{name} must be finite, got {value!r}.')
            object.__setattr__(self, name, float(value))
        if self.l1 <= 0.0 or self.l2 <= 0.0:
            raise ValueError(
                f'ArmGeometry link lengths l1, l2 must be > 0 m, got l1={self.l1}, l2={self.l2}.')
        if self.elbow not in (1, -1) or isinstance(self.elbow, bool):
            raise ValueError(f'ArmGeometry.elbow must be +1 or -1, got {self.elbow!r}.')
        object.__setattr__(self, 'elbow', int(self.elbow))

    @property
    def max_reach(self) -> float:
        """Largest base-to-tip distance ``l1 + l2`` [m] (stretched arm, theta2 = 0)."""
        return self.l1 + self.l2

    @property
    def min_reach(self) -> float:
        """Smallest base-to-tip distance ``|l1 - l2|`` [m] (folded arm, theta2 = pi)."""
        return abs(self.l1 - self.l2)


@dataclass(init=False)
class ArmPose:
    """Pose computed from the arm [m, m, rad, m, m] in the ``treadmill`` frame."""

    x_cg: float
    y_cg: float
    psi: float
    x_tip: float
    y_tip: float

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, x_cg: float, y_cg: float, psi: float, x_tip: float, y_tip: float) -> None:
        self.x_cg = x_cg
        self.y_cg = y_cg
        self.psi = psi
        self.x_tip = x_tip
        self.y_tip = y_tip


def forward_kinematics(theta1: float, theta2: float, theta3: float,
                       geometry: ArmGeometry) -> ArmPose:
    """Car c.g. pose from the three joint angles (Eq. 3, reconstruction in the notes).

    Parameters
    ----------
    theta1 : float
        Link 1 angle from +x [rad].
    theta2 : float
        Link 2 angle relative to link 1 [rad].
    theta3 : float
        Car axis relative to link 2 [rad].
    geometry : ArmGeometry

    Returns
    -------
    ArmPose
        ``x_cg, y_cg`` [m], ``psi`` [rad] wrapped to (-pi, pi], ``x_tip, y_tip`` [m].

    Notes
    -----
    The OCR text of Eq. 3 reads::

        x = Ll co&t + L* CO&~
        y = L, .sin(Ot +02) + L2 .sin(t!lt +e2)

    The ``y`` line shows the pattern ``L_i sin(sum of angles)`` and the ``x`` line the matching
    ``L1 cos(...) + L2 cos(...)``.  The only planar two-link relation consistent with the surviving
    symbols (two links L1, L2, relative joint angles theta1, theta2 as in Fig. 3) is the standard
    serial-chain forward kinematics::

        x = L1 cos(theta1) + L2 cos(theta1 + theta2)
        y = L1 sin(theta1) + L2 sin(theta1 + theta2)

    (the OCR's first ``y`` term ``L1 sin(theta1 + theta2)`` is taken as a garbling of ``L1
    sin(theta1)``: with it the ``x`` and ``y`` lines would not describe the same point).  The third
    potentiometer gives the car axis relative to link 2, so the heading is ``psi = theta1 + theta2
    + theta3``.  The project's frames, base offset and attach offset follow
    ``docs/conventions.md``::
    """
    g = geometry
    a12 = theta1 + theta2
    x_tip = g.base_x + g.l1 * math.cos(theta1) + g.l2 * math.cos(a12)
    y_tip = g.base_y + g.l1 * math.sin(theta1) + g.l2 * math.sin(a12)
    psi = wrap_angle(a12 + theta3)
    x_cg = x_tip - g.attach_offset * math.cos(psi)
    y_cg = y_tip - g.attach_offset * math.sin(psi)
    return ArmPose(x_cg=x_cg, y_cg=y_cg, psi=psi, x_tip=x_tip, y_tip=y_tip)


def inverse_kinematics(x_cg: float, y_cg: float, psi: float,
                       geometry: ArmGeometry,
                       reach_tolerance: float = 1e-9) -> Tuple[float, float, float]:
    """Joint angles that put the car's c.g. at ``(x_cg, y_cg)`` with heading ``psi``.

    The tip is ``(x_cg + a cos psi, y_cg + a sin psi)`` with ``a = attach_offset``.  With
    ``(dx, dy)`` the tip relative to the base and ``r^2 = dx^2 + dy^2`` (law of cosines)::

        cos(theta2) = (r^2 - L1^2 - L2^2) / (2 L1 L2),   theta2 = elbow * arccos(.)
        theta1 = atan2(dy, dx) - atan2(L2 sin theta2, L1 + L2 cos theta2)
        theta3 = psi - theta1 - theta2

    Parameters
    ----------
    x_cg, y_cg : float
        Target c.g. position [m].
    psi : float
        Target heading [rad].
    geometry : ArmGeometry
    reach_tolerance : float
        Distance [m] by which the tip may lie outside the reachable annulus and still be
        accepted (projected onto the boundary) to absorb round-off.

    Returns
    -------
    (theta1, theta2, theta3) : tuple of float
        Joint angles [rad] wrapped to (-pi, pi].  On the singular boundaries the elbow branch is
        irrelevant (theta2 = 0 or pi).  For the fully folded arm with ``L1 == L2`` at the base,
        theta1 is arbitrary and 0 is returned.

    Raises
    ------
    ArmReachError
        If the tip is farther than ``l1 + l2`` or closer than ``|l1 - l2|`` to the base
        (beyond ``reach_tolerance``), or the inputs are not finite.
    """
    g = geometry
    for name, v in (('x_cg', x_cg), ('y_cg', y_cg), ('psi', psi)):
        if not math.isfinite(v):
            raise ArmReachError(f'inverse_kinematics expected a finite {name}, got {v!r}.')
    x_tip = x_cg + g.attach_offset * math.cos(psi)
    y_tip = y_cg + g.attach_offset * math.sin(psi)
    dx = x_tip - g.base_x
    dy = y_tip - g.base_y
    r = math.hypot(dx, dy)
    if r > g.max_reach + reach_tolerance:
        raise ArmReachError(
            f'Arm tip ({x_tip:.4f}, {y_tip:.4f}) m is {r:.4f} m from the base, beyond the '
            f'maximum reach l1 + l2 = {g.max_reach:.4f} m.')
    if r < g.min_reach - reach_tolerance:
        raise ArmReachError(
            f'Arm tip ({x_tip:.4f}, {y_tip:.4f}) m is {r:.4f} m from the base, inside the '
            f'minimum reach |l1 - l2| = {g.min_reach:.4f} m.')
    c2 = (r * r - g.l1 ** 2 - g.l2 ** 2) / (2.0 * g.l1 * g.l2)
    c2 = min(1.0, max(-1.0, c2))
    theta2 = g.elbow * math.acos(c2)
    if r == 0.0:
        theta1 = 0.0  # folded arm with l1 == l2 at the base: theta1 undetermined
    else:
        theta1 = math.atan2(dy, dx) - math.atan2(g.l2 * math.sin(theta2),
                                                 g.l1 + g.l2 * math.cos(theta2))
    theta3 = psi - theta1 - theta2
    return wrap_angle(theta1), wrap_angle(theta2), wrap_angle(theta3)


def singularity_margin(theta2: float) -> float:
    """Angular distance [rad] of the elbow angle from the nearest singular configuration.

    Singular configurations are the stretched (theta2 = 0) and folded (theta2 = +-pi) arm, where
    the tip Jacobian determinant ``L1 L2 sin(theta2)`` vanishes and the IK branches merge.
    Returns ``min(|w|, pi - |w|)`` with ``w = wrap(theta2)``, in [0, pi/2].
    """
    w = abs(wrap_angle(theta2))
    return min(w, math.pi - w)


def is_near_singular(theta2: float, tolerance: float = math.radians(5.0)) -> bool:
    """True if ``singularity_margin(theta2) < tolerance`` [rad] (default 5 deg = 0.0873 rad)."""
    if tolerance < 0.0 or not math.isfinite(tolerance):
        raise ValueError(f'tolerance must be a finite angle >= 0 rad, got {tolerance!r}.')
    return singularity_margin(theta2) < tolerance


def tip_jacobian_determinant(theta2: float, geometry: ArmGeometry) -> float:
    """Determinant ``L1 L2 sin(theta2)`` [m^2] of d(x_tip, y_tip)/d(theta1, theta2)."""
    return geometry.l1 * geometry.l2 * math.sin(theta2)


def sensor_point(pose: ArmPose, ds: float) -> Tuple[float, float]:
    """Lateral sensor point ``ds`` metres ahead of the c.g. on the car's axis.

    ``x_s = x_cg + ds cos(psi)``, ``y_s = y_cg + ds sin(psi)`` [m] (paper's Y_s).
    """
    if not math.isfinite(ds):
        raise ValueError(f'ds must be a finite distance in metres, got {ds!r}.')
    return (pose.x_cg + ds * math.cos(pose.psi), pose.y_cg + ds * math.sin(pose.psi))
