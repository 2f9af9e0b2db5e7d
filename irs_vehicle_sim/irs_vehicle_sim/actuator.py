"""Steering actuator of one axle: hobby servo (position loop in horn coordinates) + linkage.

The paper (Sec. 3.3) identified the servo alone from the *servo* angle (its feedback
potentiometer), commanded with "the reference actuator angle, which is a gain multiplied by the
reference steer angle"; its frequency response depends on the amplitude (Fig. 6: first-order
poles between 1 and 7 Hz) and large steps are rate limited "because of gearing and steering
linkage friction" (Fig. 7).  This model makes that amplitude dependence emerge from the physics
of a position servo driving the wheels through a linkage.  Angles: ``delta`` = road-wheel steer
angle [rad], ``theta`` = servo-horn angle [rad]; ``N`` = ``gear_ratio`` [rad horn / rad steer].

Element order (signal flow, each element can be switched off):

1. **Transmitter transport delay** ``T_d`` (paper Sec. 3.3: 0.017 +- 0.005 s, attributed to the
   radio link and the receiver/servo electronics).  It acts on the *command*, so it comes
   first.  Implemented as an exact FIFO of ``n = round(T_d / dt)`` samples: the delay is
   **quantised to the step dt** (at 1 kHz, 0.017 s is exactly 17 samples).
2. **Command saturation** ``|u| <= delta_max`` (default 15 deg = 0.2618 rad, the paper's hard
   constraint on the front steer angle): the servo reference is clipped to the travel.
3. **Servo reference in horn coordinates** ``theta_ref = N u`` (the paper's "gain multiplied by
   the reference steer angle"; the transmitter maps linearly).
4. **Servo position loop with friction and slew limit**, in horn coordinates.  A hobby servo is
   a proportional position loop around a geared DC motor.  Quasi-statically (motor inertia
   neglected) the horn speed is proportional to the net torque: loop torque ``k e`` (``e =
   theta_ref - theta``) minus the Coulomb friction ``T_c`` of the gear train and the steering
   linkage, so the horn moves only when ``|e| > e_f = T_c / k`` and then as a first-order loop
   towards ``theta_ref -+ e_f`` (a dead zone on the error, the servo's deadband); the motor's
   speed is bounded by its no-load/stall line, the **slew limit** ``Omega`` [rad/s of horn].
   Exact ZOH of ``tau theta' = dz(e)`` (``tau = 1 / (2 pi lag_hz)``) with the limit on the
   increment::

       a = exp(-dt / tau),   target = theta_ref - sign(e) e_f   (theta held if |e| <= e_f)
       theta_{k+1} = theta_k + clip((1 - a) (target - theta_k), -Omega dt, +Omega dt)

   ``lag_hz`` is the *small-signal* loop bandwidth.  With the slew limit in horn coordinates the
   wheel-side limit is ``Omega / N``: the loop saturates when ``|e| > Omega tau``, i.e. for steer
   errors above ``Omega tau / N`` (defaults: 1.5 deg at the wheel), so sines of a few degrees
   are already slew limited and the fitted first-order pole falls with the amplitude.
5. **Linkage geometry** (servo horn -> steering arm through a drag link parallel to the axle;
   horn radius r, steering-arm radius N r): equal link-end displacements ``r sin(theta) = N r
   sin(delta)`` give ``delta = asin(sin(theta) / N)``, gain 1/N at the centre and slightly less
   towards the end stops (15 deg command with N = 3: 13.63 deg).  Switched off: ``delta =
   theta / N`` (a pure gain).  The servo state reported as ``servo`` is this wheel angle without
   the play.
6. **Gear / linkage backlash** (play element, total width ``b`` at the wheel; paper Sec. 4:
   0.175 deg).  The wheel angle ``w`` follows ``s`` (step 5) only when the play is taken up::

       w_{k+1} = s_{k+1} - b/2   if s_{k+1} - w_k >  b/2
                 s_{k+1} + b/2   if s_{k+1} - w_k < -b/2
                 w_k             otherwise

   The output is the **achieved** wheel steer angle.

The old model (a 4.6 Hz lag with a 6.98 rad/s limit on the wheel) is ``gear_ratio = 1``,
``enable_friction = false``, ``enable_linkage_geometry = false`` and ``rate_limit = 6.981``:
then steps 3-5 are the identity and the update is the one of the old model, to the bit.

Timing: ``step(u_k, dt)`` consumes the command held over ``[t_k, t_k + dt)`` and returns the
achieved angle at ``t_{k+1}``.  The chain is strictly proper (the loop output at ``t_{k+1}``
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
           'DEFAULT_STEER_LIMIT_RAD', 'DEFAULT_RATE_LIMIT_RAD_S', 'DEFAULT_GEAR_RATIO',
           'DEFAULT_FRICTION_DEADBAND_RAD', 'DEFAULT_LAG_HZ', 'LEGACY_RATE_LIMIT_RAD_S', 'LEGACY']

#: Hard steer limit, 15 deg [rad] (paper Sec. 5: +-15 deg hard constraint).
DEFAULT_STEER_LIMIT_RAD = math.radians(STEER_LIMIT_DEG)
#: Small-signal bandwidth of the servo position loop [Hz].  The paper's first-order fits span
#: 1-7 Hz with the amplitude (Sec. 3.3); friction, play and the slew limit can only slow a fit
#: down, so the loop itself must be about 7 Hz.  The paper's 3.8 Hz (isolated servo) and 4.6 Hz
#: (Eq. 6, in the car) are then fits at moderate amplitudes: this model fits about 4 Hz at 4 deg
#: and 6 Hz at 2 deg (docs/vehicle_sim.md, measured with :mod:`irs_sysid.actuator_fit`).
DEFAULT_LAG_HZ = 7.0
#: Servo-horn angle per road-wheel steer angle [rad/rad].  Assumed, because the paper gives only
#: "a gain": a standard hobby servo's +-45 deg of horn travel spans the paper's +-15 deg of steer
#: (steering arm three times the horn radius).
DEFAULT_GEAR_RATIO = 3.0
#: Loaded slew limit of the servo horn [rad/s]: 60 deg in 0.30 s = 3.49 rad/s.  Assumed: a
#: standard analog hobby servo is rated 0.15-0.23 s / 60 deg unloaded (e.g. Futaba S3003: 0.23 s
#: at 4.8 V); the steering linkage's friction and the tyres' scrub on the rig slow it down along
#: the motor's speed-torque line.  Chosen so that the fitted first-order pole falls to about
#: 1 Hz at 15 deg of steer amplitude (paper Fig. 6: 1 Hz at the low end).  At the wheel:
#: 3.49 / 3 = 1.16 rad/s (66.7 deg/s).
DEFAULT_RATE_LIMIT_RAD_S = math.radians(60.0) / 0.30
#: The old model's wheel-side limit, 60 deg / 0.15 s = 6.98 rad/s (unloaded hobby servo).
LEGACY_RATE_LIMIT_RAD_S = math.radians(60.0) / 0.15
#: Parameter overrides that give the old linear model (4.6 Hz lag, 6.98 rad/s on the wheel,
#: no gearing, no friction, no linkage geometry); the update is then bit-identical to it.
LEGACY = {'lag_hz': 4.6, 'rate_limit': LEGACY_RATE_LIMIT_RAD_S, 'gear_ratio': 1.0,
          'enable_friction': False, 'enable_linkage_geometry': False}
#: Half-width of the servo's dead zone in horn coordinates [rad] (Coulomb friction of gears and
#: linkage over the loop stiffness, plus the servo amplifier's deadband).  Assumed 0.05 deg of
#: horn: a digital servo's deadband of about 1 us of pulse width at 1000 us per 90 deg is
#: 0.09 deg of horn (full width).  0.017 deg at the wheel, well below the paper's 0.175 deg
#: backlash.  Wider dead zones (0.2 deg, an analog servo's 2-5 us) make the Figure 10 loops hunt
#: around the set point (the plant has two integrators), which the paper does not show.
DEFAULT_FRICTION_DEADBAND_RAD = math.radians(0.05)


@dataclass
class ActuatorParams:
    """Parameters of one steering actuator.

    Attributes
    ----------
    lag_hz : float
        Small-signal bandwidth of the servo position loop [Hz]; tau = 1 / (2 pi lag_hz).
        Default 7 Hz (the top of the paper's 1-7 Hz; the old linear model used 4.6 Hz, Eq. 6).
    rate_limit : float
        Slew limit of the servo horn [rad/s of horn]; the wheel-side limit is rate_limit /
        gear_ratio.  Default 3.49 rad/s (60 deg / 0.30 s, loaded hobby servo, assumed).
    delay : float
        Transmitter transport delay [s], quantised to the step: round(delay / dt) samples.
    backlash : float
        Total width of the gear/linkage play at the wheel [rad].  Default 0.175 deg.
    limit : float
        Symmetric hard saturation of the steer reference [rad].  Default 15 deg.
    gear_ratio : float
        Servo-horn angle per steer angle N [rad/rad] (the paper's "gain").  Default 3.
    friction_deadband : float
        Half-width of the servo's dead zone in horn coordinates [rad] (linkage Coulomb
        friction over loop stiffness, plus amplifier deadband).  Default 0.05 deg.
    enable_lag, enable_rate_limit, enable_delay, enable_backlash, enable_saturation : bool
        Switch each element; a disabled element is an identity.
    enable_friction : bool
        Simulate the dead zone (off: the loop is linear up to the slew limit).
    enable_linkage_geometry : bool
        Wheel angle asin(sin(theta) / N) (on) or theta / N (off).
    """

    lag_hz: float = DEFAULT_LAG_HZ
    rate_limit: float = DEFAULT_RATE_LIMIT_RAD_S
    delay: float = 0.017
    backlash: float = math.radians(0.175)
    limit: float = DEFAULT_STEER_LIMIT_RAD
    gear_ratio: float = DEFAULT_GEAR_RATIO
    friction_deadband: float = DEFAULT_FRICTION_DEADBAND_RAD
    enable_lag: bool = True
    enable_rate_limit: bool = True
    enable_delay: bool = True
    enable_backlash: bool = True
    enable_saturation: bool = True
    enable_friction: bool = True
    enable_linkage_geometry: bool = True

    def validate(self) -> None:
        """Raise ``ValueError`` if a parameter is not physically meaningful."""
        for name in ('lag_hz', 'rate_limit', 'delay', 'backlash', 'limit', 'gear_ratio',
                     'friction_deadband'):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f'{name} must be a finite number, got {getattr(self, name)!r}')
        checks = [
            (self.lag_hz > 0.0, f'lag_hz must be a positive frequency in Hz, got {self.lag_hz!r}'),
            (self.rate_limit > 0.0,
             f'rate_limit must be a positive slew rate in rad/s, got {self.rate_limit!r}'),
            (self.delay >= 0.0, f'delay must be a non-negative time in s, got {self.delay!r}'),
            (self.backlash >= 0.0,
             f'backlash must be a non-negative total play width in rad, got {self.backlash!r}'),
            (self.limit > 0.0, f'limit must be a positive steer angle in rad, got {self.limit!r}'),
            (self.gear_ratio > 0.0,
             f'gear_ratio must be a positive horn/steer ratio, got {self.gear_ratio!r}'),
            (self.friction_deadband >= 0.0,
             'friction_deadband must be a non-negative horn angle in rad, got '
             f'{self.friction_deadband!r}'),
        ]
        for ok, msg in checks:
            if not ok:
                raise ValueError(msg)
        if self.enable_linkage_geometry and self.gear_ratio < 1.0:
            raise ValueError('gear_ratio must be >= 1 with enable_linkage_geometry (the steering '
                             f'arm cannot be shorter than the horn), got {self.gear_ratio!r}')

    @property
    def tau(self) -> float:
        """Loop time constant tau = 1 / (2 pi lag_hz) [s]."""
        return 1.0 / (2.0 * math.pi * self.lag_hz)

    @property
    def wheel_rate_limit(self) -> float:
        """Slew limit referred to the wheel, rate_limit / gear_ratio [rad/s] (at the centre)."""
        return self.rate_limit / self.gear_ratio


@dataclass
class ActuatorState:
    """Signals of the actuator chain at the current sample (for the actuator-state message).

    Attributes
    ----------
    commanded : float
        Last raw command received [rad] (before delay and saturation).
    delayed : float
        Command leaving the delay FIFO, after saturation [rad] (the steer reference).
    servo : float
        Servo angle referred to the wheel through the linkage, before the play [rad].
    achieved : float
        Wheel steer angle after the backlash [rad].
    rate_limited : bool
        True if the slew limit clipped the last increment.
    saturated : bool
        True if the saturation clipped the last reference.
    horn : float
        Servo-horn angle theta [rad of horn].
    """

    commanded: float = 0.0
    delayed: float = 0.0
    servo: float = 0.0
    achieved: float = 0.0
    rate_limited: bool = False
    saturated: bool = False
    horn: float = 0.0


class SteeringActuator:
    """Fixed-step steering actuator: delay -> saturation -> servo loop -> linkage -> backlash.

    Parameters
    ----------
    params : ActuatorParams, optional
        Actuator parameters (validated).
    initial_angle : float
        Initial steer angle [rad] of servo and wheel; the delay FIFO is pre-filled with it.
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
        self.state = ActuatorState(commanded=a0, delayed=a0, servo=a0, achieved=a0,
                                   horn=self._to_horn(a0))
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

    def _to_horn(self, delta: float) -> float:
        """Horn angle that holds the wheel at ``delta`` (inverse linkage) [rad]."""
        p = self.params
        if p.gear_ratio == 1.0 and not p.enable_linkage_geometry:
            return delta
        if p.enable_linkage_geometry:
            return math.asin(max(-1.0, min(1.0, p.gear_ratio * math.sin(delta))))
        return p.gear_ratio * delta

    def _to_wheel(self, theta: float) -> float:
        """Wheel angle of the horn angle ``theta`` through the linkage [rad]."""
        p = self.params
        if p.enable_linkage_geometry:
            return math.asin(math.sin(theta) / p.gear_ratio)
        if p.gear_ratio == 1.0:
            return theta
        return theta / p.gear_ratio

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
        # 2. saturation of the steer reference
        st.saturated = False
        if p.enable_saturation and abs(u) > p.limit:
            u = math.copysign(p.limit, u)
            st.saturated = True
        st.delayed = u
        # 3. reference in horn coordinates: the transmitter's gain
        ref = u if p.gear_ratio == 1.0 else p.gear_ratio * u
        # 4. servo loop: dead zone (friction), exact first-order ZOH, slew limit on the increment
        err = ref - st.horn
        if p.enable_friction and p.friction_deadband > 0.0:
            if abs(err) <= p.friction_deadband:
                ref = st.horn
            else:
                ref = ref - math.copysign(p.friction_deadband, err)
        inc = (1.0 - self._a) * (ref - st.horn)
        st.rate_limited = False
        if p.enable_rate_limit:
            rmax = p.rate_limit * self._dt
            if abs(inc) > rmax:
                inc = math.copysign(rmax, inc)
                st.rate_limited = True
        if p.enable_lag or st.rate_limited:
            st.horn = st.horn + inc
        else:
            st.horn = ref  # exact pass-through (avoids s + (u - s) round-off)
        # 5. linkage: horn -> wheel
        st.servo = self._to_wheel(st.horn)
        # 6. backlash (play) on the output
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
