"""Anti-lock braking: a per-wheel slip PI on the wheel torques, and a speed estimate (ROS-free).

Measurements only (never the simulator's ground truth): the wheel speeds ``omega_i`` [rad/s]
from the encoders and a vehicle speed estimate ``v_hat`` [m/s] over the belt: the wheels'
(:mod:`.abs_reference`) or, for comparison, :class:`ArmSpeedEstimator` (the arm's pose
differentiated plus the belt speed the treadmill encoder measures).  Wheel slip (the tyre
model's definition, negative when braking)::

    lambda_i = (omega_i R - v_hat) / max(v_hat, v_min)

Control law, per wheel whose requested torque ``T_req,i < 0`` brakes, while ``v_hat > v_min``
(slip PI with a speed-scheduled gain and anti-windup by clamping)::

    e_i  = lambda* - lambda_i              (> 0: the wheel slips more than the target)
    K_p  = w_c J v_hat / R                 [N m]  (the wheel's slip dynamics
                                            dlambda/dt = R (T - R F_x) / (J v_hat)
                                            closed by K_p have the pole -w_c)
    T_abs = I_i + K_p e_i,   dI_i/dt = K_i e_i
    T_i   = clip(T_abs, T_req,i, 0)        (ABS only takes braking away, never adds drive)
    I_i   clamped to [T_req,i, 0]          (anti-windup: the integral cannot run past the range)

It exists so that a braking torque car keeps its wheels near the friction peak (steerable, the
shortest stop) from measurements only. The two gains: :class:`AbsController`; the defaults and
their sources: :class:`AbsParams`; the per-wheel peak seeker: :mod:`.abs_peak`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from irs_common.field_checks import check_numbers

__all__ = ['AbsParams', 'AbsController', 'AbsOutput', 'ArmSpeedEstimator', 'wheel_slips']


@dataclass
class AbsParams:
    """ABS parameters.

    Sources of the defaults. Defaults: ``lambda* = -0.10`` (Rajamani, Vehicle Dynamics and Control
    2012, sec. 6 / Bosch Automotive Handbook: the friction peak of car tyres lies at 10-20 % slip;
    the tyre model here peaks at 9 % on mu = 0.3 and 16 % on mu = 0.8, and gives 99.97 % and 90 %
    of its peak at 10 % slip; :mod:`.abs_peak` moves the target per wheel to the fitted peak);
    ``w_c = 200 rad/s`` and ``K_i = 40 N m/s`` (pole near 17 rad/s below the peak): tuned on the
    two-track model with 5-sample (5 ms) encoder windows -- the encoder's 2.5 ms lag costs 29 deg
    of phase at 200 rad/s; slower loops (40 rad/s) let the wheels lock before the release and
    limit-cycle between lock and the peak, and 10-sample windows do too; ``v_min = 0.1 m/s`` (below
    it slip is meaningless and the wheels may lock, as real ABS cuts out at walking pace);
    ``torque_limit = 0.3 N m``: assumed, a 1:10 hub motor's peak torque, enough to lock a wheel on
    the best surface (``R mu F_z = 0.033 * 0.8 * 7 = 0.19 N m``); ``J`` and ``R`` the two-track
    model's defaults (5e-5 kg m^2, 0.033 m).

    Attributes
    ----------
    slip_target : float
        Target slip lambda* while braking [-], in (-1, 0) (default -0.10).
    bandwidth : float
        Slip loop pole w_c [rad/s] (default 200).
    integral_gain : float
        Integral gain K_i [N m/s per unit slip] (default 40).
    v_min : float
        Speed below which ABS is off [m/s] (default 0.1).
    torque_limit : float
        Motor torque limit [N m] (default 0.3).
    wheel_radius : float
        R [m] (default 0.033).
    wheel_inertia : float
        J [kg m^2] (default 5e-5).
    """

    slip_target: float = -0.10
    bandwidth: float = 200.0
    integral_gain: float = 40.0
    v_min: float = 0.1
    torque_limit: float = 0.3
    wheel_radius: float = 0.033
    wheel_inertia: float = 5e-5

    def __post_init__(self):
        check_numbers(self, ('bandwidth', 'v_min', 'torque_limit', 'wheel_radius',
                             'wheel_inertia'), above=0.0)
        check_numbers(self, ('integral_gain',), at_least=0.0)
        check_numbers(self, ('slip_target',))
        if not -1.0 < self.slip_target < 0.0:
            raise ValueError(f'AbsParams.slip_target must be a braking slip in (-1, 0), got '
                             f'{self.slip_target!r}.')


@dataclass
class AbsOutput:
    """One ABS step's answer.

    Attributes
    ----------
    torques : ndarray
        Wheel torques to apply [N m] (FL, FR, RL, RR).
    slips : ndarray
        Measured slips lambda_i [-] (0 when not computed).
    active : ndarray of bool
        Wheels whose torque the slip loop set.
    reason : str
        ``'ok'``, ``'low_speed'`` or ``'nonfinite_input'`` (then all torques are 0).
    """

    torques: np.ndarray
    slips: np.ndarray
    active: np.ndarray
    reason: str


def wheel_slips(omega, v_hat: float, wheel_radius: float, v_min: float) -> np.ndarray:
    """``lambda_i = (omega_i R - v_hat) / max(v_hat, v_min)`` [-]."""
    return (np.asarray(omega, float) * wheel_radius - v_hat) / max(v_hat, v_min)


def _finite(*xs) -> bool:
    """Every element of every argument (floats, sequences, arrays) is a finite number."""
    try:
        for x in xs:
            if type(x) is float:
                if not math.isfinite(x):
                    return False
            elif not np.isfinite(np.asarray(x, dtype=float)).all():
                return False
        return True
    except (TypeError, ValueError):
        return False


class AbsController:
    """Per-wheel slip PI (module docstring); ``step`` filters the requested torques.

    Two regimes set the two gains: below the friction peak the tyre is stiff (``T = R F_x ~ R C_k
    F_z lambda``, a static gain of ``R C_k F_z = 2.3 N m`` per unit slip, so the integral alone
    gives the pole ``K_i / 2.3``); at and past the peak the wheel is an integrator and the
    proportional part closes it at ``w_c``.  A wheel that is not braking, or all wheels below
    ``v_min``, get ``T_req``, and the integral starts at ``T_req`` when a wheel starts braking
    (bumpless engagement: the full request first, released as the slip grows).  Requests are
    clipped to ``+-torque_limit`` first.
    """

    def __init__(self, params: AbsParams | None = None, n: int = 4):
        self.params = params if params is not None else AbsParams()
        self.n = int(n)
        self.reset()

    def reset(self) -> None:
        """Integrals to zero, no wheel braking."""
        self.integral = np.zeros(self.n)
        self._braking = np.zeros(self.n, bool)

    def step(self, torque_request, omega, v_hat: float, dt: float, slip_target=None
             ) -> AbsOutput:
        """One control step.

        Parameters
        ----------
        torque_request : sequence of n float
            Torques asked for by the driver / chassis controller [N m] (negative brakes).
        omega : sequence of n float
            Encoder wheel speeds [rad/s].
        v_hat : float
            Vehicle speed estimate over the belt [m/s] (not ground truth).
        dt : float
            Step [s].
        slip_target : sequence of n float, optional
            Per-wheel targets lambda* in (-1, 0) [-] (e.g. :class:`~.abs_peak.PeakSeeker`'s,
            negated); default ``params.slip_target`` for every wheel.
        """
        p = self.params
        zero = np.zeros(self.n)
        if not (_finite(torque_request, omega, v_hat, dt) and dt > 0.0) \
                or np.shape(torque_request) != (self.n,) or np.shape(omega) != (self.n,):
            self.reset()
            return AbsOutput(zero, zero.copy(), np.zeros(self.n, bool), 'nonfinite_input')
        treq = np.clip(np.asarray(torque_request, float), -p.torque_limit, p.torque_limit)
        v = float(v_hat)
        if v <= p.v_min:
            self.integral = treq.copy()
            self._braking = treq < 0.0
            return AbsOutput(treq, zero.copy(), np.zeros(self.n, bool), 'low_speed')
        lam = wheel_slips(omega, v, p.wheel_radius, p.v_min)
        braking = treq < 0.0
        kp = p.bandwidth * p.wheel_inertia * v / p.wheel_radius
        target = p.slip_target if slip_target is None else np.clip(
            np.asarray(slip_target, float), -0.99, -1e-3)
        e = target - lam
        start = np.where(self._braking, self.integral, treq)
        integ = np.where(braking, start + dt * p.integral_gain * e, treq)
        integ = np.where(braking, np.clip(integ, treq, 0.0), integ)
        t_abs = integ + kp * e
        out = np.where(braking, np.clip(t_abs, treq, 0.0), treq)
        self.integral = integ
        self._braking = braking
        active = braking & (out > treq)
        return AbsOutput(out, lam, active, 'ok')


class ArmSpeedEstimator:
    """Forward speed over the belt from the arm's pose and the belt speed [m/s].

    ``dx/dt = u cos(psi) - v sin(psi) - V_b`` (docs/conventions.md), so with the lateral term
    neglected (``v sin(psi)`` is second order for small heading)::

        u_hat = ((x_k - x_{k-W}) / (W dt) + V_b,k) / cos(psi_k)

    ``x`` [m] and ``psi`` [rad] as the arm measures them, ``V_b`` the belt speed its encoder
    measures; a window of ``W`` samples (default 10, i.e. 10 ms at 1 kHz).  Returns ``V_b`` (or
    the last estimate) until a window exists; non-finite samples are skipped and keep it.
    """

    def __init__(self, window: int = 10):
        if isinstance(window, bool) or not isinstance(window, int) or window < 1:
            raise ValueError(f'window must be an integer >= 1 [samples], got {window!r}.')
        self.window = window
        self.reset()

    def reset(self) -> None:
        self._x = deque(maxlen=self.window + 1)
        self._dt = deque(maxlen=self.window)
        self.estimate = 0.0

    def step(self, x: float, psi: float, belt_speed: float, dt: float) -> float:
        if not _finite(x, psi, belt_speed, dt) or dt <= 0.0:
            return self.estimate
        self._x.append(float(x))
        if len(self._x) > 1:
            self._dt.append(float(dt))
        if len(self._dt) == 0:
            self.estimate = float(belt_speed)
            return self.estimate
        dxdt = (self._x[-1] - self._x[0]) / sum(self._dt)
        self.estimate = (dxdt + belt_speed) / max(math.cos(psi), 0.1)
        return self.estimate
