"""Common interface of the lateral plants used by the rig, and the physical bicycle plant.

``LateralPlant`` (a ``typing.Protocol``) is what :class:`irs_vehicle_sim.rig.RigSimulation`
needs: ``reset(y0)`` (heading 0, the car at lateral position ``y0`` [m], where the c.g. and the
sensor point coincide), ``step(delta_front, delta_rear, dt)`` with the *achieved* steer angles
[rad] held constant (ZOH) over the step, ``curvature_gain(speed)``
(:meth:`ZohSteps.curvature_gain`) and read-only outputs

* ``y_s`` [m]: sensor-point lateral displacement, ``y_s = y_cg + ds sin(psi)`` (conventions),
* ``y_cg`` [m]: c.g. lateral position in the treadmill frame,
* ``psi`` [rad]: heading (CCW from +x),
* ``yaw_rate`` [rad/s],
* ``lateral_velocity`` [m/s]: body-frame lateral velocity ``v`` at the c.g. (used by the
  longitudinal kinematics ``dx/dt = u cos psi - v sin psi - V_b``).

Implementations: :class:`irs_models.identified.IdentifiedPlant` (paper Eq. 6) and
:class:`BicyclePlant` below (states ``[v_y, r, y, psi]`` of
:func:`irs_models.bicycle.bicycle_state_space`, exact ZOH discretisation by
:func:`irs_models.zoh.zoh`).  The bicycle model is linear at a fixed speed ``speed``;
like the identified plant it does not rescale with the car's actual speed.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from .zoh import zoh

__all__ = ['LateralPlant', 'ZohSteps', 'BicyclePlant']


@runtime_checkable
class LateralPlant(Protocol):
    """Interface of a lateral vehicle plant (see module docstring for units)."""

    def reset(self, y0: float = 0.0, /) -> None: ...

    def step(self, delta_front: float, delta_rear: float, dt: float) -> None: ...

    def curvature_gain(self, speed: float) -> float: ...

    @property
    def y_s(self) -> float: ...

    @property
    def y_cg(self) -> float: ...

    @property
    def psi(self) -> float: ...

    @property
    def yaw_rate(self) -> float: ...

    @property
    def lateral_velocity(self) -> float: ...


class ZohSteps:
    """Exact zero-order-hold steps of a continuous plant with matrices ``A, B, C, D``
    (:func:`irs_models.zoh.zoh`), computed once per step size.
    """

    def discrete(self, dt: float):
        """(Ad, Bd) for step dt [s] (cached)."""
        cache = self._zoh_cache
        if dt not in cache:
            if not (math.isfinite(dt) and dt > 0.0):
                raise ValueError(f'dt must be a positive finite step in s, got {dt!r}')
            cache[dt] = zoh(self.A, self.B, dt)
        return cache[dt]

    def curvature_gain(self, speed: float) -> float:
        """Steady path curvature per unit front steer, ``kappa = lim_{s->0} s^2 G(s) / U^2``
        [1/(m rad)], with ``G`` the front steer -> ``y_s`` transfer function (output 0) and
        ``U = speed`` [m/s]: the sensor point's acceleration per radian in a steady turn, per
        ``U^2``. A kinematic bicycle gives ``1 / L``; an understeering one ``1 / (L + K U^2)``.
        Evaluated at ``s = 1e-6`` 1/s (``G`` has a double pole at 0; relative error ~1e-6).
        """
        s = 1e-6
        n = self.A.shape[0]
        g = self.C[0] @ np.linalg.solve(s * np.eye(n) - self.A, self.B[:, 0]) + self.D[0, 0]
        return float(s * s * g) / (float(speed) ** 2)


class BicyclePlant(ZohSteps):
    """Linear bicycle model, exact ZOH discretisation, implementing :class:`LateralPlant`.

    Parameters
    ----------
    params : irs_models.bicycle.BicycleParams
    speed : float
        Forward speed V of the linearisation [m/s].
    ds : float
        Sensor distance ahead of the c.g. [m].
    """

    def __init__(self, params, speed: float, ds: float):
        self._zoh_cache = {}
        from .bicycle import bicycle_state_space

        self.params = params
        self.speed = float(speed)
        self.ds = float(ds)
        self.A, self.B, self.C, self.D = bicycle_state_space(params, speed, ds)
        self.x = np.zeros(4)

    def reset(self, y_cg: float = 0.0, psi: float = 0.0) -> None:
        """Zero velocities, c.g. at lateral position ``y_cg`` [m] with heading ``psi`` [rad]."""
        self.x = np.array([0.0, 0.0, float(y_cg), float(psi)])

    def step(self, delta_front: float, delta_rear: float = 0.0, dt: float = 1e-3) -> None:
        """Advance dt [s] with achieved steer angles [rad] held constant."""
        Ad, Bd = self.discrete(dt)
        self.x = Ad @ self.x + Bd @ np.array([float(delta_front), float(delta_rear)])

    @property
    def lateral_velocity(self) -> float:
        """v_y [m/s] (body frame, at the c.g.)."""
        return float(self.x[0])

    @property
    def yaw_rate(self) -> float:
        """r [rad/s]."""
        return float(self.x[1])

    @property
    def y_cg(self) -> float:
        """y [m]."""
        return float(self.x[2])

    @property
    def psi(self) -> float:
        """psi [rad]."""
        return float(self.x[3])

    @property
    def y_s(self) -> float:
        """y_s = y + ds sin(psi) [m] (the linear model output C x uses ds psi; equal to first
        order).
        """
        return self.y_cg + self.ds * math.sin(self.psi)
