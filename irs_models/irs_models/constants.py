"""The rig's numbers, each written once (paper Sec. 3 and 5; docs/conventions.md).

Units: m, rad, s. Parameter files (``config/*.yaml``) repeat some of them as the values a
deployment starts with; the code's defaults and bounds come from here.
"""
from __future__ import annotations

__all__ = ['BELT_HALF_LENGTH', 'BELT_HALF_WIDTH', 'STEER_LIMIT', 'STEER_LIMIT_DEG',
           'PAPER_PLANT_GAIN', 'PAPER_ACTUATOR_POLE', 'PAPER_VEHICLE_POLES', 'PAPER_ZEROS',
           'IDENTIFICATION_SPEED', 'SENSOR_DISTANCE']

#: Belt half length, 8 ft / 2 [m] (x, along the belt).
BELT_HALF_LENGTH = 1.2192
#: Belt half width, 4 ft / 2 [m] (y, across the belt).
BELT_HALF_WIDTH = 0.6096
#: Steer limit of the servos [deg] (the actuator model's default travel).
STEER_LIMIT_DEG = 15.0
#: Steer command limit of the controllers [rad]: 15 deg as the rig's configuration writes it
#: (``math.radians(STEER_LIMIT_DEG)`` = 0.261799 is the exact angle).
STEER_LIMIT = 0.2618

#: Plant high-frequency gain b0 of Eq. 6 [m rad^-1 s^-3]: T(0) = Ao(0) Bm(0) / b0 = 23779
#: => b0 = 2308 * 26 * 144 / 23779 = 363.394 (derivation: irs_control.paper_design).
PAPER_PLANT_GAIN = 2308.0 * 26.0 * 144.0 / 23779.0
#: Actuator pole magnitude [rad/s] as printed in Eq. 6 (the 4.6 Hz servo lag, 2 pi 4.6 = 28.90).
PAPER_ACTUATOR_POLE = 29.0
#: Vehicle poles [rad/s] (Eq. 6).
PAPER_VEHICLE_POLES = (0.0, 0.0, -8.0, -20.0)
#: Plant zeros [rad/s] (Eq. 6).
PAPER_ZEROS = (-2.4, -4.8)
#: Speed at which Eq. 6 was identified [m/s].
IDENTIFICATION_SPEED = 1.2
#: Distance of the sensor point ahead of the c.g. in Eq. 6 [m].
SENSOR_DISTANCE = 0.33
