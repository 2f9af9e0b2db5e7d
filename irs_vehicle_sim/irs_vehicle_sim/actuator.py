"""Steering actuator of one axle: radio link, hobby servo (in horn coordinates) and linkage.

Signal flow, each element switchable (numbers and their sources: docs/vehicle_sim.md)::

    radio frame + latency (radio_link) -> |u| <= limit (the steer angle at the wheel)
    -> horn reference theta_ref = asin(N sin u)   (the linkage's inverse; off: N u)
    -> servo loop: dead zone e_f, minimum drive m, gain K = 2 pi lag_hz, slew limit Omega
    -> linkage delta = asin(sin(theta) / N) -> backlash b -> achieved steer angle

``delta`` [rad] is the road-wheel steer angle, ``theta`` [rad] the servo-horn angle, ``N`` =
``gear_ratio``.  The servo loop is quasi-static (motor inertia neglected): outside the dead zone
the horn moves at ``sign(e) min(Omega, m + K (|e| - e_f))``, ``e = theta_ref - theta``, and stops
at the dead zone's edge.  Small errors therefore move at least at ``m`` (fast first-order fits,
about 6.7 Hz at 1 deg), errors of a few degrees follow the proportional loop (its 4.4 Hz, the
fits of 4.4-4.8 Hz at 5-8 deg) and large ones slew at ``Omega`` (2.8 Hz at 15 deg): the
amplitude dependence of the paper's Fig. 6, with its 4.6 Hz (Eq. 6) where Figure 10 and the
Fig. 8 sweep run (:mod:`.servo_fit` measures it).

Timing: ``step(u_k, dt)`` consumes the command held over ``[t_k, t_k + dt)`` and returns the
achieved angle at ``t_{k+1}``; ``achieved`` read *before* ``step`` is the angle at ``t_k``.
``PRESETS`` holds the earlier calibrations, one parameter set away.  Units: rad, s, rad/s, Hz.
No rclpy.
"""

from __future__ import annotations

import math
from typing import Any
from dataclasses import dataclass

import numpy as np

from irs_models.constants import STEER_LIMIT_DEG

from .radio_link import RadioLink

__all__ = ['ActuatorParams', 'ActuatorState', 'SteeringActuator', 'actuator_seed',
           'DEFAULT_STEER_LIMIT_RAD', 'DEFAULT_RATE_LIMIT_RAD_S', 'DEFAULT_GEAR_RATIO',
           'DEFAULT_FRICTION_DEADBAND_RAD', 'DEFAULT_LAG_HZ', 'DEFAULT_MIN_DRIVE_RAD_S',
           'DEFAULT_RADIO_FRAME_S', 'LEGACY_RATE_LIMIT_RAD_S', 'LEGACY', 'PRESETS']

#: Hard steer limit at the wheel, 15 deg [rad] (paper Sec. 5: +-15 deg on the steer angle).
DEFAULT_STEER_LIMIT_RAD = math.radians(STEER_LIMIT_DEG)
#: Bandwidth of the servo's proportional loop, K / (2 pi) [Hz].  Calibrated: the first-order
#: fits at 5-8 deg of steer (where Figure 10's steer of 7.3 deg and the Fig. 8 sweep run) are the
#: paper's 4.6 Hz to +-0.3 Hz (:mod:`.servo_fit`, docs/paper.md).  Eq. 6 prints the actuator
#: pole as 29 rad/s (4.6 Hz).
DEFAULT_LAG_HZ = 4.4
#: Minimum drive of the servo amplifier [rad/s of horn]: the horn speed just outside the dead
#: zone.  The amplifier of an analog hobby servo drives the motor with a pulse per frame
#: stretched from the error pulse, at least long enough to break the motor's static friction
#: (NE544-type amplifiers: pulse stretcher, dead band and trigger); so small errors close faster
#: than the proportional loop alone.  Assumed mechanism, calibrated: first-order fits of about
#: 6.7 Hz at 1 deg, the top of the paper's 1-7 Hz.  5 % of the slew rate.
DEFAULT_MIN_DRIVE_RAD_S = 0.5
#: Slew limit of the servo horn [rad/s of horn]: 60 deg in 0.11 s, 9.5 rad/s.  Calibrated with
#: the loop gain: the fits fall from 4.4 Hz at 8 deg to 2.8 Hz at 15 deg.  With this loop a
#: 60 deg horn step settles to 98 % in 0.16 s, within the no-load ratings of hobby servos
#: (about 0.1-0.25 s / 60 deg at 4.8 V; 0.23 s for a Futaba S3003).
DEFAULT_RATE_LIMIT_RAD_S = math.radians(60.0) / 0.11
#: Servo-horn angle per road-wheel steer angle at the centre [rad/rad].  Assumed, because the
#: paper gives only "a gain": a standard servo's +-45 deg of horn for the paper's +-15 deg of
#: steer, 45 / 15; through the drag link the wheel's 15 deg needs 50.9 deg of horn.
DEFAULT_GEAR_RATIO = 3.0
#: Half-width of the servo's dead zone in horn coordinates [rad] (Coulomb friction of gears and
#: linkage over the loop stiffness, plus the amplifier's dead band).  Assumed 0.05 deg of horn: a
#: digital servo's dead band of about 1 us of pulse width at 1000 us per 90 deg is 0.09 deg of
#: horn (full width); 0.017 deg at the wheel, well below the paper's 0.175 deg backlash.
DEFAULT_FRICTION_DEADBAND_RAD = math.radians(0.05)
#: Radio frame period [s]: the PPM frame of an 8-channel hobby transmitter, 8 channel pulses of
#: at most 2 ms (plus gaps) and a sync gap, about 20 ms (20-22.5 ms by make).
DEFAULT_RADIO_FRAME_S = 0.020
#: The linear model's wheel-side limit, 60 deg / 0.15 s = 6.98 rad/s (unloaded hobby servo).
LEGACY_RATE_LIMIT_RAD_S = math.radians(60.0) / 0.15
#: Overrides that give the linear model (4.6 Hz lag, 6.98 rad/s on the wheel, no gearing,
#: friction, minimum drive, linkage geometry or radio frame); bit-identical to it (tested).
LEGACY = {'lag_hz': 4.6, 'rate_limit': LEGACY_RATE_LIMIT_RAD_S, 'gear_ratio': 1.0,
          'enable_friction': False, 'enable_linkage_geometry': False, 'min_drive': 0.0,
          'enable_radio_frame': False}
#: Earlier calibrations, each one set of overrides away (``config/servo_*.yaml`` for a rig):
#: ``servo_7hz``: a 7 Hz loop, 60 deg / 0.30 s (3.4907 rad/s, as the rig ran it), no minimum
#: drive, the transmitter's linear gain (full command reaches 13.6 deg at the wheel), a constant
#: 17 ms delay -- its 4.6 Hz fit falls at 4 deg.  ``linear_4p6``: :data:`LEGACY`.
PRESETS = {
    'servo_7hz': {'lag_hz': 7.0, 'rate_limit': 3.4907, 'min_drive': 0.0,
                  'enable_radio_frame': False, 'enable_linkage_compensation': False},
    'linear_4p6': dict(LEGACY),
}


def actuator_seed(rig_seed: int, side: str) -> tuple:
    """Seed of one actuator's random stream (its radio-frame phase): ``(rig_seed, 1)`` for the
    front, ``(rig_seed, 2)`` for the rear; apart from the arm noise's ``rig_seed`` stream.
    """
    return (int(rig_seed), {'front': 1, 'rear': 2}[side])


@dataclass
class ActuatorParams:
    """Parameters of one steering actuator.

    Attributes
    ----------
    lag_hz : float
        Bandwidth of the servo's proportional loop K / (2 pi) [Hz] (the linear region).
    rate_limit : float
        Slew limit Omega of the servo horn [rad/s of horn]; at the wheel about Omega / N.
    delay : float
        Mean transport delay of the command [s] (paper: 0.017 +- 0.005 s).  Frame off: a FIFO
        of round(delay / dt) samples; frame on: latency delay - radio_frame / 2 after the frame.
    backlash : float
        Total width of the gear/linkage play at the wheel [rad].  Default 0.175 deg (paper).
    limit : float
        Hard limit of the steer angle at the wheel [rad], +-15 deg: the steer reference is
        clipped to it and the end stops hold the wheel to it.
    gear_ratio : float
        Servo-horn angle per steer angle at the centre N [rad/rad].  Default 3.
    friction_deadband : float
        Half-width e_f of the servo's dead zone in horn coordinates [rad].
    min_drive : float
        Horn speed m just outside the dead zone [rad/s of horn]; 0 = none.
    radio_frame : float
        Period of the transmitter's frame [s] (the command is sampled and held once a frame).
    enable_lag, enable_rate_limit, enable_delay, enable_backlash, enable_saturation : bool
        Switch each element; a disabled element is an identity.
    enable_friction : bool
        Simulate the dead zone.
    enable_linkage_geometry : bool
        Wheel angle asin(sin(theta) / N) (on) or theta / N (off).
    enable_linkage_compensation : bool
        Horn reference asin(N sin u), the linkage's inverse, so that the wheel statically holds
        the steer command and the limit holds at the wheel (on); or the transmitter's gain N u
        (off: full command reaches asin(sin(N limit) / N), 13.6 deg).  Only with the geometry.
    enable_radio_frame : bool
        Sample and hold the command once a radio frame, at a random phase (seeded).
    """

    lag_hz: float = DEFAULT_LAG_HZ
    rate_limit: float = DEFAULT_RATE_LIMIT_RAD_S
    delay: float = 0.017
    backlash: float = math.radians(0.175)
    limit: float = DEFAULT_STEER_LIMIT_RAD
    gear_ratio: float = DEFAULT_GEAR_RATIO
    friction_deadband: float = DEFAULT_FRICTION_DEADBAND_RAD
    min_drive: float = DEFAULT_MIN_DRIVE_RAD_S
    radio_frame: float = DEFAULT_RADIO_FRAME_S
    enable_lag: bool = True
    enable_rate_limit: bool = True
    enable_delay: bool = True
    enable_backlash: bool = True
    enable_saturation: bool = True
    enable_friction: bool = True
    enable_linkage_geometry: bool = True
    enable_linkage_compensation: bool = True
    enable_radio_frame: bool = True

    def validate(self) -> None:
        """Raise ``ValueError`` if a parameter is not physically meaningful."""
        for name in ('lag_hz', 'rate_limit', 'delay', 'backlash', 'limit', 'gear_ratio',
                     'friction_deadband', 'min_drive', 'radio_frame'):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f'{name} must be a finite number, got {getattr(self, name)!r}')
        checks = [
            (self.lag_hz > 0.0, f'lag_hz must be a positive frequency in Hz, got {self.lag_hz!r}'),
            (self.rate_limit > 0.0,
             f'rate_limit must be a positive slew rate in rad/s, got {self.rate_limit!r}'),
            (self.delay >= 0.0, f'delay must be a non-negative time in s, got {self.delay!r}'),
            (self.backlash >= 0.0,
             f'backlash must be a non-negative total play width in rad, got {self.backlash!r}'),
            (0.0 < self.limit < 0.5 * math.pi,
             f'limit must be a steer angle in (0, pi/2) rad, got {self.limit!r}'),
            (self.gear_ratio > 0.0,
             f'gear_ratio must be a positive horn/steer ratio, got {self.gear_ratio!r}'),
            (self.friction_deadband >= 0.0,
             'friction_deadband must be a non-negative horn angle in rad, got '
             f'{self.friction_deadband!r}'),
            (self.min_drive >= 0.0,
             f'min_drive must be a non-negative horn speed in rad/s, got {self.min_drive!r}'),
            (self.radio_frame > 0.0 or not self.enable_radio_frame,
             f'radio_frame must be a positive period in s, got {self.radio_frame!r}'),
        ]
        for ok, msg in checks:
            if not ok:
                raise ValueError(msg)
        if self.enable_linkage_geometry and self.gear_ratio < 1.0:
            raise ValueError('gear_ratio must be >= 1 with enable_linkage_geometry (the steering '
                             f'arm cannot be shorter than the horn), got {self.gear_ratio!r}')
        if self.compensated and self.gear_ratio * math.sin(self.limit) >= 1.0:
            raise ValueError(
                f'gear_ratio * sin(limit) must be < 1 with enable_linkage_compensation (the horn '
                f'cannot reach the wheel limit through the linkage), got {self.gear_ratio!r} * '
                f'sin({self.limit!r})')
        if self.framed and self.delay < 0.5 * self.radio_frame:
            raise ValueError(f'delay must be at least half the radio frame with '
                             f'enable_radio_frame ({0.5 * self.radio_frame!r} s: the mean wait '
                             f'for a frame), got {self.delay!r}')

    @property
    def tau(self) -> float:
        """Loop time constant tau = 1 / (2 pi lag_hz) = 1 / K [s]."""
        return 1.0 / (2.0 * math.pi * self.lag_hz)

    @property
    def wheel_rate_limit(self) -> float:
        """Slew limit referred to the wheel, rate_limit / gear_ratio [rad/s] (at the centre)."""
        return self.rate_limit / self.gear_ratio

    @property
    def compensated(self) -> bool:
        """True when the horn reference is the linkage's inverse asin(N sin u)."""
        return self.enable_linkage_geometry and self.enable_linkage_compensation

    @property
    def framed(self) -> bool:
        """True when the command passes the radio frame (frame and delay both on)."""
        return self.enable_radio_frame and self.enable_delay

    def horn_of(self, delta: float) -> float:
        """Horn angle that holds the wheel at ``delta`` through the linkage [rad]."""
        if self.enable_linkage_geometry:
            return math.asin(max(-1.0, min(1.0, self.gear_ratio * math.sin(delta))))
        return self.gear_ratio * delta

    def wheel_of(self, theta: float) -> float:
        """Wheel angle of the horn angle ``theta`` through the linkage [rad]."""
        if self.enable_linkage_geometry:
            return math.asin(math.sin(theta) / self.gear_ratio)
        return theta / self.gear_ratio


@dataclass(init=False)
class ActuatorState:
    """Signals of the actuator chain at the current sample (for the actuator-state message).

    Attributes
    ----------
    commanded : float
        Last raw command received [rad] (before delay and saturation).
    delayed : float
        Command leaving the radio link, after saturation [rad] (the steer reference).
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

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, commanded: float = 0.0, delayed: float = 0.0, servo: float = 0.0,
                       achieved: float = 0.0, rate_limited: bool = False, saturated: bool = False,
                       horn: float = 0.0) -> None:
        self.commanded = commanded
        self.delayed = delayed
        self.servo = servo
        self.achieved = achieved
        self.rate_limited = rate_limited
        self.saturated = saturated
        self.horn = horn

    def copy(self) -> 'ActuatorState':
        """A copy of this sample's signals (the rig's outputs keep them as the chain moves on)."""
        return ActuatorState(self.commanded, self.delayed, self.servo, self.achieved,
                             self.rate_limited, self.saturated, self.horn)


class SteeringActuator:
    """Fixed-step steering actuator (module docstring for the chain).

    Parameters
    ----------
    params : ActuatorParams, optional
        Actuator parameters (validated).
    initial_angle : float
        Initial steer angle [rad] of servo and wheel; the radio link holds it at first.
    seed : int or tuple of int
        Seed of the radio frame's phase, drawn uniformly in ``[0, radio_frame)`` once
        (:func:`actuator_seed` gives the rig's).
    """

    def __init__(self, params: ActuatorParams | None = None, initial_angle: float = 0.0,
                 seed=0):
        self.params = params if params is not None else ActuatorParams()
        self.params.validate()
        p = self.params
        #: First frame instant of the radio link [s] (uniform in [0, radio_frame), seeded).
        self.frame_phase = (float(np.random.default_rng(seed).uniform(0.0, p.radio_frame))
                            if p.framed else 0.0)
        self._initial = float(initial_angle)
        self._dt: Any = None         # [s] and the RadioLink: set by _configure
        self._link: Any = None
        self._a = 0.0
        self._horn_max = p.horn_of(p.limit)
        self.state = ActuatorState()
        self.reset(initial_angle)

    # ------------------------------------------------------------------ api
    def reset(self, initial_angle: float | None = None, keep_clock: bool = False) -> None:
        """Reset all states to ``initial_angle`` [rad] (default: the constructor's).

        ``keep_clock``: the radio frame's schedule runs on (a reset in the middle of a run);
        otherwise the link's clock restarts with the first frame at ``frame_phase``.
        """
        if initial_angle is not None:
            self._initial = float(initial_angle)
        a0 = self._initial
        self.state = ActuatorState(commanded=a0, delayed=a0, servo=a0, achieved=a0,
                                   horn=self._to_horn(a0))
        if keep_clock and self._link is not None:
            self._link.reset(a0, keep_clock=True)
        else:
            self._dt = None
            self._link = None

    @property
    def achieved(self) -> float:
        """Achieved wheel steer angle at the current sample [rad]."""
        return self.state.achieved

    @property
    def delay_samples(self) -> int:
        """Length of the delay FIFO in samples, round(delay / dt) (0 before the first step, if
        disabled, or with the radio frame).
        """
        return self._link.samples if self._link is not None else 0

    def _to_horn(self, delta: float) -> float:
        """Horn angle that holds the wheel at ``delta`` (inverse linkage) [rad]."""
        p = self.params
        if p.gear_ratio == 1.0 and not p.enable_linkage_geometry:
            return delta
        return p.horn_of(delta)

    def _to_wheel(self, theta: float) -> float:
        """Wheel angle of the horn angle ``theta`` through the linkage [rad]."""
        p = self.params
        if not p.enable_linkage_geometry and p.gear_ratio == 1.0:
            return theta
        return p.wheel_of(theta)

    def _configure(self, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite step in s, got {dt!r}')
        p = self.params
        self._dt = dt
        self._a = math.exp(-dt / p.tau) if p.enable_lag else 0.0
        self._link = RadioLink(p.delay if p.enable_delay else 0.0, dt,
                               p.radio_frame if p.framed else 0.0, self.frame_phase,
                               self._initial)

    def _reference(self, u: float) -> float:
        """Servo reference in horn coordinates for the steer reference ``u`` [rad]."""
        p = self.params
        if p.compensated:
            return math.asin(p.gear_ratio * math.sin(u))
        return u if p.gear_ratio == 1.0 else p.gear_ratio * u

    def _servo_increment(self, ref: float, horn: float):
        """``(inc, limited, edge)``: the horn increment over one step toward ``ref`` (None in the
        dead zone: the horn holds), whether the slew limit clipped it, the dead zone's edge.

        Outside the dead zone the horn follows ``theta' = sign(e)(m + K(|e| - e_f))`` (exact
        ZOH: a first-order approach to ``ref -+ e_f +- m/K``), clipped to the slew limit and
        stopped at the dead zone's edge ``ref -+ e_f`` (the drive ends there).
        """
        p = self.params
        err = ref - horn
        edge = ref
        if p.enable_friction and p.friction_deadband > 0.0:
            if abs(err) <= p.friction_deadband:
                return None, False, ref
            edge = ref - math.copysign(p.friction_deadband, err)
        target = edge
        if p.min_drive > 0.0 and err != 0.0:
            target = edge + math.copysign(p.min_drive * p.tau, err)
        inc = (1.0 - self._a) * (target - horn)
        limited = False
        if p.enable_rate_limit:
            rmax = p.rate_limit * self._dt
            if abs(inc) > rmax:
                inc = math.copysign(rmax, inc)
                limited = True
        if p.min_drive > 0.0 and abs(inc) > abs(edge - horn):
            inc = edge - horn
        return inc, limited, edge

    def step(self, command_rad: float, dt: float) -> float:
        """Advance one step of length ``dt`` [s] with ``command_rad`` [rad] held (ZOH).

        Returns the achieved wheel angle at the end of the step [rad].  ``dt`` must stay the same
        between resets (the radio link's schedule depends on it).
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
        # 1. radio link: frame sampling and hold, latency (or the FIFO of the delay)
        u = self._link.step(u)
        # 2. saturation of the steer reference (a wheel angle)
        st.saturated = False
        if p.enable_saturation and abs(u) > p.limit:
            u = math.copysign(p.limit, u)
            st.saturated = True
        st.delayed = u
        # 3.-4. horn reference, servo loop
        ref = self._reference(u)
        inc, st.rate_limited, edge = self._servo_increment(ref, st.horn)
        if inc is None:
            pass                                   # inside the dead zone: the horn holds
        elif p.enable_lag or st.rate_limited or p.min_drive > 0.0:
            st.horn = st.horn + inc
        else:
            st.horn = edge  # exact pass-through (avoids s + (u - s) round-off)
        if p.enable_saturation and abs(st.horn) > self._horn_max:
            st.horn = math.copysign(self._horn_max, st.horn)   # the end stops
        # 5. linkage: horn -> wheel
        st.servo = self._to_wheel(st.horn)
        if p.enable_saturation and abs(st.servo) > p.limit:
            st.servo = math.copysign(p.limit, st.servo)
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
