"""The torque car's controller as one step: speed estimate, driver, chassis controller, ABS.

ROS-free; the ``chassis_controller`` node wraps it and the offline composition
(``irs_bringup/offline_twin/chassis_loop.py``) steps the same object, so the graph and the offline
run give the same commands.

Per measurement step (wheel encoders ``omega_i`` [rad/s], arm pose ``x`` [m], ``psi`` [rad], yaw
rate ``r`` [rad/s], belt speed ``V_b`` [m/s]; measurements only, never ground truth) the driver
sets the front step steer and the brake, the chassis controller (:mod:`.chassis_control`) the
wheel torque requests [N m] and the rear steer [rad], and the ABS (:mod:`.abs_control`) limits
each braking wheel's slip. Bad input gives zero torques and steer (the car coasts straight),
never a non-finite command. The step, the brake modes and the bad-input rule:
:class:`TorqueCarController`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .abs_control import AbsController, AbsParams, ArmSpeedEstimator, wheel_slips
from .abs_peak import PeakSeeker, PeakSeekParams
from .abs_reference import WheelSpeedObserver, WheelSpeedParams
from .chassis_control import MIXES, ChassisController, ChassisParams

__all__ = ['BRAKE_MODES', 'YAW_CONTROLS', 'ABS_REFERENCES', 'TorqueCarConfig',
           'TorqueCarController', 'TorqueCarOutput']

BRAKE_MODES = ('abs', 'abs_peak', 'locked', 'open')
YAW_CONTROLS = ('off',) + MIXES
ABS_REFERENCES = ('wheels', 'arm')


@dataclass
class TorqueCarConfig:
    """What the driver does and how the car is controlled (the node's parameters).

    Attributes
    ----------
    dt : float
        Control period = encoder sample period [s].
    speed_target : float
        Speed over the belt to hold [m/s]; 0 = the belt speed measured at the first step (or
        at the first step after the target was set to 0), held from then on. The car keeps its
        own speed and the treadmill regulator matches the belt to it, which is what keeps the
        car at the regulator's set point: a car that followed the measured belt speed would
        cancel every speed difference the regulator makes, so the position error would stay
        and the regulator would slow car and belt together until the car stops (about 10 s).
    brake_start_time : float
        Brake from this time since the first step [s]; < 0 = never.
    brake_duration : float
        Release the brake after this long [s]; <= 0 = hold to the end (a stop).
    brake_torque : float
        Brake demand per wheel [N m] (> 0, a magnitude).
    brake_mode : str
        ``'abs'`` (fixed slip target), ``'abs_peak'`` (peak-seeking), ``'locked'`` or ``'open'``.
    abs_reference : str
        The ABS's speed: ``'wheels'`` (:class:`WheelSpeedObserver`) or ``'arm'``.
    yaw_control : str
        ``'off'``, ``'rear_steer'``, ``'differential'`` or ``'both'``.
    steer_amplitude, steer_start_time : float
        The driver's front step steer [rad] from ``steer_start_time`` [s] (0 = straight).
    speed_window : int
        Samples of the arm-speed estimate's difference.
    pose_timeout : float
        [s] the newest valid pose older than this at an encoder sample (their stamps' difference)
        is stale: zero torques and steer (``stale_pose``). The speed estimate is the pose
        differentiated: on a pose that stopped coming it freezes, and the speed loop would drive
        on it. Default 0.2 s: the speed loop ``L(s) = (w_v s + w_vi) / s^2`` (3 rad/s, 2.25
        1/s^2) crosses over at 3.09 rad/s with 76 deg of phase margin (delay margin 0.43 s);
        a pose 0.2 s old plus the estimate's own 0.05 s (half its 10-pose window at 100 Hz)
        leaves 32 deg.
    abs : AbsParams
    chassis : ChassisParams (its ``mix`` is set from ``yaw_control``)
    peak : PeakSeekParams (its ``baseline`` is set to ``-abs.slip_target``, its car's mass to
        the chassis car's, wheel radius and inertia to the ABS's)
    """

    dt: float = 0.001
    speed_target: float = 0.0
    brake_start_time: float = -1.0
    brake_duration: float = 0.0
    brake_torque: float = 0.3
    brake_mode: str = 'abs'
    abs_reference: str = 'wheels'
    yaw_control: str = 'off'
    steer_amplitude: float = 0.0
    steer_start_time: float = 0.0
    speed_window: int = 10
    pose_timeout: float = 0.2
    abs: AbsParams = field(default_factory=AbsParams)
    chassis: ChassisParams = field(default_factory=ChassisParams)
    peak: PeakSeekParams = field(default_factory=PeakSeekParams)

    def __post_init__(self):
        if self.brake_mode not in BRAKE_MODES:
            raise ValueError(f'brake.mode must be one of {list(BRAKE_MODES)}, got '
                             f'{self.brake_mode!r}.')
        if self.abs_reference not in ABS_REFERENCES:
            raise ValueError(f'abs.reference must be one of {list(ABS_REFERENCES)}, got '
                             f'{self.abs_reference!r}.')
        if self.yaw_control not in YAW_CONTROLS:
            raise ValueError(f'yaw_control must be one of {list(YAW_CONTROLS)}, got '
                             f'{self.yaw_control!r}.')
        for name in ('dt', 'speed_target', 'brake_start_time', 'brake_duration', 'brake_torque',
                     'steer_amplitude', 'steer_start_time', 'pose_timeout'):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f'{name} must be a finite number, got {v!r}.')
        if self.dt <= 0.0 or self.brake_torque <= 0.0 or self.speed_target < 0.0:
            raise ValueError(f'dt and brake torque must be > 0 and speed.target >= 0, got '
                             f'{self.dt!r}, {self.brake_torque!r}, {self.speed_target!r}.')
        if self.pose_timeout <= 0.0:
            raise ValueError(f'pose_timeout must be > 0 s, got {self.pose_timeout!r}.')
        if self.yaw_control != 'off':
            self.chassis.mix = self.yaw_control
        car = WheelSpeedParams(mass=self.chassis.car.mass, wheel_radius=self.abs.wheel_radius,
                               wheel_inertia=self.abs.wheel_inertia)
        self.peak = replace(self.peak, baseline=-self.abs.slip_target, car=car,
                            lf=self.chassis.car.lf, lr=self.chassis.car.lr)

    @classmethod
    def from_params(cls, p: dict) -> 'TorqueCarConfig':
        """From the node's flat parameter dict (``chassis_params.PARAMS`` names)."""
        abs_params = AbsParams(slip_target=p['abs.slip_target'], bandwidth=p['abs.bandwidth'],
                               integral_gain=p['abs.integral_gain'], v_min=p['abs.v_min'],
                               torque_limit=p['torque_limit'])
        chassis = ChassisParams(yaw_bandwidth=p['yaw.bandwidth'],
                                yaw_integral=p['yaw.integral'],
                                differential_bandwidth=p['yaw.differential_bandwidth'],
                                speed_bandwidth=p['speed.bandwidth'],
                                speed_integral=p['speed.integral'],
                                torque_limit=p['torque_limit'], v_min=p['abs.v_min'])
        peak = PeakSeekParams(slip_min=p['abs.peak.slip_min'], slip_max=p['abs.peak.slip_max'],
                              gain_threshold=p['abs.peak.gain_threshold'],
                              forgetting=p['abs.peak.forgetting'],
                              baseline=min(max(-p['abs.slip_target'], p['abs.peak.slip_min']),
                                           p['abs.peak.slip_max']))
        return cls(dt=p['dt'], speed_target=p['speed.target'],
                   brake_start_time=p['brake.start_time'],
                   brake_duration=p['brake.duration'], brake_torque=p['brake.torque'],
                   brake_mode=p['brake.mode'], abs_reference=p['abs.reference'],
                   yaw_control=p['yaw_control'], steer_amplitude=p['steer.amplitude'],
                   steer_start_time=p['steer.start_time'], speed_window=p['speed.window'],
                   pose_timeout=p['pose_timeout'],
                   abs=abs_params, chassis=chassis, peak=peak)


@dataclass
class TorqueCarOutput:
    """One step's commands and what they were made from.

    ``torques`` [N m] FL, FR, RL, RR; ``locked`` 4 bools; ``front_steer``, ``rear_steer`` [rad];
    ``v_hat`` [m/s] the arm's speed, ``v_ref`` [m/s] the wheels'; ``slips`` [-] measured
    against the ABS's speed (0 when not computed); ``slip_target`` [-] per wheel (negative);
    ``mu`` [-] the peak seeker's friction estimate per wheel (0 unless ``'abs_peak'``, which
    alone runs it); ``r_ref`` [rad/s]; ``braking``;
    ``t`` [s] since the first step; ``reason`` ``'ok'``, ``'low_speed'`` (ABS off below v_min)
    or the bad input (then every command is 0).
    """

    torques: np.ndarray
    locked: tuple
    front_steer: float
    rear_steer: float
    v_hat: float
    slips: np.ndarray
    r_ref: float
    braking: bool
    t: float
    reason: str
    v_ref: float = math.nan
    slip_target: np.ndarray = field(default_factory=lambda: np.zeros(4))
    mu: np.ndarray = field(default_factory=lambda: np.zeros(4))

    @property
    def ok(self) -> bool:
        return self.reason in ('ok', 'low_speed')


def _finite(*xs) -> bool:
    return all(math.isfinite(x) for x in xs)


#: A pose beyond this [m] (the belt is 2.44 m long) or a belt speed or speed estimate beyond
#: this [m/s] (the belt's top speed is 6.7 m/s) is no measurement: the step is a bad-input one.
POSITION_LIMIT = 5.0
SPEED_LIMIT = 20.0


class TorqueCarController:
    """Speed estimate + driver + chassis controller + ABS.

    Per measurement step ``t_k`` (encoder sample ``omega_i`` [rad/s], arm pose ``x`` [m], ``psi``
    [rad], yaw rate ``r`` [rad/s], belt speed ``V_b`` [m/s]; measurements only, never ground
    truth)::

        t       = t_k - t_0                           (time since the first step, [s])
        v_hat   = ArmSpeedEstimator(x, psi, V_b)      (((x_k - x_{k-W}) / (W dt) + V_b) / cos psi)
        v_ref   = WheelSpeedObserver(omega, T_{k-1}, V_b)   (the wheels' speed: abs_reference.py)
        v_abs   = v_ref, or v_hat with abs.reference 'arm'
        delta_f = A  if t >= t_steer else 0           (the driver's front step steer [rad])
        braking = t_brake >= 0 and t >= t_brake and (d_brake <= 0 or t < t_brake + d_brake)
        v_tgt   = speed.target, or V_b if it is 0     (drive at belt speed: stay put on the belt)
        (T_req, delta_r) = ChassisController(v_tgt, v_hat, r, delta_f, dt, brake = b if braking)
        T       = AbsController(T_req, omega, v_abs, dt)      (brake.mode 'abs': lambda* fixed)
                  AbsController(T_req, omega, v_abs, dt, -PeakSeeker(...))   ('abs_peak')
                  T_req                                       ('open': the request, no ABS)
                  0 with every wheel locked while braking     ('locked': the friction brake)
                  0 with every wheel locked once braking and v_abs <= v_min (any mode: a motor's
                  brake torque on a stopped wheel would drive it backwards; the friction brake
                  holds the stopped car, as real ABS hands over to locked wheels at walking pace),
                  latched until the brake is released

    The arm's speed ``v_hat`` drives the speed loop and the yaw reference (staying put on the
    treadmill is the rig's business); the ABS takes the wheels' ``v_ref``, as a car must.

    ``yaw_control``: ``'off'`` runs the chassis controller with ``r = r_ref`` (its yaw error and
    integral stay 0: no yaw moment, speed control only); ``'rear_steer'``, ``'differential'``,
    ``'both'`` are the chassis controller's mixes.

    Bad input: a non-finite or missing encoder speed, a non-finite pose or belt speed (the arm
    estimator publishes NaN for a rejected reading), a pose beyond 5 m or a belt speed or speed
    estimate beyond 20 m/s, the newest valid pose more than ``pose_timeout`` older than the
    encoder sample (``stale_pose``), or, with yaw control on, a non-finite yaw rate -> all
    torques 0, no wheel locked, both steers 0 (the car coasts straight), the ABS and chassis
    integrals, the wheels' speed and the peak seeker reset, and ``reason`` names the input; the
    next valid step runs again (from rest of the integrals). Every output is finite.
    """

    def __init__(self, config: TorqueCarConfig | None = None):
        self.config = config if config is not None else TorqueCarConfig()
        self.estimator = ArmSpeedEstimator(self.config.speed_window)
        self.abs = AbsController(self.config.abs)
        self.chassis = ChassisController(self.config.chassis)
        self.wheels = WheelSpeedObserver(self.config.peak.car)
        self.peak = PeakSeeker(self.config.peak)
        self.reset()

    def reset(self) -> None:
        """Start again: time origin, speed estimate and integrals forgotten."""
        self.t0_ns = None
        self.last_pose_ns = None
        self.pose_ok = False
        self.belt_speed = math.nan
        self.cruise = None            # the speed held for speed_target 0 [m/s], once measured
        self.estimator.reset()
        self.holding = False
        self.reset_controllers()

    def reset_controllers(self) -> None:
        """ABS and chassis integrals, the wheels' speed and the peak seeker to their start
        (after bad input); time and the arm's estimate kept.
        """
        self.abs.reset()
        self.chassis.reset()
        self.wheels.reset()
        self.peak.reset()
        self.applied = np.zeros(4)          # torques held over the last step [N m]
        self.applied_locked = False
        self.peak_running = False

    def update_pose(self, stamp_ns: int, x: float, psi: float, belt_speed: float) -> None:
        """A new arm pose ``x`` [m], ``psi`` [rad] and belt speed [m/s] at ``stamp_ns``.

        The speed estimator's step is the stamp difference (the configured ``dt`` for the first
        pose); a pose stamped at or before the last one is not differentiated again.
        """
        x, psi, belt_speed = float(x), float(psi), float(belt_speed)
        self.pose_ok = _finite(x, psi, belt_speed) and abs(x) <= POSITION_LIMIT \
            and abs(belt_speed) <= SPEED_LIMIT
        self.belt_speed = belt_speed
        if self.last_pose_ns is not None and stamp_ns <= self.last_pose_ns:
            return
        dt = self.config.dt if self.last_pose_ns is None else (stamp_ns - self.last_pose_ns) * 1e-9
        if self.pose_ok:
            self.estimator.step(x, psi, belt_speed, dt)
            self.last_pose_ns = stamp_ns

    def _problem(self, stamp_ns, omega, yaw_rate) -> str | None:
        if omega.shape != (4,) or not np.isfinite(omega).all():
            return 'nonfinite_encoders'
        if not self.pose_ok or not math.isfinite(self.estimator.estimate):
            return 'invalid_pose_or_belt_speed'     # (a huge finite belt speed overflows)
        if stamp_ns - self.last_pose_ns > self.config.pose_timeout * 1e9:
            return 'stale_pose'
        if self.config.yaw_control != 'off' and not math.isfinite(yaw_rate):
            return 'nonfinite_yaw_rate'
        v_hat = self.estimator.estimate
        if not (math.isfinite(v_hat) and abs(v_hat) <= SPEED_LIMIT):
            return 'implausible_speed_estimate'
        return None

    def step(self, stamp_ns: int, omega, yaw_rate: float) -> TorqueCarOutput:
        """The commands for the encoder sample ``omega`` [rad/s] at ``stamp_ns`` (module
        docstring); call :meth:`update_pose` with this step's pose first.
        """
        c = self.config
        if self.t0_ns is None:
            self.t0_ns = int(stamp_ns)
        t = (int(stamp_ns) - self.t0_ns) * 1e-9
        braking = c.brake_start_time >= 0.0 and t >= c.brake_start_time and (
            c.brake_duration <= 0.0 or t < c.brake_start_time + c.brake_duration)
        try:
            omega = np.asarray(omega, dtype=float).reshape(-1)
            yaw_rate = float(yaw_rate)
        except (TypeError, ValueError):
            omega, yaw_rate = np.full(4, math.nan), math.nan
        problem = self._problem(int(stamp_ns), omega, yaw_rate)
        if problem is not None:
            self.reset_controllers()
            v_hat = self.estimator.estimate
            return TorqueCarOutput(np.zeros(4), (False,) * 4, 0.0, 0.0,
                                   v_hat if math.isfinite(v_hat) else 0.0,
                                   np.zeros(4), 0.0, braking, t, problem)
        delta_f = c.steer_amplitude if t >= c.steer_start_time else 0.0
        v_hat = self.estimator.estimate
        with np.errstate(over='ignore', invalid='ignore'):      # huge finite encoder speeds
            v_ref = self.wheels.step(omega, self.applied, braking, self.applied_locked,
                                     self.belt_speed, c.dt)
        v_abs = v_ref if c.abs_reference == 'wheels' else v_hat
        if c.speed_target > 0.0:
            v_target, self.cruise = c.speed_target, None
        else:
            if self.cruise is None:
                self.cruise = self.belt_speed
            v_target = self.cruise
        if c.yaw_control == 'off':
            yaw_rate = self.chassis.yaw_rate_reference(delta_f, v_hat)   # no yaw error
        ch = self.chassis.step(v_target, v_hat, yaw_rate, delta_f, c.dt,
                               brake=c.brake_torque if braking else 0.0)
        reason = ch.reason
        locked = (False,) * 4
        # the hold latches for the braking event (the speed hovers about v_min as the car stops)
        self.holding = braking and (self.holding or v_abs <= c.abs.v_min)
        peak = c.brake_mode == 'abs_peak'
        if peak != self.peak_running:       # (brake.mode is writable): the seeker starts afresh
            self.peak.reset()
            self.peak_running = peak
        targets = self.peak.target.copy()
        if peak:
            learn = (ch.torques < 0.0) & (braking and not self.holding)
            with np.errstate(over='ignore', invalid='ignore'):
                targets = self.peak.step(omega, self.applied, v_abs, learn, c.dt)
        if not (math.isfinite(v_ref) and np.isfinite(targets).all()
                and np.isfinite(self.peak.kappa).all()):
            self.wheels.reset()             # absurd input: start again (the ABS answers 0 N m)
            self.peak.reset()
            targets = self.peak.target.copy()
        if braking and (c.brake_mode == 'locked' or self.holding):
            torques, locked = np.zeros(4), (True,) * 4     # the friction brakes hold the wheels
            reason = 'ok' if c.brake_mode == 'locked' else 'low_speed'
        elif c.brake_mode in ('abs', 'abs_peak'):
            a = self.abs.step(ch.torques, omega, v_abs, c.dt,
                              slip_target=-targets if peak else None)
            torques, reason = a.torques, a.reason
        else:
            torques = ch.torques
        torques = np.asarray(torques, float)
        self.applied, self.applied_locked = torques.copy(), any(locked)
        slips = wheel_slips(omega, v_abs, c.abs.wheel_radius, c.abs.v_min)
        target = -targets if peak else np.full(4, c.abs.slip_target)
        return TorqueCarOutput(torques, locked, float(delta_f), float(ch.rear_steer),
                               float(v_hat), slips, float(ch.r_ref), braking, t, reason,
                               v_ref=float(v_ref), slip_target=target,
                               mu=-np.asarray(self.peak.mu, float))
