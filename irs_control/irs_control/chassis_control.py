"""Integrated chassis control of the torque car: yaw-rate tracking and speed (ROS-free).

Yaw-rate reference: the steady-state yaw rate of the linear bicycle model (irs_models.bicycle,
the torque car of irs_models.torque_car) for the driver's front steer at the current speed::

    [v_y, r]_ss = -A_2^{-1} B_2 [delta_f, 0]^T,   r_ref = r_ss(V = max(v_hat, v_min))

(``A_2``, ``B_2`` the dynamic 2x2 block and its input columns; for small steer
``V delta_f / (L + K_us V^2)``, Rajamani 2012 sec. 3.5). Yaw moment demand [N m], a PI with a
clamped integral, allocated to rear steer ``delta_r = -M / (l_r C_r)`` and differential torque
``dT = M R / (2 t)`` [N m]; speed [m/s] by a PI on the wheel torques::

    M_z = I_z (w_r (r_ref - r) + w_ri z),   dz/dt = r_ref - r
    F = m (w_v (v_target - v_hat) + w_vi q),   dq/dt = v_target - v_hat,   T_base = F R / 4

with the measured yaw rate ``r`` [rad/s] (the arm's heading differentiated). The car drives at
belt speed so it stays put on the treadmill; the controller exists to keep the torque car on its
path when it brakes on split friction (allocation and braking: :class:`ChassisController`;
tuning: :class:`ChassisParams`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from irs_common.field_checks import check_numbers
from irs_common.scalar import clip
from irs_models.bicycle import BicycleParams, bicycle_state_space
from irs_models.constants import STEER_LIMIT

__all__ = ['ChassisParams', 'ChassisController', 'ChassisOutput', 'MIXES']

MIXES = ('rear_steer', 'differential', 'both')


def _default_car() -> BicycleParams:
    from irs_models.torque_car import torque_car_bicycle

    return torque_car_bicycle()   # frozen dataclass: safe to share


@dataclass
class ChassisParams:
    """Chassis controller parameters.

    Sources of the defaults. Defaults: ``w_r = 300 rad/s``, ``w_ri = 60 1/s``, ``mix = 'both'``:
    tuned on the two-track model braking on split mu (0.8 left / 0.3 right) from 1.2 m/s under ABS
    with the yaw rate from the heading differentiated over one 1 ms step.  The differential torque
    only acts when it asks for *less* braking than the ABS allows on the high side, i.e. when the
    demand exceeds the gap between the brake demand and the ABS's torque (about 0.1 N m, a moment
    of 1 N m), hence the high gain; 15-60 rad/s cut the peak yaw rate by 10-30 % only, 300 rad/s by
    about 55 %.  While driving (no brake demand, no ABS clipping) the torque path has its own
    dynamics (the wheel spin against the relaxed slip, about 280 rad/s and lightly damped) and a
    step steer makes it unstable above about 60 rad/s on the two-track model, so there its share of
    the moment is scaled by ``w_d / w_r`` with ``w_d = 40 rad/s``.  The rear steer is taken as
    achieved: through the rig's 4.6 Hz servo it acts later, and the gain must be re-checked there
    (the moment demand is applied to the motors at once). ``w_v = 3 rad/s``, ``w_vi = 2.25 1/s``
    (assumed: the speed loop ``s^2 + w_v s + w_vi`` critically damped at 1.5 rad/s, slower than the
    treadmill regulator, which also moves the car), steer limit 0.2618 rad (irs_models.constants),
    ``torque_limit = 0.3 N m`` (as the ABS), ``v_min = 0.1 m/s``.

    Attributes
    ----------
    car : BicycleParams
        The car (default: irs_models.torque_car, the ``irs_iwt`` preset on rubber tyres).
    yaw_bandwidth, yaw_integral : float
        w_r [rad/s], w_ri [1/s].
    differential_bandwidth : float
        w_d [rad/s]: while driving (no brake demand) the differential-torque share of the
        moment is scaled by ``min(1, w_d / w_r)`` (default 40).
    speed_bandwidth, speed_integral : float
        w_v [rad/s], w_vi [1/s].
    mix : str
        ``'rear_steer'``, ``'differential'`` or ``'both'``.
    steer_limit : float
        Rear steer limit [rad].
    torque_limit : float
        Wheel torque limit [N m].
    v_min : float
        Lowest speed used for the reference and the gains [m/s].
    """

    car: BicycleParams = field(default_factory=_default_car)
    yaw_bandwidth: float = 300.0
    yaw_integral: float = 60.0
    differential_bandwidth: float = 40.0
    speed_bandwidth: float = 3.0
    speed_integral: float = 2.25
    mix: str = 'both'
    steer_limit: float = STEER_LIMIT
    torque_limit: float = 0.3
    v_min: float = 0.1

    def __post_init__(self):
        check_numbers(self, ('yaw_bandwidth', 'differential_bandwidth', 'speed_bandwidth',
                             'steer_limit', 'torque_limit', 'v_min'), above=0.0)
        check_numbers(self, ('yaw_integral', 'speed_integral'), at_least=0.0)
        if self.mix not in MIXES:
            raise ValueError(f'ChassisParams.mix must be one of {list(MIXES)}, got {self.mix!r}.')
        if not isinstance(self.car, BicycleParams):
            raise ValueError(f'ChassisParams.car must be a BicycleParams, got {self.car!r}.')


@dataclass
class ChassisOutput:
    """One step's answer: ``torques`` [N m] (FL, FR, RL, RR), ``rear_steer`` [rad], ``r_ref``
    [rad/s], ``yaw_moment`` demanded [N m] and a ``reason`` (``'ok'``, ``'nonfinite_input'``).
    """

    torques: np.ndarray
    rear_steer: float
    r_ref: float
    yaw_moment: float
    reason: str


class ChassisController:
    """Yaw-rate and speed control through wheel torques and rear steer.

    Allocation of the yaw moment (``mix``), half each for ``'both'``:

    * rear steer: the rear axle's lateral force ``C_r delta_r`` at ``-l_r`` gives ``M = -l_r C_r
      delta_r``, so ``delta_r = -M / (l_r C_r)``, clipped to the steer limit;
    * differential torque: ``+dT`` on the right wheels and ``-dT`` on the left ones gives ``M =
      (t/2) 4 dT / R``, so ``dT = M R / (2 t)``.

    or, while a brake demand ``b > 0`` [N m per wheel] is given, ``T_base = -b`` (the speed
    integral is then reset, and the ABS downstream limits each wheel's slip).  Torques are clipped
    to ``+-torque_limit``.
    """

    def __init__(self, params: ChassisParams | None = None):
        self.params = params if params is not None else ChassisParams()
        self._reference = None        # ((steer, its sign, speed, car), yaw rate): the last answer
        self.reset()

    def reset(self) -> None:
        """Integrals to zero."""
        self.z = 0.0
        self.q = 0.0

    def yaw_rate_reference(self, delta_f: float, speed: float) -> float:
        """Steady-state bicycle yaw rate [rad/s] for front steer ``delta_f`` [rad].

        The last answer is kept: a step asks twice for the same steer and speed when the yaw
        rate is not controlled (the torque-car controller's reference, then :meth:`step`'s).
        """
        V = max(float(speed), self.params.v_min)
        d = float(delta_f)
        key = (d, math.copysign(1.0, d), V, self.params.car)
        if self._reference is not None and self._reference[0] == key:
            return self._reference[1]
        A, B, _, _ = bicycle_state_space(self.params.car, V)
        x = -np.linalg.solve(A[:2, :2], B[:2, 0] * d)
        self._reference = (key, float(x[1]))
        return self._reference[1]

    def _moment_capacity(self) -> float:
        p, c = self.params, self.params.car
        m_steer = c.lr * c.c_r * p.steer_limit
        m_diff = 2.0 * c.track * p.torque_limit / c.wheel_radius
        return {'rear_steer': m_steer, 'differential': m_diff,
                'both': m_steer + m_diff}[p.mix]

    def step(self, v_target: float, v_hat: float, yaw_rate: float, delta_f: float, dt: float,
             brake: float = 0.0) -> ChassisOutput:
        """One control step.

        Parameters
        ----------
        v_target : float
            Speed over the belt to hold [m/s] (the belt speed to stay in place).
        v_hat : float
            Speed estimate over the belt [m/s].
        yaw_rate : float
            Measured yaw rate [rad/s].
        delta_f : float
            The driver's (lateral controller's) front steer [rad].
        dt : float
            Step [s].
        brake : float
            Brake demand per wheel [N m] (>= 0; > 0 overrides the speed loop).
        """
        p, c = self.params, self.params.car
        vals = (v_target, v_hat, yaw_rate, delta_f, dt, brake)
        try:
            ok = all(math.isfinite(float(x)) for x in vals) and float(dt) > 0.0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            self.reset()
            return ChassisOutput(np.zeros(4), 0.0, 0.0, 0.0, 'nonfinite_input')
        # the bicycle reference of a huge steer is still finite; keep the steer physical
        delta_f = clip(float(delta_f), -p.steer_limit, p.steer_limit)
        r_ref = self.yaw_rate_reference(delta_f, v_hat)
        e = r_ref - float(yaw_rate)
        cap = self._moment_capacity()
        kz = c.yaw_inertia * p.yaw_integral
        if kz > 0.0:
            self.z = clip(self.z + dt * e, -cap / kz, cap / kz)
        m_z = clip(c.yaw_inertia * (p.yaw_bandwidth * e) + kz * self.z, -cap, cap)
        share_steer = {'rear_steer': 1.0, 'differential': 0.0, 'both': 0.5}[p.mix]
        rear = clip(-share_steer * m_z / (c.lr * c.c_r), -p.steer_limit, p.steer_limit)
        # driving, the torque path is slower (module docstring): its moment is scaled by w_d / w_r
        scale = 1.0 if brake > 0.0 else min(1.0, p.differential_bandwidth / p.yaw_bandwidth)
        m_d = (1.0 - share_steer) * m_z * scale
        d_t = m_d * c.wheel_radius / (2.0 * c.track)
        if brake > 0.0:
            self.q = 0.0
            base = -min(float(brake), p.torque_limit)
        else:
            ev = float(v_target) - float(v_hat)
            f_max = 4.0 * p.torque_limit / c.wheel_radius
            kq = c.mass * p.speed_integral
            if kq > 0.0:
                self.q = clip(self.q + dt * ev, -f_max / kq, f_max / kq)
            force = c.mass * p.speed_bandwidth * ev + kq * self.q
            base = force * c.wheel_radius / 4.0
        torques = np.clip(np.array([base - d_t, base + d_t, base - d_t, base + d_t]),
                          -p.torque_limit, p.torque_limit)
        return ChassisOutput(torques, rear, r_ref, m_z, 'ok')
