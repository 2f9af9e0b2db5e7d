"""Longitudinal motion of the car over the belt, off-belt detection and wheel speeds.

Longitudinal speed (car forward speed over the belt surface ``u`` [m/s]) follows the driver's
speed command ``u_cmd`` with a first-order lag of time constant ``tau_u`` [s], discretised
exactly for ``u_cmd`` held over the step::

    a = exp(-dt / tau_u),    u_{k+1} = a u_k + (1 - a) u_cmd

Position along the belt (treadmill frame, conventions)::

    dx/dt = u cos(psi) - v sin(psi) - V_b

``psi``, ``v`` (body lateral velocity at the c.g.) and ``V_b`` are held at their values at the
start of the step; the ``u`` term is integrated exactly::

    x_{k+1} = x_k + cos(psi) [u_cmd dt + (u_k - u_cmd) tau_u (1 - a)] - (v sin(psi) + V_b) dt

It exists to give the rig the car's position along the belt (the treadmill regulator's input),
the off-belt fault (:func:`off_belt_edge`) and the kinematic wheel speeds (:func:`wheel_speeds`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from irs_common.field_checks import check_numbers
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

__all__ = ['CarParams', 'CarOnBelt', 'wheel_speeds', 'off_belt_edge',
           'BELT_HALF_LENGTH', 'BELT_HALF_WIDTH']


@dataclass
class CarParams:
    """Car geometry and longitudinal parameters (1:10 scale defaults).

    Attributes
    ----------
    tau_u : float
        Time constant of the speed response to the driver command [s] (default 0.3, assumed).
    length, width : float
        Car body length and width used for the off-belt margin [m] (default 0.45 x 0.20).
    lf, lr : float
        c.g. to front / rear axle [m] (default 0.13 / 0.13, wheelbase 0.26 m).
    track : float
        Track width [m] (default 0.16).
    wheel_radius : float
        Wheel rolling radius [m] (default 0.033).
    """

    tau_u: float = 0.3
    length: float = 0.45
    width: float = 0.20
    lf: float = 0.13
    lr: float = 0.13
    track: float = 0.16
    wheel_radius: float = 0.033

    def validate(self) -> None:
        check_numbers(self, ('tau_u', 'length', 'width', 'lf', 'lr', 'track', 'wheel_radius'),
                      above=0.0)
        if self.length >= 2 * BELT_HALF_LENGTH or self.width >= 2 * BELT_HALF_WIDTH:
            raise ValueError('CarParams.length/width must be smaller than the belt '
                             f'({2 * BELT_HALF_LENGTH} m x {2 * BELT_HALF_WIDTH} m)')


def off_belt_edge(x: float, y: float, params: CarParams) -> str:
    """Edge the c.g. crossed, or ``''`` if it is inside the shrunk belt rectangle.

    Off-belt detection: fault when the c.g. leaves the belt rectangle shrunk by the car's half
    length (in x) and half width (in y), i.e. ``|x| > 1.2192 - length/2`` or ``|y| > 0.6096 -
    width/2``; the edge is reported as ``'front'`` (+x), ``'rear'`` (-x), ``'left'`` (+y) or
    ``'right'`` (-y).

    Non-finite positions are reported as ``'nonfinite'``.
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        return 'nonfinite'
    xm = BELT_HALF_LENGTH - 0.5 * params.length
    ym = BELT_HALF_WIDTH - 0.5 * params.width
    if x > xm:
        return 'front'
    if x < -xm:
        return 'rear'
    if y > ym:
        return 'left'
    if y < -ym:
        return 'right'
    return ''


def wheel_speeds(u: float, v: float, r: float, delta_f: float, delta_r: float,
                 params: CarParams) -> tuple:
    """Kinematic wheel angular speeds ``(FL, FR, RL, RR)`` [rad/s].

    Wheel speeds (independent-wheel-torque, 4WS car; kinematic, no longitudinal slip): the contact
    point of wheel i at body position ``(px_i, py_i)`` moves over the belt surface with body-frame
    velocity ``(u - r py_i, v + r px_i)``; the wheel rolls along its own heading (steer angle
    ``delta_i``, front wheels ``delta_f``, rear wheels ``delta_r``)::

        omega_i = [ (u - r py_i) cos(delta_i) + (v + r px_i) sin(delta_i) ] / R_w

    with ``px = +lf`` (front) / ``-lr`` (rear), ``py = +track/2`` (left) / ``-track/2`` (right).
    Order ``(FL, FR, RL, RR)`` [rad/s], positive = rolling forward.

    Parameters
    ----------
    u, v : float
        Body-frame forward / lateral velocity of the c.g. over the belt surface [m/s].
    r : float
        Yaw rate [rad/s].
    delta_f, delta_r : float
        Achieved front / rear steer angles [rad].
    """
    p = params
    h = 0.5 * p.track
    pos = ((p.lf, h, delta_f), (p.lf, -h, delta_f), (-p.lr, h, delta_r), (-p.lr, -h, delta_r))
    out = []
    for px, py, d in pos:
        vx = u - r * py
        vy = v + r * px
        out.append((vx * math.cos(d) + vy * math.sin(d)) / p.wheel_radius)
    return tuple(out)


class CarOnBelt:
    """Longitudinal state ``(x, u)`` of the car on the belt.

    Parameters
    ----------
    params : CarParams
    x0 : float
        Initial c.g. x [m].
    u0 : float
        Initial forward speed over the belt [m/s].
    """

    def __init__(self, params: CarParams | None = None, x0: float = 0.0, u0: float = 0.0):
        self.params = params if params is not None else CarParams()
        self.params.validate()
        self._x0, self._u0 = float(x0), float(u0)
        self.reset()

    def reset(self, x0: float | None = None, u0: float | None = None) -> None:
        """Reset to ``x0`` [m], ``u0`` [m/s] (default: the constructor values)."""
        if x0 is not None:
            self._x0 = float(x0)
        if u0 is not None:
            self._u0 = float(u0)
        self.x = self._x0
        self.u = self._u0

    def step(self, u_cmd: float, psi: float, v: float, belt_speed: float, dt: float) -> None:
        """Advance dt [s]; ``u_cmd`` [m/s], ``psi`` [rad], ``v`` [m/s] and ``belt_speed`` [m/s]
        held over the step.
        """
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite step in s, got {dt!r}')
        tau = self.params.tau_u
        a = math.exp(-dt / tau)
        u_int = u_cmd * dt + (self.u - u_cmd) * tau * (1.0 - a)   # exact integral of u
        self.x += math.cos(psi) * u_int - (v * math.sin(psi) + belt_speed) * dt
        self.u = a * self.u + (1.0 - a) * u_cmd

    def edge(self, y: float) -> str:
        """Off-belt edge for the current x and the given c.g. lateral position y [m]."""
        return off_belt_edge(self.x, y, self.params)
