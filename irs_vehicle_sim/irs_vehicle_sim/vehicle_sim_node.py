"""``vehicle_sim`` node: the simulated IRS rig on ROS topics (thin wrapper of :mod:`.rig`).

In ``lockstep`` the rig is the clock: it publishes ``/clock`` = t_k and every output stamped t_k,
and steps to t_{k+1} once each listed input has answered step k, so a run is reproducible to the
bit whatever the machine load. In ``realtime`` a wall timer steps it with the latest commands,
like the hardware. Bad, stale or future-stamped commands get the safe value (steer 0 rad, drive
0 V) and, past ``stall_grace``, the rig's controlled stop (:mod:`.safe_stop`). The node exists so
that the controllers, the estimator and the recorder see the same topics from the simulation
as from the hardware. Clock modes, start, message budget, stamps, the torque car's topics and
the services: :class:`VehicleSimNode`; parameters: docs/parameters.md; topics:
docs/architecture.md; stop and recovery: docs/safety.md.
"""
import dataclasses
import math
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (Point, PointStamped, Pose, PoseWithCovariance, Quaternion, Twist,
                               TwistWithCovariance, Vector3)
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Header
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.input_checks import ThrottledWarner
from irs_common.loop_timing import LoopTiming, format_ms, timing_level
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.orientation import quaternion_from_yaw
from irs_common.params import declare_table
from irs_common.stamp_gate import FUTURE, OLD, StampGate, answer_age
from irs_common.stamp_sync import StampSync
from irs_common.stamps import clock_now_ns, from_ns, to_ns
from irs_common.start_gate import ALREADY_RUNNING, StartGate
from irs_models.constants import STEER_LIMIT
from irs_msgs.msg import (BeltSpeed, DriverCommand, RigStatus, SteeringActuatorState,
                          SteeringCommand, TreadmillDriveCommand, TreadmillState, TyreState,
                          WheelEncoders, WheelTorqueCommand)

from .rig import RigInputs, RigSimulation
from .rig_params import NODE_PARAMS, rig_config, vehicle_sim_parameter_table
from .rig_torque_car import NOT_LOCKED, ZERO_TORQUE
from .safe_stop import HOLDING, RECOVERING, STOPPING, SafeStop, SafeStopParams

#: ``rig/timing`` levels of :func:`irs_common.loop_timing.timing_level`.
TIMING_LEVELS = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR)

#: lock-step input name -> (topic, message type)
INPUTS = {
    'steering': ('steering/command', SteeringCommand),
    'drive': ('treadmill/drive', TreadmillDriveCommand),
    'driver': ('driver/command', DriverCommand),
    'wheels': ('wheels/torque_command', WheelTorqueCommand),    # plant two_track only
}
#: Safe value of an input whose commands are stale (real time; steering and drive are held,
#: then the controlled stop of :mod:`.safe_stop` applies its own).
SAFE = {'steering': (0.0, 0.0), 'drive': 0.0, 'wheels': (ZERO_TORQUE, NOT_LOCKED)}
#: treadmill/state fault codes that do not stop the rig (irs_treadmill.safety.FaultCode
#: INVALID_INPUT: one rejected reading, cleared by the next valid one).
TREADMILL_PASSING_FAULTS = (6,)

ARM_JOINTS = ['arm_joint1', 'arm_joint2', 'arm_joint3']
WHEELS = ['wheel_front_left', 'wheel_front_right', 'wheel_rear_left', 'wheel_rear_right']

# Builders of the messages published every step (irs_common.msg_builder).
_CLOCK, _HEADER, _JOINT_STATE = builder(Clock), builder(Header), builder(JointState)
_BELT_SPEED, _ACTUATOR_STATE = builder(BeltSpeed), builder(SteeringActuatorState)
_ODOMETRY, _POSE_COV, _POSE = builder(Odometry), builder(PoseWithCovariance), builder(Pose)
_TWIST_COV, _TWIST, _VECTOR3 = builder(TwistWithCovariance), builder(Twist), builder(Vector3)
_POINT, _POINT_STAMPED, _QUATERNION = builder(Point), builder(PointStamped), builder(Quaternion)
_RIG_STATUS, _WHEEL_ENCODERS, _TYRE_STATE = (builder(RigStatus), builder(WheelEncoders),
                                            builder(TyreState))


class VehicleSimNode(Node):
    """Publishes what the rig's sensors report; takes steering, drive and driver commands.

    Clock modes (parameter ``clock_mode``, read-only):

    - ``realtime``: a wall timer advances the rig by as many steps as wall time has passed, each
      with the latest commands received, like the hardware. Stamps are ``t_start + k dt`` (ROS
      time).
    - ``lockstep``: the rig is the clock. It publishes ``/clock`` = t_k and every output stamped
      t_k, then waits until every input listed in ``lockstep_inputs`` has delivered a command
      stamped t_k (the answer to the measurement of t_k) before it steps to t_{k+1}. Inputs not
      listed use the latest value received. A run is therefore bit-for-bit reproducible whatever
      the machine load. If nothing arrives for ``lockstep_resend_period`` s of wall time (a
      subscriber matched late and missed step k), step k's outputs are published again; consumers
      ignore stamps they have seen.

    Start in real time: with ``autostart`` the rig holds the car at its start pose (publishing its
    sensors every step on the 1 ms grid the run then continues, the simulation not advancing:
    :meth:`_hold`) until every input in
    ``start_inputs`` has delivered a command, so a graph started by hand in any order does not lose
    the car while its nodes are still joining. ``rig/start`` (std_srvs/Trigger) starts it at once.

    Message budget per step (see docs/architecture.md): ``arm/joint_states``, ``belt/speed`` and,
    in lock-step, ``/clock`` every step; the ground truth (``ground_truth/odom``,
    ``ground_truth/sensor_point``) every ``ground_truth_decimation`` steps and ``steering/state``
    every ``actuator_state_decimation`` steps (0 = off: simulation-only extras a real-time run can
    drop); ``rig/status`` on a change and every ``status_period`` s. In real time the rig measures
    its own loop (deadline misses, loop latency: :mod:`irs_common.loop_timing`) and publishes it on
    ``rig/timing`` (diagnostic_msgs/DiagnosticArray) every second.

    Commands that are NaN, inf or out of range are replaced by the safe value (steer 0 rad, drive 0
    V, driver speed held) with a throttled warning; the counts are on ``rig/status``. In real time
    a command is as old as the rig's sample it answers (its stamp; any other stamp counts from its
    arrival): a steering or drive command older than ``command_timeout`` is held, and one older
    than ``stall_grace``, whether silent or answering old samples (or a fault on
    ``treadmill/state``), brings the rig to its controlled stop, car and belt together
    (:mod:`.safe_stop`; ``rig/status`` says which, and why, in one log line).

    The torque car (``plant: two_track``, docs/torque_car.md): the rig also subscribes
    ``wheels/torque_command`` (irs_msgs/WheelTorqueCommand, the lock-step input ``wheels``) and
    publishes ``wheels/encoders`` (irs_msgs/WheelEncoders) every step and the tyres' ground truth
    ``rig/tyre_truth`` (irs_msgs/TyreState) every ``ground_truth_decimation`` steps; the driver's
    speed command is ignored. A non-finite wheel torque is replaced by 0 N m (that wheel coasts), a
    stale one (real time, ``command_timeout``) or none yet by 0 N m on every wheel and no wheel
    locked, each with a throttled warning. The other plants have none of these topics.

    Stamps of commands (irs_common.stamp_gate): one stamped more than ``future_tolerance`` s ahead
    of the rig's time (lock-step: the current step; real time: the node clock) is dropped and
    counted as rejected (it is not applied and does not refresh the stale timer). In lock-step a
    command for an earlier step is a resend duplicate and ignored. In real time a command older
    than the last one of its input is ignored as out of order, unless it is more than 1 s older (a
    restarted publisher): then it is taken; a command with the same stamp as the last is taken
    (``ros2 topic pub`` sends stamp 0 every time).

    ``rig/reset`` (std_srvs/Trigger): after the car left the belt (or at any time), put the car
    back at its start pose and clear the rig's latched fault (:meth:`RigSimulation.reset_to_start`;
    time runs on, the belt keeps its speed); ``rig/status`` says ``car_on_belt`` again (a stop
    stays). ``rig/recover`` (std_srvs/Trigger, real time): the whole rig running again from any
    fault: the car held at its start pose, the treadmill reset (``treadmill/reset``,
    std_msgs/Empty), the belt brought up to ``u0`` by the rig, then the car released
    (docs/safety.md).

    Writable parameters (``ros2 param set``, applied at once): ``command_timeout``,
    ``stall_grace``, ``lockstep_resend_period``.
    """

    def __init__(self, **node_options):
        super().__init__('vehicle_sim', **node_options)
        values = declare_table(self, vehicle_sim_parameter_table(), on_change=self._on_parameter)
        self.p = {p.name: values[p.name] for p in NODE_PARAMS}
        self.config = rig_config(values)
        if self.p['clock_mode'] not in ('realtime', 'lockstep'):
            raise ValueError(
                f"clock_mode must be 'realtime' or 'lockstep', got {self.p['clock_mode']!r}"
            )
        self.lockstep = self.p['clock_mode'] == 'lockstep'
        self.torque_car = self.config.plant == 'two_track'
        # the wheel torque input exists only for the torque car (no extra topic on the others)
        self.inputs = {n: v for n, v in INPUTS.items() if n != 'wheels' or self.torque_car}
        required = [n for n in self.p['lockstep_inputs'] if n]
        self._check_input_names('lockstep_inputs', required)
        self.required = tuple(required) if self.lockstep else ()
        self.start_inputs = tuple(n for n in self.p['start_inputs'] if n)
        self._check_input_names('start_inputs', self.start_inputs)
        self.status_every = max(1, int(round(self.p['status_period'] / self.config.dt)))
        self.sim = RigSimulation(self.config)
        self.safe = SafeStop(SafeStopParams(
            command_timeout=self.p['command_timeout'], stall_grace=self._grace(),
            belt_gain=self.config.belt.gain / self.config.belt.pole,
            u_max=self.config.belt.u_max, u0=self.config.u0,
            curvature_gain=self.sim.curvature_gain, steer_limit=STEER_LIMIT,
            **self.sim.stop_torque_params()))
        self.plant_speed = self.sim.plant_speed
        self.dt_ns = int(round(self.config.dt * 1e9))
        if abs(self.dt_ns * 1e-9 - self.config.dt) > 1e-15:
            raise ValueError(f'dt = {self.config.dt} s is not a whole number of nanoseconds')

        # Latest accepted command of every input (used for inputs that are not lock-step inputs).
        self.latest = {'steering': (0.0, 0.0), 'drive': self.p['default_drive_voltage'],
                       'driver': self.config.u0, 'wheels': SAFE['wheels']}
        self.rejected = {'steering': 0, 'drive': 0, 'driver': 0, 'wheels': 0}
        # input name -> time.monotonic() its latest command counts from (real time: the time of
        # the sample it answers, ``stamp_gate.answer_age``)
        self.received_at = {}
        self.stale_inputs = set()
        self.sync = StampSync(self.required) if self.required else None
        self.resends = {}           # lock-step: step -> times its outputs were published again
        tolerance_ns = int(round(self.p['future_tolerance'] * 1e9))
        self.gates = {name: StampGate(tolerance_ns) for name in self.inputs}   # real time
        self.resets = 0

        # rclpy's throttled logging costs ~1 ms per call: per-step warnings are throttled first.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.info_warner = ThrottledWarner(self._log_info, 1.0)
        self.pub_clock = (
            self.create_publisher(Clock, '/clock', qos.CLOCK_PUB) if self.lockstep else None
        )
        self.pub_arm = self.create_publisher(JointState, 'arm/joint_states', qos.SENSOR_PUB)
        self.pub_belt = self.create_publisher(BeltSpeed, 'belt/speed', qos.SENSOR_PUB)
        self.pub_act = self.create_publisher(SteeringActuatorState, 'steering/state',
                                             qos.SENSOR_PUB)
        self.pub_odom = self.create_publisher(Odometry, 'ground_truth/odom', qos.SENSOR_PUB)
        self.pub_point = self.create_publisher(
            PointStamped, 'ground_truth/sensor_point', qos.SENSOR_PUB
        )
        self.pub_wheels = (self.create_publisher(JointState, 'wheel_speeds', qos.SENSOR_PUB)
                           if self.p['publish_wheel_speeds'] else None)
        # torque car: the encoders are the controller's 1 kHz measurement, as the arm angles
        # (SENSOR: reliable, keep last 100: a lock-step controller must see every sample), the
        # tyre truth a decimated ground truth for the recorder, as ground_truth/odom
        self.pub_encoders = (self.create_publisher(WheelEncoders, 'wheels/encoders',
                                                   qos.SENSOR_PUB)
                             if self.torque_car else None)
        self.pub_tyre = (self.create_publisher(TyreState, 'rig/tyre_truth', qos.SENSOR_PUB)
                         if self.torque_car else None)
        self.pub_status = self.create_publisher(RigStatus, 'rig/status', qos.STATUS_PUB)
        self.pub_timing = (None if self.lockstep else
                           self.create_publisher(DiagnosticArray, 'rig/timing', qos.STATUS_PUB))
        self.timing = LoopTiming()
        self.arm_sent = {}  # real time: arm stamp [ns] -> monotonic time of publishing
        self.last_steer_stamp = -1       # real time: stamp of the newest steering command
        self.subs = {name: self.create_subscription(
            mtype, topic, lambda msg, n=name: self._on_command(n, msg), qos.COMMAND)
            for name, (topic, mtype) in self.inputs.items()}

        self.last_fault = None
        self.run_complete = False
        self.started = False
        self.stamp0_ns = 0
        self.timer = None
        self.create_service(Trigger, 'rig/start', self._on_start)
        self.create_service(Trigger, 'rig/reset', self._on_reset)
        self.create_service(Trigger, 'rig/recover', self._on_recover)
        # the treadmill's fault stops the rig (real time); recover resets it (std_msgs/Empty on
        # treadmill/reset: a service call from a callback would wait on this executor)
        self.create_subscription(TreadmillState, 'treadmill/state', self._on_treadmill_state,
                                 qos.SENSOR)
        self.pub_treadmill_reset = self.create_publisher(Empty, 'treadmill/reset', qos.COMMAND)
        self.holding = False
        self.status_k = -1
        if self.p['autostart']:
            if self.lockstep or not self.start_inputs:
                self._start()
            else:
                self._hold()
        self.get_logger().info(
            f"rig up: {self.p['clock_mode']}, dt = {self.config.dt} s, plant = {self.config.plant}"
            + (f', lock-step inputs {list(self.required)}' if self.lockstep else ''))


    def _grace(self) -> float:
        """The stall grace in effect [s]: ``stall_grace``, at least ``command_timeout``."""
        return max(self.p['stall_grace'], self.p['command_timeout'])

    def _check_input_names(self, what, names):
        unknown = set(names) - set(self.inputs)
        if unknown:
            extra = ('' if self.torque_car or 'wheels' not in unknown
                     else " ('wheels' needs plant: two_track)")
            raise ValueError(f'{what}: unknown input(s) {sorted(unknown)}; expected some of '
                             f'{sorted(self.inputs)}{extra}')

    # rclpy fixes a logging call site's severity at its first call (a later call with another
    # severity raises ValueError): warners that log at other severities than warning call rclpy
    # from these lines, not from ThrottledWarner's one.
    def _log_info(self, text):
        self.get_logger().info(text)

    def _hold(self):
        """Real time, before the start: publish the start pose at the step rate, the simulation
        not advancing. The stamps are those of a run started at the hold's first tick: ``t_0 + n
        dt`` for hold step n, the steps a late tick missed published back to back (at most 0.1
        s, as :meth:`_realtime_tick`), and the run goes on from the last hold step. So the
        samples' stamps stay 1 ms apart across the start, and an estimator differentiating
        them is not reset by the timer's jitter (a gap off ``dt`` restarts its
        differentiators).
        """
        self.holding = True
        self.get_logger().info(
            f'holding the car at its start pose until {list(self.start_inputs)} '
            'have delivered a command (or rig/start is called)'
        )
        self.hold_clock = (clock_now_ns(self.get_clock()), time.monotonic())
        self.hold_sent = -1            # the last hold step published

        def hold_tick():
            missing = [n for n in self.start_inputs if n not in self.received_at]
            if missing:
                stamp0_ns, wall0 = self.hold_clock
                due = int((time.monotonic() - wall0) / self.config.dt)
                for n in range(max(self.hold_sent + 1, due - 99), due + 1):
                    self.stamp0_ns = stamp0_ns + n * self.dt_ns
                    self._publish_outputs()
                self.hold_sent = max(self.hold_sent, due)
                return
            self.get_logger().info(f'inputs {list(self.start_inputs)} present: starting')
            self._start()
        self.timer = self.create_timer(self.config.dt, hold_tick)

    def _start(self):
        resume = None
        if self.holding:
            self.holding = False
            self.destroy_timer(self.timer)
            if self.hold_sent >= 0:    # step 0 of the run is the last hold step
                stamp0_ns, wall0 = self.hold_clock
                resume = (stamp0_ns + self.hold_sent * self.dt_ns,
                          wall0 + self.hold_sent * self.config.dt)
        self.started = True
        if self.lockstep:
            self.stamp0_ns = 0
            gate = StartGate(self)   # step 0 once the runner's subscriptions are matched

            def begin():
                if not gate.ready():
                    return
                self.destroy_timer(self.timer)
                self.last_progress = time.monotonic()
                self._publish_outputs()
                self.timer = self.create_timer(0.05, self._lockstep_watchdog)
            self.timer = self.create_timer(0.01, begin)
        else:
            if resume is None:
                resume = (clock_now_ns(self.get_clock()), time.monotonic())
            self.stamp0_ns, self.wall0 = resume
            self.next_timing = self.tick_now = time.monotonic()
            self.timer = self.create_timer(self.config.dt, self._realtime_tick)

    def _on_start(self, _request, response):
        if self.started and not self.holding:
            response.success = False
            response.message = ALREADY_RUNNING
        else:
            self._start()
            response.success = True
            response.message = f"started ({self.p['clock_mode']})"
        return response

    def _on_reset(self, _request, response):
        was = self.sim.outputs.fault_reason
        self.sim.reset_to_start()
        self.resets += 1
        response.success = True
        response.message = (
            f'car back at its start pose (x = {self.config.x0} m, y = '
            f'{self.config.y0} m) at t = {self.sim.time:.3f} s; was: {was or "no fault"}'
        )
        self.get_logger().info(f'rig/reset: {response.message}')
        if self.started and not self.holding:
            self._publish_status(self.sim.outputs, from_ns(self._stamp_ns()))
            self.last_fault = (self.sim.outputs.fault, self.sim.outputs.fault_reason,
                               self.safe.state, self.safe.late)
        return response

    def _on_recover(self, _request, response):
        if self.lockstep or not self.started or self.holding:
            response.success = False
            response.message = ('not running in real time (lock-step runs restart with '
                                'rig/reset; before the start the car is held anyway)')
            return response
        was = self.safe.cause or self.sim.outputs.fault_reason or 'no fault'
        self.sim.reset_to_start()
        self.sim.path_rate = 1.0
        self.safe.recover()
        self.stale_inputs.clear()
        self.pub_treadmill_reset.publish(Empty())
        response.success = True
        response.message = (
            f'recovering: treadmill fault reset, car held at its start pose until the belt runs '
            f'at {self.config.u0} m/s and the steering and drive commands are fresh; was: {was}')
        self.get_logger().info(f'rig/recover: {response.message}')
        return response

    def _on_treadmill_state(self, msg):
        if self.lockstep or not self.started or self.holding:
            return
        if msg.mode == TreadmillState.MODE_FAULT \
                and msg.fault_code not in TREADMILL_PASSING_FAULTS:
            cause = self.safe.stop(f'treadmill fault {msg.fault_code}: {msg.fault_text}')
            if cause:
                self._announce_stop(cause)

    def _on_parameter(self, name, value):
        self.p[name] = value    # read where used (watchdog, stale check)
        if name in ('command_timeout', 'stall_grace'):
            self.safe.params = dataclasses.replace(
                self.safe.params, command_timeout=self.p['command_timeout'],
                stall_grace=self._grace())
        self.get_logger().info(f'parameter {name} = {value!r} applied')

    # ---------------------------------------------------------------- inputs
    def _decode(self, name, msg):
        if name == 'steering':
            return (msg.front_angle, msg.rear_angle)
        if name == 'drive':
            return msg.voltage
        if name == 'wheels':
            return (tuple(float(t) for t in msg.torque), tuple(bool(b) for b in msg.locked))
        return msg.speed

    def _on_command(self, name, msg):
        value = self._decode(name, msg)
        stamp = to_ns(msg.header.stamp)
        if name in self.required:
            if not self.started:
                return
            current = self._stamp_ns()
            if stamp < current:
                return  # answer to a step already taken (a resend duplicate)
            if stamp - current > self.gates[name].future_tolerance_ns:
                self._reject_stamp(name, FUTURE, stamp, current)
                return
            for stamp_ns, values in self.sync.add(name, stamp, value):
                if stamp_ns == self._stamp_ns():
                    self._lockstep_step(values)
            return
        if self.lockstep:
            now_ns = self._stamp_ns()
        else:
            now_ns = clock_now_ns(self.get_clock())
        verdict = self.gates[name].check(stamp, now_ns)
        if verdict == FUTURE or verdict == OLD:
            self._reject_stamp(name, verdict, stamp, now_ns)
            return
        self.latest[name] = value
        now = time.monotonic()
        # a command counts from the sample it answers (a graph that falls behind is late)
        self.received_at[name] = now - answer_age(stamp, self.stamp0_ns, self._stamp_ns())
        if name == 'steering' and self.started:
            sent = self.arm_sent.pop(stamp, None)
            if sent is not None:
                self.timing.add_latency(now - sent)
            self.last_steer_stamp = (
                stamp if verdict == 'reset' else max(self.last_steer_stamp, stamp)
            )

    def _reject_stamp(self, name, verdict, stamp, now_ns):
        if verdict == FUTURE:
            self.rejected[name] += 1
        self.warner.warn(f'{name}-{verdict}', f'{name} command '
                         f'{self.gates[name].reason(verdict, stamp, now_ns)}', time.monotonic())

    # ---------------------------------------------------------------- stepping
    def _stamp_ns(self) -> int:
        return self.stamp0_ns + self.sim.k * self.dt_ns

    def _fresh_latest(self) -> dict:
        """Latest commands (real time: late steering/drive held, stale wheel torques zero; the
        safe-stop state updated from the inputs' ages at this step's time).
        """
        latest = dict(self.latest)
        if self.lockstep:
            return latest
        # the wall time of this tick (the inputs' ages are real ages, whatever the rig's own
        # lag), and how far the step being taken is behind real time
        now = self.tick_now
        if self.torque_car:
            self._wheels_fresh(latest, now)
        held = self.safe.late
        cause = self.safe.watch(now, self.received_at,
                                now - self.wall0 - self.sim.k * self.config.dt)
        if cause:
            self._announce_stop(cause)
        elif self.safe.late != held:
            if self.safe.late:
                self.warner.warn('late', f'{self.safe.late} command late (> command_timeout '
                                 f"{self.p['command_timeout']} s): its last value is held for "
                                 f"up to stall_grace {self.p['stall_grace']} s", time.monotonic())
            else:
                self.info_warner.warn('fresh', f'{held} commands fresh again', time.monotonic())
        return latest

    def _wheels_fresh(self, latest: dict, now: float) -> None:
        """Torque car: no or stale wheel torque command -> 0 N m on every wheel, no lock."""
        seen = self.received_at.get('wheels')
        if seen is None:
            if self.started:
                self.warner.warn('wheels-missing', 'no wheel torque command yet: using 0 N m on '
                                 'every wheel (the car coasts)', time.monotonic())
            return
        if now - seen <= self.p['command_timeout']:
            if 'wheels' in self.stale_inputs:
                self.stale_inputs.discard('wheels')
                self.info_warner.warn('wheels-fresh', 'wheels commands are fresh again', now)
            return
        latest['wheels'] = SAFE['wheels']
        if 'wheels' not in self.stale_inputs:    # once per transition, at most 1/s
            self.stale_inputs.add('wheels')
            self.warner.warn('wheels-stale', f'wheels command stale (none for {now - seen:.3f} '
                             f"s > {self.p['command_timeout']} s): using 0 N m on every wheel",
                             time.monotonic())

    def _announce_stop(self, cause: str) -> None:
        """The one log line of a stop (rig/status carries the cause until recover)."""
        self.get_logger().error(f'controlled stop: {cause}; the rig steers to the centre line, '
                                "the belt coasts and the car's speed follows it; call "
                                'rig/recover to restart')

    def _inputs(self, values: dict) -> RigInputs:
        merged = {**self._fresh_latest(), **values}
        if self.safe.state >= STOPPING:
            return self._safe_inputs()
        front, rear = merged['steering']
        torque, locked = merged['wheels']
        return RigInputs(front_steer=front, rear_steer=rear, drive_voltage=merged['drive'],
                         speed_cmd=merged['driver'], wheel_torque=torque, wheel_locked=locked)

    def _safe_inputs(self) -> RigInputs:
        """The rig's own commands during a stop or a recovery (:mod:`.safe_stop`)."""
        out = self.sim.outputs
        steer, drive, speed, self.sim.path_rate = self.safe.commands(out, self.plant_speed)
        torque = (self.safe.stop_torque(speed, out.u) if self.torque_car
                  and self.safe.state != RECOVERING else ZERO_TORQUE)
        return RigInputs(steer, 0.0, drive, speed, torque, NOT_LOCKED)

    def _done(self) -> bool:
        return self.p['max_steps'] > 0 and self.sim.k >= self.p['max_steps']

    def _step(self, values: dict):
        out = self.sim.step(self._inputs(values))
        if self.safe.state == RECOVERING:
            out = self._recovering()
        for reason in out.input_warnings:
            kind = ('wheels' if reason.startswith('wheel_torque') else 'steering'
                    if 'steer' in reason else 'drive' if 'drive' in reason else 'driver')
            self.rejected[kind] += 1
            self.warner.warn(kind, f'rejected command: {reason}', time.monotonic())
        self._publish_outputs()

    def _recovering(self):
        """Hold the car at its start pose; release it once the belt is up to speed."""
        out = self.sim.reset_to_start()
        if self.safe.ready(out.belt_speed_measured, self.tick_now, self.received_at):
            self.pub_treadmill_reset.publish(Empty())   # the regulator restarts from here
            self.get_logger().info(f'rig/recover: belt at {out.belt_speed_measured:.3f} m/s, '
                                   'car released')
        return out

    def _lockstep_step(self, values):
        if self._done():
            # The commands answering the last published step: every node has now published its
            # outputs for every step of the run.
            self._complete()
            return
        self._step(values)
        self.last_progress = time.monotonic()

    def _lockstep_watchdog(self):
        if self._done():
            return
        if time.monotonic() - self.last_progress > self.p['lockstep_resend_period']:
            self.resends[self.sim.k] = self.resends.get(self.sim.k, 0) + 1
            self.warner.warn(
                'resend', f'lock-step: no commands for t = {self._stamp_ns() * 1e-9:.3f} s from '
                f'{list(self.required)} for {self.p["lockstep_resend_period"]} s; '
                'publishing the outputs of this step again', time.monotonic())
            self._publish_outputs()
            self.last_progress = time.monotonic()

    def _realtime_tick(self):
        self.tick_now = time.monotonic()
        due = int((self.tick_now - self.wall0) / self.config.dt)
        if due - self.sim.k > 1:
            self.timing.late_ticks += 1    # the tick came late: steps are taken back to back
        for _ in range(min(due - self.sim.k, 100)):   # catch up, at most 0.1 s per tick
            if self._done():
                self._complete()
                return
            if 'steering' in self.received_at:
                self.timing.step(self.last_steer_stamp >= self._stamp_ns())
            self._step({})
        now = time.monotonic()
        if now >= self.next_timing:
            self.next_timing = now + 1.0
            self._publish_timing()

    def _publish_timing(self):
        summary = self.timing.summary()
        status = DiagnosticStatus(level=TIMING_LEVELS[timing_level(summary)],
                                  name='vehicle_sim: real-time loop',
                                  hardware_id='irs_rig',
                                  message=(f"{summary['miss_pct']:.2f} % deadline misses, latency "
                                           f"p99 {format_ms(summary['latency_p99_ms'])} ms"))
        status.values = [KeyValue(key=k, value=f'{v:.6g}' if isinstance(v, float) else str(v))
                         for k, v in summary.items()]
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self.pub_timing.publish(array)
        if len(self.arm_sent) > 2000:   # stamps never answered (e.g. no controller running)
            self.arm_sent.clear()

    def _complete(self):
        if not self.run_complete:
            self.run_complete = True
            self.get_logger().info(f'run complete: {self.sim.k} steps ({self.sim.time:.3f} s)'
                                   + resends_text(self.resends))
            if self.pub_timing is not None:
                self._publish_timing()
            self._publish_status(self.sim.outputs, from_ns(self._stamp_ns()))

    # ---------------------------------------------------------------- outputs
    def _publish_outputs(self):
        out = self.sim.outputs
        stamp = from_ns(self._stamp_ns())
        frame = self.p['frame_id']
        k = self.sim.k
        if self.pub_clock is not None:
            self.pub_clock.publish(_CLOCK(clock=stamp))

        header = _HEADER(stamp=stamp, frame_id=frame)
        js = _JOINT_STATE(header=header, name=ARM_JOINTS,
                          position=[float(a) for a in out.arm_angles])
        if self.started and not self.lockstep:
            self.arm_sent[self._stamp_ns()] = time.monotonic()
        self.pub_arm.publish(js)

        if k % self.p['belt_speed_decimation'] == 0:
            self.pub_belt.publish(_BELT_SPEED(
                header=header, speed=float(out.belt_speed_measured),
                encoder_count=int(self.sim.belt.encoder.count)))

        every = self.p['actuator_state_decimation']
        if every and k % every == 0:
            self._publish_actuator(stamp, out)
        every = self.p['ground_truth_decimation']
        if every and k % every == 0:
            self._publish_ground_truth(stamp, header, out)
            if self.pub_tyre is not None:
                self.pub_tyre.publish(tyre_state_msg(stamp, frame, out.tyre))
        if self.pub_encoders is not None:
            self.pub_encoders.publish(wheel_encoders_msg(
                stamp, out, self.config.encoders['counts_per_rev'],
                self.config.encoders['window']))

        if self.pub_wheels is not None:
            self.pub_wheels.publish(_JOINT_STATE(
                header=_HEADER(stamp=stamp), name=WHEELS,
                velocity=[float(w) for w in out.wheel_speeds]))

        fault = (out.fault, out.fault_reason, self.safe.state, self.safe.late)
        if fault != self.last_fault or (k % self.status_every == 0 and k != self.status_k):
            if out.fault and (self.last_fault is None or out.fault_reason != self.last_fault[1]):
                self.get_logger().error(f'rig fault: {out.fault_reason}')
            self.last_fault = fault
            self._publish_status(out, stamp)

    def _publish_actuator(self, stamp, out):
        af, ar = out.actuator_front, out.actuator_rear
        self.pub_act.publish(_ACTUATOR_STATE(
            header=_HEADER(stamp=stamp),
            front_commanded=float(af.commanded), front_achieved=float(af.achieved),
            rear_commanded=float(ar.commanded), rear_achieved=float(ar.achieved),
            front_saturated=bool(af.saturated), rear_saturated=bool(ar.saturated)))

    def _publish_ground_truth(self, stamp, header, out):
        qx, qy, qz, qw = quaternion_from_yaw(out.psi)
        pose = _POSE(position=_POINT(x=float(out.x), y=float(out.y)),
                     orientation=_QUATERNION(x=qx, y=qy, z=qz, w=qw))
        twist = _TWIST(linear=_VECTOR3(x=float(out.u), y=float(out.v)),
                       angular=_VECTOR3(z=float(out.yaw_rate)))
        self.pub_odom.publish(_ODOMETRY(
            header=header, child_frame_id=self.p['child_frame_id'],
            pose=_POSE_COV(pose=pose), twist=_TWIST_COV(twist=twist)))
        self.pub_point.publish(_POINT_STAMPED(header=header, point=_POINT(
            x=float(out.x + self.config.ds * math.cos(out.psi)), y=float(out.y_s))))

    def _publish_status(self, out, stamp):
        self.status_k = self.sim.k
        self.pub_status.publish(_RIG_STATUS(
            header=_HEADER(stamp=stamp),
            car_on_belt=not out.fault_reason.startswith('off_belt'),
            fault_text=out.fault_reason,
            rejected_steer_count=self.rejected['steering'],
            rejected_drive_count=self.rejected['drive'],
            step=self.sim.k, run_complete=self.run_complete, safe_state=self.safe.state,
            stop_cause=self.safe.cause,
            late_inputs=self.safe.late if self.safe.state == HOLDING else ''))


def wheel_encoders_msg(stamp, out, counts_per_rev: int, window: int) -> WheelEncoders:
    """irs_msgs/WheelEncoders of the rig outputs ``out`` (torque car)."""
    return _WHEEL_ENCODERS(header=_HEADER(stamp=stamp),
                           counts=[int(c) for c in out.encoder_counts],
                           velocity=[float(v) for v in out.encoder_velocity],
                           counts_per_rev=int(counts_per_rev), window=int(window))


def tyre_state_msg(stamp, frame: str, truth) -> TyreState:
    """irs_msgs/TyreState of the rig's tyre ground truth ``truth`` (a ``TyreTruth``)."""
    arrays = {key: [float(v) for v in getattr(truth, key)]
              for key in ('slip', 'slip_angle', 'fx', 'fy', 'fz', 'mu', 'omega')}
    return _TYRE_STATE(header=_HEADER(stamp=stamp, frame_id=frame), x_belt=float(truth.x_belt),
                       u=float(truth.u), **arrays)


def resends_text(resends: dict, most: int = 10) -> str:
    """The part of the ``run complete`` line that names the lock-step steps whose outputs were
    published again, ``{step: times}`` ('' for none), at most ``most`` steps named:
    ``; outputs re-sent while no commands came (step: times) 0: 3, 540: 4``.
    """
    if not resends:
        return ''
    steps = sorted(resends)
    more = f' and {len(steps) - most} more steps' if len(steps) > most else ''
    return ('; outputs re-sent while no commands came (step: times) '
            + ', '.join(f'{k}: {resends[k]}' for k in steps[:most]) + more)


def main(args=None):
    return run_node(VehicleSimNode, args)
