"""The whole IRS rig as one fixed-step, deterministic simulation (no rclpy).

Each step ``k -> k+1`` (``t_k = k dt``) sanitises the inputs, advances the lateral plant with
the **achieved** steer at ``t_k``, the car's longitudinal state with the exact belt travel, the
steering actuators and the belt, and forms the outputs at ``t_{k+1}`` (arm potentiometer angles,
belt encoder speed, actuator states, ground truth, wheel speeds, latched fault flags).
``outputs_k`` describe the state at ``t_k``, and the command applied over ``[t_k, t_{k+1})`` is
the one computed from them (``inputs_k = input_fn(outputs_k)``): no delay beyond the physical
ones (actuator, belt and encoder delays).

It exists so that one core serves the ``vehicle_sim`` node, :func:`simulate` and the offline
twin, which must agree to the bit. Step order, faults, the torque car and the heading of
``plant: identified``: :class:`RigSimulation`; the components: docs/vehicle_sim.md.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, fields, asdict, replace
from typing import Any, Callable, Optional

import numpy as np

from irs_models.arm_kinematics import ArmGeometry, ArmReachError
from irs_models.constants import SENSOR_DISTANCE
from irs_models.identified import IdentifiedParams, IdentifiedPlant, quadratic_roots
from irs_models.lateral_plant import BicyclePlant
from irs_models.torque_car import GRAVITY

from .actuator import ActuatorParams, ActuatorState, SteeringActuator, actuator_seed
from .car_on_belt import CarParams, CarOnBelt, off_belt_edge, wheel_speeds
from .arm_sensor import ArmSensorParams, ArmSensor
from .belt import BeltParams, TreadmillBelt
from .rig_torque_car import (NOT_LOCKED, ZERO_TORQUE, TorqueCarPlant, TyreTruth,
                             check_torque_limit, encoder_defaults, make_encoder_params,
                             make_surface, make_two_track_params, sanitize_wheel_inputs,
                             surface_defaults, two_track_defaults)

__all__ = ['RigInputs', 'RigOutputs', 'RigConfig', 'RigSimulation', 'simulate', 'PLANTS',
           'TyreTruth', 'sanitize_steer', 'sanitize_voltage', 'sanitize_speed', 'unflatten']

#: Steer commands beyond this magnitude are rejected as garbage (30 deg) [rad]; commands between
#: the actuator limit (15 deg) and this value are accepted and saturated by the actuator.
DEFAULT_STEER_REJECT_RAD = math.radians(30.0)
#: Plants the rig can step.
PLANTS = ('identified', 'bicycle', 'two_track')
#: Share of the surface's grip the torque car's stop may use per wheel [-]: below the tyre's
#: peak, with room for the load moving between the axles as the car speeds up or slows down
#: (:meth:`RigSimulation.stop_torque_params`).
STOP_TRACTION = 0.7


# ----------------------------------------------------------------------------- sanitising
def _screen(value, what: str, accept, out_of_range, safe: float, instead: str):
    """``(float(value), None)`` if ``value`` is a finite number that ``accept`` takes, else
    ``(safe, reason)``; ``out_of_range(v)`` words the refusal of a finite number, ``instead``
    says what is used in its place.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        return safe, f'{what} {value!r} is not a number; {instead}'
    if not math.isfinite(v):
        return safe, f'{what} {v!r} is not finite; {instead}'
    if not accept(v):
        return safe, f'{what} {out_of_range(v)}; {instead}'
    return v, None


def sanitize_steer(value: object, reject_limit: float = DEFAULT_STEER_REJECT_RAD):
    """Safe steer command [rad] and a reason (``None`` if accepted).

    Non-finite values and ``|value| > reject_limit`` are replaced by 0 rad.
    """
    if type(value) is float and abs(value) <= reject_limit:   # the common case, answered first
        return value, None
    return _screen(value, 'steer command', lambda v: abs(v) <= reject_limit,
                   lambda v: f'{v:.4f} rad exceeds the accepted range +-{reject_limit:.4f} rad',
                   0.0, 'using 0 rad')


def sanitize_voltage(value: object, u_max: float):
    """Safe drive voltage [V] and a reason; non-finite or outside [0, u_max] -> 0 V."""
    if type(value) is float and 0.0 <= value <= u_max:
        return value, None
    return _screen(value, 'drive voltage', lambda v: 0.0 <= v <= u_max,
                   lambda v: f'{v:.3f} V is outside [0, {u_max:.3f}] V', 0.0, 'using 0 V')


def sanitize_speed(value: object, u_max: float, fallback: float):
    """Safe driver speed command [m/s] and a reason; non-finite or outside [0, u_max] ->
    ``fallback`` (the last accepted command: stopping the car on a moving belt is not safe).
    """
    if type(value) is float and 0.0 <= value <= u_max:
        return value, None
    return _screen(value, 'speed command', lambda v: 0.0 <= v <= u_max,
                   lambda v: f'{v:.3f} m/s is outside [0, {u_max:.3f}] m/s', fallback,
                   f'holding {fallback:.3f} m/s')


# ----------------------------------------------------------------------------- data
@dataclass(init=False)
class RigInputs:
    """Inputs held over one step: steer commands [rad], drive voltage [V], speed command [m/s];
    torque car only: wheel torques [N m] and locked flags (FL, FR, RL, RR).
    """

    front_steer: float = 0.0
    rear_steer: float = 0.0
    drive_voltage: float = 0.0
    speed_cmd: float = 0.0
    wheel_torque: tuple = ZERO_TORQUE
    wheel_locked: tuple = NOT_LOCKED

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, front_steer: float = 0.0, rear_steer: float = 0.0,
                       drive_voltage: float = 0.0, speed_cmd: float = 0.0,
                       wheel_torque: tuple = ZERO_TORQUE,
                       wheel_locked: tuple = NOT_LOCKED) -> None:
        self.front_steer = front_steer
        self.rear_steer = rear_steer
        self.drive_voltage = drive_voltage
        self.speed_cmd = speed_cmd
        self.wheel_torque = wheel_torque
        self.wheel_locked = wheel_locked


@dataclass(init=False)
class RigOutputs:
    """Rig outputs at time ``time`` [s] (all SI)."""

    time: float
    arm_angles: tuple            # (theta1, theta2, theta3) measured [rad]; NaN if unreachable
    belt_speed_measured: float   # encoder estimate [m/s]
    belt_speed: float            # true belt speed [m/s]
    actuator_front: ActuatorState
    actuator_rear: ActuatorState
    x: float                     # c.g. x [m]
    y: float                     # c.g. y [m]
    psi: float                   # heading [rad]
    u: float                     # forward speed over the belt [m/s]
    v: float                     # body lateral velocity at the c.g. [m/s]
    yaw_rate: float              # [rad/s]
    y_s: float                   # sensor-point lateral displacement [m]
    wheel_speeds: tuple          # [FL, FR, RL, RR] [rad/s]
    off_belt: bool
    off_belt_edge: str
    arm_fault: bool
    fault: bool                  # latched
    fault_reason: str            # latched first reason, '' if none
    input_warnings: tuple = ()   # reasons from sanitising the inputs of the last step
    applied_inputs: Optional[RigInputs] = None  # sanitised inputs of the last step
    encoder_counts: tuple = ()   # two_track: wheel encoder counts [FL, FR, RL, RR]; else ()
    encoder_velocity: tuple = ()  # two_track: encoder velocities [rad/s]; else ()
    tyre: Optional[TyreTruth] = None  # two_track: tyre ground truth; else None

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, time: float, arm_angles: tuple, belt_speed_measured: float,
                       belt_speed: float, actuator_front: ActuatorState,
                       actuator_rear: ActuatorState, x: float, y: float, psi: float, u: float,
                       v: float, yaw_rate: float, y_s: float, wheel_speeds: tuple, off_belt: bool,
                       off_belt_edge: str, arm_fault: bool, fault: bool, fault_reason: str,
                       input_warnings: tuple = (), applied_inputs: Optional[RigInputs] = None,
                       encoder_counts: tuple = (), encoder_velocity: tuple = (),
                       tyre: Optional[TyreTruth] = None) -> None:
        self.time = time
        self.arm_angles = arm_angles
        self.belt_speed_measured = belt_speed_measured
        self.belt_speed = belt_speed
        self.actuator_front = actuator_front
        self.actuator_rear = actuator_rear
        self.x = x
        self.y = y
        self.psi = psi
        self.u = u
        self.v = v
        self.yaw_rate = yaw_rate
        self.y_s = y_s
        self.wheel_speeds = wheel_speeds
        self.off_belt = off_belt
        self.off_belt_edge = off_belt_edge
        self.arm_fault = arm_fault
        self.fault = fault
        self.fault_reason = fault_reason
        self.input_warnings = input_warnings
        self.applied_inputs = applied_inputs
        self.encoder_counts = encoder_counts
        self.encoder_velocity = encoder_velocity
        self.tyre = tyre


def unflatten(d: dict) -> dict:
    """Turn ROS-style dotted keys (``'actuator_front.lag_hz'``) into nested dicts."""
    out: dict = {}
    for k, v in d.items():
        if isinstance(v, dict):
            v = unflatten(v)
        parts = str(k).split('.')
        cur = out
        for p in parts[:-1]:
            cur = cur.setdefault(p, {})
            if not isinstance(cur, dict):
                raise ValueError(f'parameter {k!r} conflicts with a scalar parameter {p!r}')
        if parts[-1] in cur and isinstance(cur[parts[-1]], dict) and isinstance(v, dict):
            cur[parts[-1]].update(v)
        else:
            cur[parts[-1]] = v
    return out


def _coerce(name: str, default, value):
    """Convert a YAML value to the type of the default, with a clear error."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f'{name} must be true or false, got {value!r}')
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f'{name} must be an integer, got {value!r}')
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f'{name} must be a number, got {value!r}')
        if not math.isfinite(float(value)):
            raise ValueError(f'{name} must be finite, got {value!r}')
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError(f'{name} must be a string, got {value!r}')
        return value
    return value


def _section(name: str, defaults: dict, given) -> dict:
    if given is None:
        return dict(defaults)
    if not isinstance(given, dict):
        raise ValueError(f'parameter section {name!r} must be a mapping, got {given!r}')
    unknown = set(given) - set(defaults)
    if unknown:
        raise ValueError(f'unknown parameter(s) {sorted(unknown)} in section {name!r}; '
                         f'expected some of {sorted(defaults)}')
    out = dict(defaults)
    for k, v in given.items():
        out[k] = _coerce(f'{name}.{k}', defaults[k], v)
    return out


def _bicycle_defaults() -> dict:
    """Bicycle section defaults: preset ``irs_2wd``; the explicit fields (assumed 1:10 car) are
    used only when ``preset`` is ''.
    """
    return dict(preset='irs_2wd', mass=1.9, yaw_inertia=0.03, lf=0.13, lr=0.13, c_f=40.0, c_r=50.0,
                track=0.16, wheel_radius=0.033, speed=1.2)


_RIG_SCALARS = ('dt', 'seed', 'plant', 'ds', 'steer_reject', 'speed_cmd_max', 'x0', 'y0', 'u0',
                'belt_speed0')


@dataclass
class RigConfig:
    """Validated rig configuration (see ``config/rig.yaml`` for units and defaults).

    Build with :meth:`from_dict` from the YAML ``ros__parameters`` mapping (nested or dotted
    keys).  Unknown keys, wrong types and non-physical values raise ``ValueError``.
    """

    dt: float = 1e-3
    seed: int = 0
    plant: str = 'identified'
    ds: float = SENSOR_DISTANCE
    steer_reject: float = DEFAULT_STEER_REJECT_RAD
    speed_cmd_max: float = 5.0
    x0: float = 0.0
    y0: float = 0.0
    u0: float = 1.2
    belt_speed0: float = 1.2
    actuator_front: ActuatorParams = field(default_factory=ActuatorParams)
    actuator_rear: ActuatorParams = field(default_factory=ActuatorParams)
    identified: IdentifiedParams = field(default_factory=IdentifiedParams)
    bicycle: dict = field(default_factory=_bicycle_defaults)
    car: CarParams = field(default_factory=CarParams)
    arm_geometry: ArmGeometry = field(default_factory=ArmGeometry)
    arm_sensor: ArmSensorParams = field(default_factory=ArmSensorParams)
    belt: BeltParams = field(default_factory=BeltParams)
    two_track: dict = field(default_factory=two_track_defaults)
    surface: dict = field(default_factory=surface_defaults)
    encoders: dict = field(default_factory=encoder_defaults)


    @classmethod
    def from_dict(cls, params: dict | None) -> "RigConfig":
        """Build from a (possibly dotted) parameter dict; missing keys take the defaults."""
        d = unflatten(dict(params or {}))
        base = cls()
        scal = {k: getattr(base, k) for k in _RIG_SCALARS}
        sections = ('actuator_front', 'actuator_rear', 'identified', 'bicycle', 'car', 'arm',
                    'belt', 'two_track', 'surface', 'encoders')
        unknown = set(d) - set(scal) - set(sections)
        if unknown:
            raise ValueError(f'unknown parameter(s) {sorted(unknown)}; expected some of '
                             f'{sorted(set(scal) | set(sections))}')
        kw = {k: _coerce(k, scal[k], d[k]) for k in scal if k in d}

        act_def = {f.name: getattr(ActuatorParams(), f.name) for f in fields(ActuatorParams)}
        for side in ('actuator_front', 'actuator_rear'):
            kw[side] = ActuatorParams(**_section(side, act_def, d.get(side)))

        ipd = IdentifiedParams()
        idd = {'gain': 0.0, 'speed': 1.2, 'ds': -1.0,
               'numerator': [round(v, 12) for v in ipd.numerator()],
               'denominator': [round(v, 12) for v in ipd.denominator()],
               'heading': ipd.heading}
        ids = _section('identified', idd, d.get('identified'))
        quad = {}
        for key in ('numerator', 'denominator'):
            q = ids[key]
            if not (isinstance(q, (list, tuple)) and len(q) == 2
                    and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                            and math.isfinite(v) for v in q)):
                raise ValueError(f'identified.{key} must be two coefficients [a1, a0] of '
                                 f's^2 + a1 s + a0 (1/s, 1/s^2); got {q!r}')
            # Eq. 6's coefficients keep Eq. 6's roots exactly (the stepped matrices to the bit)
            quad[key] = (getattr(ipd, 'zeros' if key == 'numerator' else 'poles')
                         if [round(float(v), 12) for v in q] == idd[key]
                         else quadratic_roots(float(q[0]), float(q[1])))
        kw['identified'] = IdentifiedParams(
            gain=None if ids['gain'] == 0.0 else ids['gain'], speed=ids['speed'],
            ds=kw.get('ds', base.ds) if ids['ds'] < 0.0 else ids['ds'],
            zeros=quad['numerator'], poles=quad['denominator'], heading=ids['heading'])
        kw['bicycle'] = _section('bicycle', _bicycle_defaults(), d.get('bicycle'))
        car_def = asdict(CarParams())
        kw['car'] = CarParams(**_section('car', car_def, d.get('car')))
        geo_def = asdict(ArmGeometry())
        sen_def = asdict(ArmSensorParams())
        sen_def.pop('seed')
        arm = _section('arm', {**geo_def, **sen_def}, d.get('arm'))
        kw['arm_geometry'] = ArmGeometry(**{k: arm[k] for k in geo_def})
        kw['arm_sensor'] = ArmSensorParams(**{k: arm[k] for k in sen_def},
                                           seed=kw.get('seed', base.seed))
        belt_def = asdict(BeltParams())
        kw['belt'] = BeltParams(**_section('belt', belt_def, d.get('belt')))
        kw['two_track'] = _section('two_track', two_track_defaults(), d.get('two_track'))
        kw['surface'] = _section('surface', surface_defaults(), d.get('surface'))
        kw['encoders'] = _section('encoders', encoder_defaults(), d.get('encoders'))
        cfg = cls(**kw)
        cfg.validate()
        return cfg

    def validate(self) -> None:
        """Raise ``ValueError`` for non-physical values."""
        if not (math.isfinite(self.dt) and 0.0 < self.dt <= 0.05):
            raise ValueError(f'dt must be a step in (0, 0.05] s, got {self.dt!r}')
        if self.plant not in PLANTS:
            raise ValueError(f"plant must be one of {', '.join(PLANTS)}, got {self.plant!r}")
        if not (self.steer_reject > 0.0):
            raise ValueError(
                f'steer_reject must be a positive angle in rad, got {self.steer_reject!r}'
            )
        if not (self.speed_cmd_max > 0.0):
            raise ValueError(
                f'speed_cmd_max must be a positive speed in m/s, got {self.speed_cmd_max!r}'
            )
        if not (0.0 <= self.u0 <= self.speed_cmd_max):
            raise ValueError(f'u0 must be in [0, speed_cmd_max] m/s, got {self.u0!r}')
        if not (0.0 <= self.belt_speed0 <= self.belt.v_top):
            raise ValueError(
                f'belt_speed0 must be in [0, {self.belt.v_top}] m/s, got {self.belt_speed0!r}'
            )
        self.actuator_front.validate()
        self.actuator_rear.validate()
        self.identified.validate()
        if self.plant == 'identified' and self.identified.heading == 'bicycle':
            IdentifiedPlant(self.identified)      # refuses a G(s) no bicycle has, with a sentence
        self.car.validate()
        self.arm_sensor.validate()
        if self.plant == 'bicycle':
            self.make_bicycle_params()
        if self.plant == 'two_track':
            self.make_torque_car()

    def make_torque_car(self) -> TorqueCarPlant:
        """The torque car of the ``two_track``, ``surface`` and ``encoders`` groups (each bad
        value refused with one sentence naming it).
        """
        return TorqueCarPlant(make_two_track_params(self.two_track),
                              make_surface(self.surface), make_encoder_params(self.encoders),
                              check_torque_limit(self.two_track['torque_limit']), self.ds)

    def make_bicycle_params(self):
        """``BicycleParams`` from the ``bicycle`` section (a named preset if given)."""
        from irs_models.bicycle import BicycleParams

        b = dict(self.bicycle)
        name = b.pop('preset', '')
        b.pop('speed', None)
        if name:
            from irs_models.presets import get_preset  # the bicycle-model engineer's presets

            try:
                return get_preset(name).params
            except KeyError as exc:
                raise ValueError(f'bicycle.preset: {exc.args[0]}') from None
        return BicycleParams(**b)


# ----------------------------------------------------------------------------- simulation
class RigSimulation:
    """Deterministic rig simulation.

    Composition per step ``k -> k+1`` (time ``t_k = k dt``), inputs held (ZOH) over the step:

    1. The inputs are sanitised (:func:`sanitize_steer`, :func:`sanitize_voltage`,
       :func:`sanitize_speed`): NaN/inf/out-of-range values are replaced by the safe value and a
       reason string is recorded in ``RigOutputs.input_warnings``.
    2. The lateral plant advances with the **achieved** steer angles at ``t_k`` (actuator outputs
       read before the actuators step; ZOH of the sampled actuator output, i.e. at most one sample,
       1 ms at 1 kHz, of extra lag versus a continuous cascade).
    3. The car's longitudinal state advances with ``psi_k``, ``v_k`` held and the *exact* belt
       travel over the step (belt stepped first, ``x -= s_{k+1} - s_k``).
    4. Both steering actuators step with the commands; the belt steps with the drive voltage.
    5. Outputs at ``t_{k+1}`` are formed: arm potentiometer angles (inverse kinematics + noise +
       ADC), belt encoder speed, actuator states, ground truth, wheel speeds, fault flags.

    Timing convention (shared with the ROS graph, which must agree bit-for-bit with
    :func:`simulate`): ``outputs_k`` describe the state at ``t_k``; the command applied during step
    ``k -> k+1`` is the one computed from ``outputs_k`` (``inputs_k = input_fn(outputs_k)``).  So a
    controller that reads the sensors at ``t_k`` and answers immediately acts over ``[t_k,
    t_{k+1})`` -- no extra sample of delay beyond the physical ones (actuator transport delay, belt
    delay, encoder delay).

    Faults are latched: the first off-belt edge (``'front'``, ``'rear'``, ``'left'``, ``'right'``,
    ``'nonfinite'``) or an arm reach error sets ``fault`` and ``fault_reason``; the simulation
    keeps integrating (the ROS node decides what to do).  Arm angles are NaN while the arm cannot
    reach.

    Torque car (``plant: two_track``, :mod:`.rig_torque_car`): steps 2-3 are one RK4 step of the
    two-track model with the achieved steer at ``t_k``, the wheel torques and locked flags of
    ``RigInputs`` (sanitised: non-finite -> 0 N m with a reason, clipped to
    ``two_track.torque_limit``) and the belt's mean speed and acceleration over the step (the belt
    is stepped first); the driver's speed command is ignored (the speed comes from the wheel
    torques). The outputs then carry the encoder counts and velocities and the tyres' ground truth
    (``RigOutputs.encoder_counts``, ``encoder_velocity``, ``tyre``; empty / None for the other
    plants, whose steps are unchanged to the bit).

    Heading with ``plant: identified``: Eq. 6 has no yaw or sideslip state, so the heading, yaw
    rate, c.g. position and the arm angles derived from them are NOT physical (``psi = v_s / U``,
    see :mod:`irs_models.identified`; a 5 deg doublet on the ``irs_2wd`` preset puts the heading
    off by 33-460 % of its peak, 1 s to 0.1 s per half).  Only the sensor-point displacement y_s is
    the model's.  Use ``plant: bicycle`` when heading or yaw rate matter, or ``identified.heading:
    bicycle`` for an identified G(s) that is some bicycle's (refused with a sentence otherwise).
    """

    def __init__(self, config: RigConfig | None = None):
        self.config = config if config is not None else RigConfig()
        self.config.validate()
        c = self.config
        self.act_front = SteeringActuator(copy.deepcopy(c.actuator_front),
                                          seed=actuator_seed(c.seed, 'front'))
        self.act_rear = SteeringActuator(copy.deepcopy(c.actuator_rear),
                                         seed=actuator_seed(c.seed, 'rear'))
        self.torque_car: Any = None        # a TorqueCarPlant, or None
        if c.plant == 'identified':
            self.plant: Any = IdentifiedPlant(c.identified)   # a LateralPlant, or None
        elif c.plant == 'bicycle':
            self.plant = BicyclePlant(c.make_bicycle_params(), c.bicycle['speed'], c.ds)
        else:
            self.plant = None
            self.torque_car = c.make_torque_car()
        self.car = CarOnBelt(c.car, c.x0, c.u0)
        self.arm = ArmSensor(c.arm_geometry, c.arm_sensor)
        self.belt = TreadmillBelt(c.belt)
        self.reset()

    def reset(self) -> RigOutputs:
        """Reset every component to the configured initial state; returns ``outputs_0``."""
        c = self.config
        self.act_front.reset(0.0)
        self.act_rear.reset(0.0)
        if self.torque_car is not None:
            self.torque_car.reset(c.x0, c.y0, c.u0, 0.0, c.dt)
        else:
            self.plant.reset(c.y0)
        self.car.reset(c.x0, c.u0)
        self.arm.reset()
        self.belt.reset(c.belt_speed0)
        self.k = 0
        self._speed_cmd = c.u0
        self._fault_reason = ''
        self.path_rate = 1.0
        self._path_time = 0.0
        self._outputs = self._make_outputs((), None)
        return self._outputs

    def reset_to_start(self, belt_speed: float | None = None) -> RigOutputs:
        """Put the car back at its start pose and clear the latched fault; time runs on.

        For a ``rig/reset`` service in the middle of a run (``reset()`` would restart the clock
        at t = 0, which a running graph cannot follow). Afterwards:

        * the car is at its configured start (``x0``, ``y0``, heading 0, zero lateral and yaw
          velocities, forward speed ``u0``; the remembered speed command is ``u0``; the torque
          car's wheels rolling at ``u0 / R``, its encoders counting on);
        * both steering actuators are at 0 rad with empty delay lines (their radio frames run
          on: the transmitter does not stop);
        * the latched fault (off-belt edge or arm reach) is cleared; it re-latches on the
          outputs formed here if the start pose itself is off the belt;
        * the time ``t_k`` and step counter are unchanged, the arm-noise stream continues (not
          re-seeded: a deterministic run stays deterministic);
        * the belt keeps its speed and delay line (it is not teleported) unless ``belt_speed``
          [m/s] is given: then it is reset to that speed in equilibrium, its encoder too.

        Returns the outputs at the current time (``outputs`` afterwards), with the reset pose.

        Raises
        ------
        ValueError
            ``belt_speed`` outside ``[0, belt.v_top]`` or not finite.
        """
        c = self.config
        if belt_speed is not None:
            self.belt.reset(float(belt_speed))   # validates the speed before anything changes
        self.act_front.reset(0.0, keep_clock=True)
        self.act_rear.reset(0.0, keep_clock=True)
        if self.torque_car is not None:
            self.torque_car.restart(c.x0, c.y0, c.u0, self.time)
        else:
            self.plant.reset(c.y0)
        self.car.reset(c.x0, c.u0)
        self._speed_cmd = c.u0
        self._fault_reason = ''
        self._outputs = self._make_outputs((), None)
        return self._outputs

    @property
    def plant_speed(self) -> float:
        """The lateral plant's speed ``U`` [m/s] (its linearisation; the torque car's start
        speed ``u0``).
        """
        c = self.config
        if c.plant == 'bicycle':
            return float(c.bicycle['speed'])
        return float(c.identified.speed if c.plant == 'identified' else c.u0)

    @property
    def curvature_gain(self) -> float:
        """The car's steady path curvature per unit front steer [1/(m rad)]: the lateral
        plant's :meth:`~irs_models.lateral_plant.ZohSteps.curvature_gain` at ``U``; the torque
        car's kinematic ``1 / (l_f + l_r)``.
        """
        if self.plant is not None:
            return self.plant.curvature_gain(self.plant_speed)
        p = self.torque_car.car.params
        return 1.0 / (p.lf + p.lr)

    def stop_torque_params(self, rate: float = 10.0) -> dict:
        """``wheel_speed_gain`` [N m s/m] and ``torque_limit`` [N m] of the torque car's speed
        loop in a controlled stop (:meth:`~irs_vehicle_sim.safe_stop.SafeStop.stop_torque`):
        ``m R rate / 4`` for a loop rate ``rate`` [1/s]; ``{}`` for the other plants.

        The limit is the motors' or what the tyres transmit without spinning, whichever is
        smaller: ``STOP_TRACTION mu_min m g R / 4`` per wheel, ``mu_min`` the lowest friction of
        the surface. The stop's speed loop must not spin the wheels: on mu 0.3 the motors' 0.3 N m
        is 4.3 times what a tyre transmits (``mu m g R / 4`` = 0.069 N m), and a stop that
        found the car 1.2 m/s slower than a belt running at 6.5 m/s (a real-time run that had lost
        its loop) spun the wheels and lost the car; limited, it held it (offline, the state of
        that run).
        """
        if self.torque_car is None:
            return {}
        p = self.torque_car.car.params
        grip = STOP_TRACTION * self.torque_car.car.surface.mu_min * p.mass * GRAVITY \
            * p.wheel_radius / 4.0
        return {'wheel_speed_gain': p.mass * p.wheel_radius * rate / 4.0,
                'torque_limit': min(self.torque_car.torque_limit, grip)}

    @property
    def time(self) -> float:
        """t_k = k dt [s]."""
        return self.k * self.config.dt

    @property
    def outputs(self) -> RigOutputs:
        """Outputs at the current time t_k."""
        return self._outputs

    def step(self, inputs: RigInputs) -> RigOutputs:
        """Advance t_k -> t_{k+1} with ``inputs`` held; returns ``outputs_{k+1}``."""
        c = self.config
        dt = c.dt
        warn = []
        df, r1 = sanitize_steer(inputs.front_steer, c.steer_reject)
        dr, r2 = sanitize_steer(inputs.rear_steer, c.steer_reject)
        vb, r3 = sanitize_voltage(inputs.drive_voltage, c.belt.u_max)
        uc, r4 = sanitize_speed(inputs.speed_cmd, c.speed_cmd_max, self._speed_cmd)
        if r1 is not None or r2 is not None or r3 is not None or r4 is not None:
            for tag, r in (('front_steer', r1), ('rear_steer', r2), ('drive_voltage', r3),
                           ('speed_cmd', r4)):
                if r is not None:
                    warn.append(f'{tag}: {r}')
        self._speed_cmd = uc
        if self.torque_car is not None:
            return self._step_torque_car(inputs, RigInputs(df, dr, vb, uc), warn)
        applied = RigInputs(df, dr, vb, uc)

        plant, belt = self.plant, self.belt
        psi_k = plant.psi
        v_k = plant.lateral_velocity
        d_front_k = self.act_front.state.achieved
        d_rear_k = self.act_rear.state.achieved
        if self.path_rate == 1.0:
            plant.step(d_front_k, d_rear_k, dt)
        else:
            self._step_on_path(d_front_k, d_rear_k, dt)
        s_prev = belt.position
        belt.step(vb, dt)
        travel = belt.position - s_prev
        self.car.step(uc, psi_k, v_k, 0.0, dt)
        self.car.x -= travel
        self.act_front.step(df, dt)
        self.act_rear.step(dr, dt)
        self.k += 1
        self._outputs = self._make_outputs(tuple(warn), applied)
        return self._outputs

    def _step_on_path(self, d_front: float, d_rear: float, dt: float) -> None:
        """Advance the lateral plant by ``path_rate`` of the step (a car slower than the
        plant's speed ``U`` covers its path at ``u / U`` of real time): whole steps of ``dt``
        as the accumulated path time allows, so the plant's one discretisation serves.
        """
        self._path_time += max(0.0, min(1.0, self.path_rate)) * dt
        while self._path_time >= dt:
            self.plant.step(d_front, d_rear, dt)
            self._path_time -= dt

    def _step_torque_car(self, inputs: RigInputs, applied: RigInputs, warn: list) -> RigOutputs:
        """Step ``t_k -> t_{k+1}`` of the torque car (class docstring); ``applied`` holds the
        sanitised steer, voltage and speed command, ``warn`` their reasons.
        """
        dt = self.config.dt
        tc = self.torque_car
        tq, lk, reasons = sanitize_wheel_inputs(inputs.wheel_torque, inputs.wheel_locked,
                                                tc.torque_limit)
        warn.extend(f'wheel_torque: {r}' for r in reasons)
        applied = replace(applied, wheel_torque=tq, wheel_locked=lk)
        s_prev, v_prev = self.belt.position, self.belt.speed
        self.belt.step(applied.drive_voltage, dt)
        belt_speed = (self.belt.position - s_prev) / dt
        belt_accel = (self.belt.speed - v_prev) / dt
        tc.step(tq, lk, self.act_front.achieved, self.act_rear.achieved, belt_speed, belt_accel,
                dt)
        self.act_front.step(applied.front_steer, dt)
        self.act_rear.step(applied.rear_steer, dt)
        self.k += 1
        self._outputs = self._make_outputs(tuple(warn), applied)
        return self._outputs

    def _make_outputs(self, warnings: tuple, applied) -> RigOutputs:
        extra = {}
        if self.torque_car is not None:
            tc = self.torque_car
            x, y, psi, u, v, r, y_s = tc.pose
            truth = tc.truth()
            ws = truth.omega
            counts, velocity = tc.encoder_readings()
            extra = dict(encoder_counts=counts, encoder_velocity=velocity, tyre=truth)
        else:
            pl, car = self.plant, self.car
            x, y, psi = car.x, pl.y_cg, pl.psi
            u, v, r, y_s = car.u, pl.lateral_velocity, pl.yaw_rate, pl.y_s
            ws = wheel_speeds(u, v, r, self.act_front.state.achieved,
                              self.act_rear.state.achieved, self.config.car)
        edge = off_belt_edge(x, y, self.config.car)
        arm_fault = False
        try:
            ang = self.arm.measure_tuple(x, y, psi)
        except ArmReachError:
            ang = (math.nan, math.nan, math.nan)
            arm_fault = True
        if not self._fault_reason:
            if edge:
                self._fault_reason = f'off_belt:{edge}'
            elif arm_fault:
                self._fault_reason = 'arm_reach'
        belt = self.belt
        return RigOutputs(
            time=self.k * self.config.dt, arm_angles=ang, belt_speed_measured=belt.measured_speed,
            belt_speed=belt.speed, actuator_front=self.act_front.state.copy(),
            actuator_rear=self.act_rear.state.copy(), x=x, y=y, psi=psi, u=u, v=v,
            yaw_rate=r, y_s=y_s, wheel_speeds=ws, off_belt=bool(edge), off_belt_edge=edge,
            arm_fault=arm_fault, fault=bool(self._fault_reason),
            fault_reason=self._fault_reason, input_warnings=warnings, applied_inputs=applied,
            **extra)


_SCALAR_OUT = ('time', 'belt_speed_measured', 'belt_speed', 'x', 'y', 'psi', 'u', 'v',
               'yaw_rate', 'y_s')


def simulate(config: RigConfig | dict | None, input_fn: Callable[[RigOutputs], RigInputs],
             duration: float) -> dict:
    """Offline run (no ROS) with the shared timing convention.

    ``N = round(duration / dt)`` steps.  For k = 0..N-1: ``inputs_k = input_fn(outputs_k)`` is
    applied over ``[t_k, t_{k+1})``.

    Returns
    -------
    dict of numpy arrays
        Output series of length N+1 (``time, x, y, psi, u, v, yaw_rate, y_s, belt_speed,
        belt_speed_measured``, ``arm_angles`` (N+1, 3), ``wheel_speeds`` (N+1, 4),
        ``steer_front``/``steer_rear`` achieved, ``servo_front``/``servo_rear``, ``fault``),
        and the sanitised inputs ``front_steer_cmd, rear_steer_cmd, drive_voltage, speed_cmd`` of
        length N (row k applied during step k). With ``plant: two_track`` also
        ``encoder_counts`` (N+1, 4) int64, ``encoder_velocity`` (N+1, 4) [rad/s], the tyre truth
        ``slip, slip_angle, fx, fy, fz, mu`` (N+1, 4), ``x_belt`` (N+1,) [m] (``wheel_speeds``
        are the true spins), and the sanitised ``wheel_torque`` (N, 4) [N m] and
        ``wheel_locked`` (N, 4) bool.
    """
    if not isinstance(config, RigConfig):
        config = RigConfig.from_dict(config)
    sim = RigSimulation(config)
    n = int(round(duration / config.dt))
    if n < 0:
        raise ValueError(f'duration must be >= 0 s, got {duration!r}')
    outs = [sim.outputs]
    ins: list = []
    for _ in range(n):
        u = input_fn(outs[-1])
        o = sim.step(u)
        ins.append(o.applied_inputs)
        outs.append(o)
    res = {k: np.array([getattr(o, k) for o in outs], dtype=float) for k in _SCALAR_OUT}
    res['arm_angles'] = np.array([o.arm_angles for o in outs], dtype=float).reshape(-1, 3)
    res['wheel_speeds'] = np.array([o.wheel_speeds for o in outs], dtype=float).reshape(-1, 4)
    res['steer_front'] = np.array([o.actuator_front.achieved for o in outs])
    res['steer_rear'] = np.array([o.actuator_rear.achieved for o in outs])
    res['servo_front'] = np.array([o.actuator_front.servo for o in outs])
    res['servo_rear'] = np.array([o.actuator_rear.servo for o in outs])
    res['fault'] = np.array([o.fault for o in outs], dtype=bool)
    res['front_steer_cmd'] = np.array([i.front_steer for i in ins], dtype=float)
    res['rear_steer_cmd'] = np.array([i.rear_steer for i in ins], dtype=float)
    res['drive_voltage'] = np.array([i.drive_voltage for i in ins], dtype=float)
    res['speed_cmd'] = np.array([i.speed_cmd for i in ins], dtype=float)
    if config.plant == 'two_track':
        res.update(_torque_car_series(outs, ins))
    return res


def _torque_car_series(outs: list, ins: list) -> dict:
    """The torque car's extra series of :func:`simulate`."""
    res = {'encoder_counts': np.array([o.encoder_counts for o in outs],
                                      dtype=np.int64).reshape(-1, 4),
           'encoder_velocity': np.array([o.encoder_velocity for o in outs],
                                        dtype=float).reshape(-1, 4),
           'x_belt': np.array([o.tyre.x_belt for o in outs], dtype=float),
           'wheel_torque': np.array([i.wheel_torque for i in ins], dtype=float).reshape(-1, 4),
           'wheel_locked': np.array([i.wheel_locked for i in ins], dtype=bool).reshape(-1, 4)}
    for key in ('slip', 'slip_angle', 'fx', 'fy', 'fz', 'mu'):
        res[key] = np.array([getattr(o.tyre, key) for o in outs], dtype=float).reshape(-1, 4)
    return res
