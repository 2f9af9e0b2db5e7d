"""The paper's identified lateral plant (Eq. 6) without the steering actuator.

Paper Eq. 6 (vehicle at U = 1.2 m/s, sensor ds = 0.33 m ahead of the c.g.), from the front steer
*command* to the sensor-point lateral displacement::

    P(s) = b0 (s + 2.4)(s + 4.8) / ( s^2 (s + 8)(s + 20)(s + 29) )

The -29 rad/s pole is the 4.6 Hz steering-actuator lag (2 pi 4.6 = 28.9 rad/s), which the
simulation reproduces with :mod:`irs_vehicle_sim.actuator` (unity DC gain, ``29/(s+29)``).  The
plant from the **achieved** front steer angle delta [rad] to y_s [m] is therefore::

    G(s) = K (s + 2.4)(s + 4.8) / ( s^2 (s + 8)(s + 20) ),    K = b0 / 29

Gain derivation: the high-frequency gain of the *full* plant is b0 = 2308 / 6.351 = 363.4
(reference-model numerator 2308 of Eq. 21 over the OCR'd leading coefficient of T, Eq. 24),
:data:`irs_models.constants.PAPER_PLANT_GAIN` = 363.394.  Because the actuator block is the
unity-DC-gain lag ``29/(s+29)``, the actuator-free gain is ``K = b0 / 29 = 12.53 m/s^2/rad``.
(Sanity check: with K = 363.4 the paper's PI loop Kp = 5, Ki = 3, which the paper ran on the car,
would be unstable; with K = 12.53 it is stable with about 34 deg phase margin.)

Realisation (states chosen so that y_s and its rate are states)::

    x = [y_s, v_s, z1, z2]           v_s = dy_s/dt [m/s]
    z1' = z2,   z2' = -160 z1 - 28 z2 + delta        (denominator (s+8)(s+20) = s^2+28s+160)
    v_s' = a_s = K (delta - 148.48 z1 - 20.8 z2)
                 (numerator/denominator - 1 = (-20.8 s - 148.48)/(...))
    y_s' = v_s

so ``a_s / delta = K (s^2 + 7.2 s + 11.52) / (s^2 + 28 s + 160)``.  Discretised exactly (ZOH on
delta) by ``scipy.signal.cont2discrete`` (the matrix exponential of ``[[A, B], [0, 0]] dt``).
:func:`identified_plant` gives the same plant (with or without the actuator) as polynomials.

Pose: the identified model has no sideslip state, so the heading is taken kinematically from the
sensor-point lateral velocity, ``psi = v_s / U`` (small-angle, as the linear model), the yaw rate
``r = a_s / U``, the body lateral velocity at the c.g. is zero, and ``y_cg = y_s - ds sin(psi)``
(conventions: ``y_s = y + ds sin psi``).  The model is LTI at the identification speed U; it
does not rescale with the actual car speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import (IDENTIFICATION_SPEED, PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN,
                        PAPER_VEHICLE_POLES, PAPER_ZEROS, SENSOR_DISTANCE)
from .lateral_plant import ZohSteps

__all__ = ['IdentifiedParams', 'IdentifiedPlant', 'identified_matrices', 'identified_plant']


def identified_plant(include_actuator: bool = True, actuator_pole: float = PAPER_ACTUATOR_POLE,
                     gain: float = PAPER_PLANT_GAIN):
    """Identified plant ``B/A`` of Eq. 6 (steer [rad] -> y_s [m]), highest power first.

    Parameters
    ----------
    include_actuator : bool
        True: full identified plant with the actuator pole at ``-actuator_pole``.
        False: vehicle only, i.e. the actuator lag ``p/(s + p)`` (unit DC gain) replaced by 1:
        ``G_veh = G (s + p)/p``, so ``B_veh = (gain/p)(s+2.4)(s+4.8)`` and both plants have
        the same low-frequency behaviour ``y_s ~ gain*11.52/(160 p) / s^2 = 0.902/s^2``.
    actuator_pole : float
        Actuator pole magnitude p [rad/s] (> 0).
    gain : float
        High-frequency gain ``b0`` of the full plant (with actuator) [m rad^-1 s^-3].

    Returns
    -------
    B, A : numpy.ndarray
        ``B = gain (s+2.4)(s+4.8)``, ``A = s^2 (s+8)(s+20)(s+p)`` (with actuator) or
        ``B = (gain/p)(s+2.4)(s+4.8)``, ``A = s^2 (s+8)(s+20)`` (without).
    """
    if not (np.isfinite(actuator_pole) and actuator_pole > 0):
        raise ValueError('actuator_pole must be a positive finite magnitude in rad/s; '
                         f'got {actuator_pole}.')
    if not (np.isfinite(gain) and gain != 0):
        raise ValueError('gain must be a finite non-zero plant gain b0 in m rad^-1 s^-3; '
                         f'got {gain}.')
    poles = list(PAPER_VEHICLE_POLES)
    if include_actuator:
        poles.append(-float(actuator_pole))
    else:
        gain = gain / float(actuator_pole)
    # real roots: np.poly gives the real coefficients (numpy.poly is the product of (s - r_i))
    return (gain * np.real(np.poly(np.asarray(PAPER_ZEROS, dtype=complex))),
            np.real(np.poly(np.asarray(poles, dtype=complex))))


@dataclass
class IdentifiedParams:
    """Parameters of the identified plant G(s) (Eq. 6 without the actuator).

    Attributes
    ----------
    gain : float or None
        K [m/s^2 per rad], high-frequency gain of y_s'' / delta.  None -> b0 / 29
        (:data:`~irs_models.constants.PAPER_PLANT_GAIN` / the actuator pole).
    zeros : tuple of float
        Zeros of G [rad/s] (negative real), default (-2.4, -4.8).
    poles : tuple of float
        Non-origin poles of G [rad/s], default (-8, -20).  Two poles at the origin are implied.
    speed : float
        Identification speed U [m/s], used for psi = v_s / U.  Default 1.2.
    ds : float
        Sensor distance ahead of the c.g. [m].  Default 0.33.
    """

    gain: float | None = None
    zeros: tuple = (-2.4, -4.8)
    poles: tuple = (-8.0, -20.0)
    speed: float = IDENTIFICATION_SPEED
    ds: float = SENSOR_DISTANCE

    def resolved_gain(self) -> float:
        """K [m/s^2/rad]: ``gain`` or b0 / 29 from the paper."""
        return (
            float(self.gain) if self.gain is not None else PAPER_PLANT_GAIN / PAPER_ACTUATOR_POLE
        )

    def validate(self) -> None:
        if len(self.zeros) != 2 or len(self.poles) != 2:
            raise ValueError('zeros and poles must each hold exactly two real values in rad/s')
        if not all(math.isfinite(float(v)) for v in (*self.zeros, *self.poles)):
            raise ValueError('zeros and poles must be finite values in rad/s')
        if not (math.isfinite(self.resolved_gain()) and self.resolved_gain() > 0.0):
            raise ValueError(
                f'gain must be a positive finite value in m/s^2/rad, got {self.gain!r}'
            )
        if not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError(f'speed must be a positive speed in m/s, got {self.speed!r}')
        if not (math.isfinite(self.ds) and self.ds >= 0.0):
            raise ValueError(f'ds must be a non-negative distance in m, got {self.ds!r}')


def identified_matrices(params: IdentifiedParams | None = None):
    """Continuous realisation (A, B, C, D) of G(s), states [y_s, v_s, z1, z2], input delta [rad],
    output y_s [m].  Also returns the acceleration row (Ca, Da) with a_s = Ca x + Da delta.

    Returns
    -------
    A, B, C, D, Ca, Da : numpy.ndarray
    """
    p = params if params is not None else IdentifiedParams()
    p.validate()
    K = p.resolved_gain()
    z1, z2 = (-float(z) for z in p.zeros)     # numerator s^2 + n1 s + n0
    p1, p2 = (-float(q) for q in p.poles)     # denominator s^2 + d1 s + d0
    n1, n0 = z1 + z2, z1 * z2
    d1, d0 = p1 + p2, p1 * p2
    # a_s = K [1 + ((n1-d1) s + (n0-d0)) / (s^2 + d1 s + d0)] delta
    Ca = np.array([[0.0, 0.0, K * (n0 - d0), K * (n1 - d1)]])
    Da = np.array([[K]])
    A = np.zeros((4, 4))
    A[0, 1] = 1.0
    A[1, :] = Ca[0]
    A[2, 3] = 1.0
    A[3, 2] = -d0
    A[3, 3] = -d1
    B = np.array([[0.0], [K], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0, 0.0]])
    D = np.zeros((1, 1))
    return A, B, C, D, Ca, Da


class IdentifiedPlant(ZohSteps):
    """Discrete (exact ZOH) identified plant implementing the ``LateralPlant`` interface.

    ``step(delta_front, delta_rear, dt)`` ignores ``delta_rear`` (Eq. 6 is front-steer only).
    """

    def __init__(self, params: IdentifiedParams | None = None):
        self.params = params if params is not None else IdentifiedParams()
        self.A, self.B, self.C, self.D, self.Ca, self.Da = identified_matrices(self.params)
        self.x = np.zeros(4)
        self._delta = 0.0

    def reset(self, y_s: float = 0.0) -> None:
        """Zero state with the sensor point at lateral position ``y_s`` [m], heading 0."""
        self.x = np.array([float(y_s), 0.0, 0.0, 0.0])
        self._delta = 0.0

    def step(self, delta_front: float, delta_rear: float = 0.0, dt: float = 1e-3) -> None:
        """Advance dt [s] with the achieved front steer ``delta_front`` [rad] held constant."""
        Ad, Bd = self.discrete(dt)
        self.x = Ad @ self.x + Bd[:, 0] * float(delta_front)
        self._delta = float(delta_front)

    # ---------------------------------------------------------- outputs
    @property
    def y_s(self) -> float:
        """Sensor-point lateral displacement [m]."""
        return float(self.x[0])

    @property
    def psi(self) -> float:
        """Kinematic heading psi = v_s / U [rad]."""
        return float(self.x[1]) / self.params.speed

    @property
    def y_cg(self) -> float:
        """c.g. lateral position y = y_s - ds sin(psi) [m]."""
        return self.y_s - self.params.ds * math.sin(self.psi)

    @property
    def yaw_rate(self) -> float:
        """r = a_s / U [rad/s], a_s evaluated with the last held steer input."""
        a_s = float(self.Ca[0] @ self.x + self.Da[0, 0] * self._delta)
        return a_s / self.params.speed

    @property
    def lateral_velocity(self) -> float:
        """Body-frame lateral velocity at the c.g. [m/s]: 0 (no sideslip state)."""
        return 0.0
