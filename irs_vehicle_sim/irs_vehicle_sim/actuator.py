"""Steering actuator of one axle (hobby servo + gear train + steering linkage).

Element order (signal flow, each element can be switched off):

1. **Transmitter transport delay** ``T_d`` (paper Sec. 3.3: 0.017 +- 0.005 s, attributed to the
   radio link and the receiver/servo electronics).  It acts on the *command*, so it comes
   first.  Implemented as an exact FIFO of ``n = round(T_d / dt)`` samples: the delay is
   **quantised to the step dt** (at 1 kHz, 0.017 s is exactly 17 samples).
2. **Command saturation / servo travel** ``|u| <= delta_max`` (default 15 deg = 0.2618 rad, the
   paper's hard constraint on the front steer angle).  The servo's feedback loop cannot be
   commanded beyond its end stops, so the reference is clipped before the servo dynamics.
3. **Servo first-order lag with rate limit**.  Paper: the servo was fitted as a first-order lag
   (3.8 Hz for the isolated servo, 4.6 Hz inside the vehicle fit of Eq. 6, which gives the
   -29 rad/s pole) and is rate limited for large steps (Fig. 7).  Exact ZOH discretisation of
   ``tau * ds/dt = u - s``::

       a = exp(-dt / tau),   Delta = (1 - a) (u - s_k)
       s_{k+1} = s_k + clip(Delta, -R dt, +R dt)

   i.e. the rate limit ``R`` [rad/s] acts on the lag's per-step increment.  Without the limit
   the update is the exact step-invariant discretisation.
4. **Gear / linkage backlash** (play element, total width ``b``; paper: 0.175 deg).  The wheel
   angle ``w`` follows the servo angle ``s`` only when the play is taken up::

       w_{k+1} = s_{k+1} - b/2   if s_{k+1} - w_k >  b/2
                 s_{k+1} + b/2   if s_{k+1} - w_k < -b/2
                 w_k             otherwise

   The output is the **achieved** wheel steer angle.

Timing: ``step(u_k, dt)`` consumes the command held over ``[t_k, t_k + dt)`` and returns the
achieved angle at ``t_{k+1}``.  The chain is strictly proper (the lag output at ``t_{k+1}``
depends on commands up to ``t_k``), so ``achieved`` read *before* ``step`` is the angle at
``t_k``.

Units: rad, s, rad/s, Hz.  No rclpy.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from irs_models.constants import STEER_LIMIT_DEG

__all__ = ['ActuatorParams', 'ActuatorState', 'SteeringActuator',
           'DEFAULT_STEER_LIMIT_RAD', 'DEFAULT_RATE_LIMIT_RAD_S']

#: Hard steer limit, 15 deg [rad] (paper Sec. 5: +-15 deg hard constraint).
DEFAULT_STEER_LIMIT_RAD = math.radians(STEER_LIMIT_DEG)
#: Rate limit of a standard hobby servo, 60 deg in 0.15 s [rad/s] = 6.98 rad/s.  The lag alone
#: (4.6 Hz) would move at most (step amplitude) * 28.9 rad/s, so with this limit steps larger than
#: about 0.24 rad (14 deg) become rate limited -- "rate limited for large actuator angles".
DEFAULT_RATE_LIMIT_RAD_S = math.radians(60.0) / 0.15


@dataclass
class ActuatorParams:
    """Parameters of one steering actuator.

    Attributes
    ----------
    lag_hz : float
        Corner frequency of the first-order servo lag [Hz]; tau = 1 / (2 pi lag_hz).
        Default 4.6 Hz (vehicle fit, Eq. 6 pole at -29 rad/s); 3.8 Hz is the isolated-servo fit.
    rate_limit : float
        Maximum servo slew rate [rad/s].  Default 6.98 rad/s (60 deg / 0.15 s hobby servo).
    delay : float
        Transmitter transport delay [s], quantised to the step: round(delay / dt) samples.
    backlash : float
        Total width of the gear/linkage play [rad].  Default 0.175 deg = 3.054e-3 rad.
    limit : float
        Symmetric hard saturation of the servo reference [rad].  Default 15 deg.
    enable_lag, enable_rate_limit, enable_delay, enable_backlash, enable_saturation : bool
        Switch each element; a disabled element is an identity.
    """

    lag_hz: float = 4.6
    rate_limit: float = DEFAULT_RATE_LIMIT_RAD_S
    delay: float = 0.017
    backlash: float = math.radians(0.175)
    limit: float = DEFAULT_STEER_LIMIT_RAD
    enable_lag: bool = True
    enable_rate_limit: bool = True
    enable_delay: bool = True
    enable_backlash: bool = True
    enable_saturation: bool = True

    def validate(self) -> None:
        """Raise ``ValueError`` if a parameter is not physically meaningful."""
        checks = [
            (self.lag_hz > 0.0, f'lag_hz must be a positive frequency in Hz, got {self.lag_hz!r}'),
            (self.rate_limit > 0.0,
             f'rate_limit must be a positive slew rate in rad/s, got {self.rate_limit!r}'),
            (self.delay >= 0.0, f'delay must be a non-negative time in s, got {self.delay!r}'),
            (self.backlash >= 0.0,
             f'backlash must be a non-negative total play width in rad, got {self.backlash!r}'),
            (self.limit > 0.0, f'limit must be a positive steer angle in rad, got {self.limit!r}'),
        ]
        for ok, msg in checks:
            if not ok:
                raise ValueError(msg)
        for name in ('lag_hz', 'rate_limit', 'delay', 'backlash', 'limit'):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f'{name} must be a finite number, got {getattr(self, name)!r}')

    @property
    def tau(self) -> float:
        """Lag time constant tau = 1 / (2 pi lag_hz) [s]."""
        return 1.0 / (2.0 * math.pi * self.lag_hz)


@dataclass
class ActuatorState:
    """Signals of the actuator chain at the current sample (for the actuator-state message).

    Attributes
    ----------
    commanded : float
        Last raw command received [rad] (before delay and saturation).
    delayed : float
        Command leaving the delay FIFO, after saturation [rad] (the servo reference).
    servo : float
        Servo output-shaft angle s (lag + rate-limit state) [rad].
    achieved : float
        Wheel steer angle after the backlash [rad].
    rate_limited : bool
        True if the rate limit clipped the last increment.
    saturated : bool
        True if the saturation clipped the last servo reference.
    """

    commanded: float = 0.0
    delayed: float = 0.0
    servo: float = 0.0
    achieved: float = 0.0
    rate_limited: bool = False
    saturated: bool = False


class SteeringActuator:
    """Fixed-step steering actuator: delay -> saturation -> rate-limited lag -> backlash.

    Parameters
    ----------
    params : ActuatorParams, optional
        Actuator parameters (validated).
    initial_angle : float
        Initial servo and wheel angle [rad]; the delay FIFO is pre-filled with it.
    """

    def __init__(self, params: ActuatorParams | None = None, initial_angle: float = 0.0):
        self.params = params if params is not None else ActuatorParams()
        self.params.validate()
        self._initial = float(initial_angle)
        self._dt: float | None = None
        self._fifo: deque = deque()
        self._a = 0.0
        self.state = ActuatorState()
        self.reset(initial_angle)

    # ------------------------------------------------------------------ api
    def reset(self, initial_angle: float | None = None) -> None:
        """Reset all states to ``initial_angle`` [rad] (default: the constructor's)."""
        if initial_angle is not None:
            self._initial = float(initial_angle)
        a0 = self._initial
        self.state = ActuatorState(commanded=a0, delayed=a0, servo=a0, achieved=a0)
        self._dt = None
        self._fifo = deque()

    @property
    def achieved(self) -> float:
        """Achieved wheel steer angle at the current sample [rad]."""
        return self.state.achieved

    @property
    def delay_samples(self) -> int:
        """Delay length in samples, round(delay / dt) (0 before the first step or if disabled)."""
        return len(self._fifo)

    def _configure(self, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite step in s, got {dt!r}')
        p = self.params
        self._dt = dt
        self._a = math.exp(-dt / p.tau) if p.enable_lag else 0.0
        n = int(round(p.delay / dt)) if p.enable_delay else 0
        self._fifo = deque([self._initial] * n)

    def step(self, command_rad: float, dt: float) -> float:
        """Advance one step of length ``dt`` [s] with ``command_rad`` [rad] held (ZOH).

        Returns the achieved wheel angle at the end of the step [rad].  ``dt`` must stay the same
        between resets (the delay FIFO length depends on it).
        """
        if self._dt is None:
            self._configure(float(dt))
        elif abs(dt - self._dt) > 1e-12 * self._dt:
            raise ValueError(
                f'dt must stay constant between resets (was {self._dt!r} s, got {dt!r} s)')
        p = self.params
        st = self.state
        u = float(command_rad)
        st.commanded = u
        # 1. transport delay (FIFO of n samples)
        if self._fifo:
            self._fifo.append(u)
            u = self._fifo.popleft()
        # 2. saturation of the servo reference
        st.saturated = False
        if p.enable_saturation and abs(u) > p.limit:
            u = math.copysign(p.limit, u)
            st.saturated = True
        st.delayed = u
        # 3. exact first-order lag with rate limit on the increment
        inc = (1.0 - self._a) * (u - st.servo)
        st.rate_limited = False
        if p.enable_rate_limit:
            rmax = p.rate_limit * self._dt
            if abs(inc) > rmax:
                inc = math.copysign(rmax, inc)
                st.rate_limited = True
        if p.enable_lag or st.rate_limited:
            st.servo = st.servo + inc
        else:
            st.servo = u  # exact pass-through (avoids s + (u - s) round-off)
        # 4. backlash (play) on the output
        if p.enable_backlash and p.backlash > 0.0:
            half = 0.5 * p.backlash
            gap = st.servo - st.achieved
            if gap > half:
                st.achieved = st.servo - half
            elif gap < -half:
                st.achieved = st.servo + half
        else:
            st.achieved = st.servo
        return st.achieved
