"""Planar heading <-> quaternion, written once (ROS-free; REP 103: z up, yaw CCW from +x).

The graph carries headings as ``geometry_msgs/Quaternion`` rotations about z; the cores use
the yaw angle ``psi`` [rad].
"""
from __future__ import annotations

import math

__all__ = ['quaternion_from_yaw', 'yaw_from_quaternion']


def quaternion_from_yaw(psi: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of the rotation by ``psi`` [rad] about z."""
    return 0.0, 0.0, math.sin(psi / 2.0), math.cos(psi / 2.0)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw [rad] in (-pi, pi] of the unit quaternion ``(x, y, z, w)`` (the z of its ZYX Euler
    angles).
    """
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
