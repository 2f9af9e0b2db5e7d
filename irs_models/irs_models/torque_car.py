"""The torque car's linear (bicycle) model: the ``irs_iwt`` preset's car on rubber 1:10 tyres.

Pure Python; no rclpy. The two-track model (irs_vehicle_sim.two_track) and the chassis
controller's yaw-rate reference (irs_control.chassis_control) both take the car from here, so at
small slip the plant and the controller's model are the same bicycle.

Geometry, mass and inertia are the ``irs_iwt`` preset's (irs_models/config/presets.yaml). Its
cornering stiffnesses are not used: the preset fitted them to Eq. 6 with parameters on their
bounds (2.2 and 1.4 /rad per unit load), and with them a tyre whose force curve is concave peaks
only at 46-59 deg of slip angle on mu 0.8. The torque car's tyres take the cornering stiffness
per unit load of f1tenth_gym's 1:10 car (a Traxxas chassis on rubber tyres; its single-track
model writes ``F_y = mu C_S F_z alpha`` with ``mu = 1.0489``, ``C_Sf = 4.718``, ``C_Sr =
5.4562 /rad``): ``C_a = mu C_S`` = 4.949 (front) and 5.723 /rad (rear), so the axles have
``c = C_a m g l_other / L``.
"""
from __future__ import annotations

import functools
from dataclasses import replace

from .bicycle import BicycleParams

__all__ = ['CORNERING_STIFFNESS_PER_LOAD', 'GRAVITY', 'torque_car_bicycle']

#: Cornering stiffness per unit load of the rubber 1:10 tyres, front and rear [1/rad]
#: (f1tenth_gym: 1.0489 x 4.718 and 1.0489 x 5.4562).
CORNERING_STIFFNESS_PER_LOAD = (1.0489 * 4.718, 1.0489 * 5.4562)
#: [m/s^2]
GRAVITY = 9.81


@functools.lru_cache(maxsize=1)
def torque_car_bicycle() -> BicycleParams:
    """BicycleParams of the torque car: ``irs_iwt`` with ``c_f``, ``c_r`` [N/rad] from the
    rubber tyres' stiffness per unit load times the static axle loads ``m g l_r / L``,
    ``m g l_f / L`` [N] (frozen, safe to share).
    """
    from .presets import get_preset

    p = get_preset('irs_iwt').params
    load = p.mass * GRAVITY / p.wheelbase
    ca_f, ca_r = CORNERING_STIFFNESS_PER_LOAD
    return replace(p, c_f=ca_f * load * p.lr, c_r=ca_r * load * p.lf)
