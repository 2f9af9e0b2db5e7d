"""The ABS's reference speed from the wheels: encoders, the applied torques, the belt (ROS-free).

A braking car has no free-rolling wheel, so its speed is integrated from the tyre forces, which
the wheels' own torque balance gives (``J domega/dt = T - R F_x - T_rr``)::

    dv/dt = sum_i F_x,i / m + a_b,    R F_x,i = T_i - T_rr,i - J domega_i/dt
    T_rr,i = f_r F_z0 R tanh(omega_i R / v_rr),   F_z0 = m g / 4

``T_i`` [N m] the torque applied over the last step (the controller's own command), ``omega_i``
[rad/s] the encoders', ``a_b`` [m/s^2] the belt's acceleration from its measured speed (the
car's speed is over the belt, whose frame accelerates: two_track.py). The inertia and belt terms
are differences, so their integrals are exact (``J (omega_k - omega_0)``, ``V_b,k - V_b,0``)
whatever the encoders' quantisation. While no brake is asked for, the wheels' mean
``mean(omega_i) R`` also corrects it, ``dv/dt += (mean(omega_i) R - v) / free_time`` (free-rolling
wheels: the drive slip at belt speed is 0.6 %, the rolling resistance's -f_r / C_k = -0.2 %;
``free_time`` averages out the encoders' steps). While a wheel is held by a friction brake its
torque is unknown: ``v`` is the wheels' speed. The
encoders' rim speed is no upper or lower bound while braking: with the relaxed slip a released
wheel overshoots the car's speed. Used instead of the arm's speed, which a real car lacks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from irs_common.field_checks import check_numbers

__all__ = ['WheelSpeedParams', 'WheelSpeedObserver']

_G = 9.81


@dataclass
class WheelSpeedParams:
    """Nominal car for the reference speed (the two-track model's values, assumed known).

    Attributes
    ----------
    mass : float
        m [kg] (default 2.86, the torque car).
    wheel_radius : float
        R [m] (0.033).
    wheel_inertia : float
        J [kg m^2] (5e-5).
    rolling_resistance : float
        f_r [-] (0.02).
    rr_speed : float
        v_rr [m/s] (0.02).
    free_time : float
        Time constant over which the free-rolling wheels' mean is averaged [s] (0.02: the
        encoders' 0.61 rad/s steps are 0.02 m/s of rim speed).
    """

    mass: float = 2.86
    wheel_radius: float = 0.033
    wheel_inertia: float = 5e-5
    rolling_resistance: float = 0.02
    rr_speed: float = 0.02
    free_time: float = 0.02

    def __post_init__(self):
        check_numbers(self, ('mass', 'wheel_radius', 'wheel_inertia', 'rr_speed', 'free_time'),
                      above=0.0)
        check_numbers(self, ('rolling_resistance',), at_least=0.0)


class WheelSpeedObserver:
    """Speed of the car over the belt from its wheels (module docstring)."""

    def __init__(self, params: WheelSpeedParams | None = None, n: int = 4):
        self.params = params if params is not None else WheelSpeedParams()
        self.n = int(n)
        self.reset()

    def reset(self) -> None:
        """No estimate until the next sample."""
        self.estimate = math.nan
        self.forces = np.zeros(self.n)
        self._omega = None
        self._belt = None

    def rolling_torques(self, omega) -> np.ndarray:
        """``T_rr,i`` [N m] at the spins ``omega`` [rad/s] and the static load."""
        p = self.params
        fz0 = p.mass * _G / self.n
        r = p.wheel_radius
        return p.rolling_resistance * fz0 * r * np.tanh(np.asarray(omega, float) * r / p.rr_speed)

    def step(self, omega, torques, braking: bool, held: bool, belt_speed: float,
             dt: float) -> float:
        """The speed [m/s] after this sample.

        Parameters
        ----------
        omega : sequence of n float
            Encoder wheel speeds now [rad/s].
        torques : sequence of n float
            Torques applied since the previous sample [N m].
        braking : bool
            A brake is requested (integrate); else the wheels' mean.
        held : bool
            Friction brakes hold the wheels (the torques are unknown): the wheels' speed.
        belt_speed : float
            Measured belt speed [m/s] (its change enters as the belt frame's acceleration).
        dt : float
            Step [s] (> 0).
        """
        p = self.params
        w = np.asarray(omega, float)
        wheels = float(np.mean(w)) * p.wheel_radius
        if self._omega is None or held or not math.isfinite(self.estimate):
            self.estimate = wheels
            self.forces = np.zeros(self.n)
        else:
            t = np.asarray(torques, float)
            self.forces = (t - self.rolling_torques(w) - p.wheel_inertia * (w - self._omega) / dt
                           ) / p.wheel_radius
            self.estimate += dt * float(np.sum(self.forces)) / p.mass + (belt_speed - self._belt)
            if not braking:     # free-rolling wheels correct it (their 0.02 m/s steps averaged)
                self.estimate += min(1.0, dt / p.free_time) * (wheels - self.estimate)
        self._omega = w.copy()
        self._belt = float(belt_speed)
        return self.estimate
