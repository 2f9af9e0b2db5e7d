"""``treadmill_regulator`` node: keeps the car at its longitudinal set point with the belt speed.

A thin wrapper of :class:`~irs_treadmill.regulator.BeltSpeedRegulator` and
:class:`~irs_treadmill.safety.SafetyMonitor`: one regulator step per pose (paired with the
velocity of the same stamp), ``treadmill/drive`` [V] stamped like the pose and
``treadmill/state`` out. A car near a belt end or edge cuts the drive and latches a fault until
reset; a bad or stale pose cuts it until the next valid one. It exists so that the regulator
and the safety monitor run in the graph unchanged. Topics, the bad-input rule and the writable
parameters: :class:`TreadmillRegulatorNode`.
"""
import dataclasses
import math
import time

from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.node import Node
from std_msgs.msg import Empty, Header
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.answer_cache import AnswerCache
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.orientation import yaw_from_quaternion
from irs_common.node_edge import EdgeGate
from irs_common.params import declare_table
from irs_common.stamp_gate import FUTURE
from irs_common.stamp_sync import StampSync
from irs_common.stamps import clock_now_ns, to_ns
from irs_msgs.msg import BeltSpeed, TreadmillDriveCommand, TreadmillState

from .regulator import BeltSpeedRegulator
from .regulator_params import regulator_config, regulator_parameter_table
from .safety import TRANSIENT, SafetyMonitor

#: [s] of stamps after the first velocity during which a non-finite one is the estimator's
#: warm-up, not bad input (its 20-sample differentiators fill in 0.02 s at 1 kHz, 0.2 s at 100 Hz).
VELOCITY_WARMUP = 1.0
VELOCITY_WARMUP_NS = int(VELOCITY_WARMUP * 1e9)

# Builders of the messages published every step (irs_common.msg_builder).
_HEADER, _DRIVE, _STATE = builder(Header), builder(TreadmillDriveCommand), builder(TreadmillState)


class TreadmillRegulatorNode(Node):
    """Pose and belt speed in, treadmill drive command and state out.

    Inputs: ``pose`` (PoseStamped, car c.g. in the treadmill frame), ``velocity`` (TwistStamped,
    car velocity in the car frame relative to the treadmill), ``belt/speed`` (irs_msgs/BeltSpeed).
    Pose and velocity of the same stamp are paired (they come from the same arm reading); the belt
    speed too when ``sync_belt_speed`` is set. One regulator step per pose: ``treadmill/drive``
    (TreadmillDriveCommand, stamped like the pose) every step and ``treadmill/state``
    (TreadmillState) every ``state_decimation`` steps and whenever the mode changes.

    Safety (irs_treadmill.safety): a car near a belt end or edge cuts the drive (0 V: the belt
    coasts) and latches a fault, published in ``treadmill/state`` until reset through the
    ``treadmill/reset_fault`` service (std_srvs/Trigger) or a message on ``treadmill/reset``
    (std_msgs/Empty). A NaN pose or no pose for ``safety.stale_timeout`` s cuts the drive too,
    until the next valid pose (an input fault, not a dangerous car: it is not latched).

    Bad input at this node's edge:

    - values: a pose with ``|x|`` or ``|y|`` beyond the regulator's position limit (5 m; the belt
      is 2.44 x 1.22 m) is not a measurement: treated like a NaN pose (drive cut, transient input
      fault); a bad belt speed gives 0 V and a regulator reset; a bad velocity makes the regulator
      use its internal estimate (``BeltSpeedRegulator.update`` rule); a non-finite velocity
      before the first finite one, for up to :data:`VELOCITY_WARMUP` s of stamps after the first
      velocity, is the estimator's differentiators still filling (it publishes NaN until they
      are) and is taken as no velocity yet, silently, as without the topic. The reason is
      logged through a throttled warner (at most once a second per kind) and the fault is on
      ``treadmill/state``;
    - stamps, against the node clock: a pose/velocity/belt speed stamped more than
      ``future_tolerance`` s ahead is dropped (not answered, not stored); an older step than the
      last is dropped as out of order unless it is more than 1 s older (a replay loop, a restarted
      rig): then the regulator and the safety monitor's position timing restart (latched faults
      stay) and the step is taken; the last step again is answered with the same command;
    - the node clock jumping back (``/clock`` of ``bag play --loop --clock``) restarts the same
      time state;
    - a pose whose velocity of the same stamp never comes (a pose published alone) is not
      answered: after waiting 1-2 s (by arrival) it is dropped and reported
      (:meth:`~irs_common.node_edge.EdgeGate.expire_unpaired`).

    Writable parameters (``ros2 param set``, applied at once): ``enabled`` (false: 0 V, belt
    coasts), ``regulator.x_ref``, ``regulator.k_x``, ``regulator.k_i``, ``regulator.k_v``,
    ``regulator.integral_limit``.
    """

    def __init__(self, **node_options):
        super().__init__('treadmill_regulator', **node_options)
        self.p = declare_table(self, regulator_parameter_table(), on_change=self._on_parameter)
        config = regulator_config(self.p)
        self.regulator = BeltSpeedRegulator(config.regulator)
        self.safety = SafetyMonitor(config.safety, future_tolerance=self.p['future_tolerance'])
        self.dt = 1.0 / self.p['rate_hz']
        inputs = ['pose'] + (['velocity'] if self.p['use_velocity_input'] else []) \
            + (['belt'] if self.p['sync_belt_speed'] else [])
        self.inputs = tuple(inputs)
        self.sync = StampSync(self.inputs)
        self.belt_speed = math.nan
        self.belt_seen = False
        self.velocity_seen = False    # a finite velocity has arrived
        self.velocity_from_ns = None  # stamp [ns] of the first velocity (VELOCITY_WARMUP)
        self.pose_arrived_ns = None   # node clock [ns] when the last valid pose arrived
        self.answer = AnswerCache()   # what was published for the last stamp (re-sent on a repeat)
        self.reported_fault = None
        self.published_mode = None
        self.steps = 0
        # rclpy's throttled logging costs ~1 ms per call: per-step warnings are throttled first.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.edge = EdgeGate(self, self.p['future_tolerance'], 'pose', self._reset_time_state,
                             self.warner)
        self.fault_warner = ThrottledWarner(self._log_error, 1.0)
        self.pub_drive = self.create_publisher(
            TreadmillDriveCommand, 'treadmill/drive', qos.COMMAND_PUB
        )
        self.pub_state = self.create_publisher(TreadmillState, 'treadmill/state', qos.SENSOR_PUB)
        self.create_subscription(PoseStamped, 'pose', lambda m: self._add('pose', m), qos.SENSOR)
        if self.p['use_velocity_input']:
            self.create_subscription(TwistStamped, 'velocity', lambda m: self._add('velocity', m),
                                     qos.SENSOR)
        self.create_subscription(BeltSpeed, 'belt/speed', self._on_belt, qos.SENSOR)
        self.create_subscription(Empty, 'treadmill/reset', lambda _m: self._reset(), qos.COMMAND)
        self.create_service(Trigger, 'treadmill/reset_fault', self._on_reset_service)
        self.create_timer(max(self.safety.params.stale_timeout / 4.0, 0.001), self._check_stale)

    # ------------------------------------------------------------------ parameters, time

    # rclpy fixes a logging call site's severity at its first call (a later call with another
    # severity raises ValueError): warners that log at other severities than warning call rclpy
    # from these lines, not from ThrottledWarner's one.
    def _log_info(self, text):
        self.get_logger().info(text)

    def _log_error(self, text):
        self.get_logger().error(text)

    def _on_parameter(self, name, value):
        if name.startswith('regulator.'):
            key = name.split('.', 1)[1]
            self.regulator.params = dataclasses.replace(self.regulator.params, **{key: value})
        # 'enabled' is read from self.p (kept current by declare_table) at every step
        self.get_logger().info(f'parameter {name} = {value!r} applied')

    def _reset_time_state(self):
        """Time went back: forget the regulator state and the position timing (the edge gate
        has forgotten the stamps; latched faults stay latched). Pending pairs stay: they may
        hold parts of newer steps already taken from another input.
        """
        self.regulator.reset()
        self.safety.forget_time()
        self.pose_arrived_ns = None
        self.answer.clear()

    def _on_belt(self, msg):
        if self.p['sync_belt_speed']:
            self._add('belt', msg)
        else:
            now_ns = clock_now_ns(self.get_clock())
            stamp_ns = to_ns(msg.header.stamp)
            if now_ns and stamp_ns - now_ns > self.edge.future_tolerance_ns:
                self.edge.drop('belt speed', FUTURE, stamp_ns, now_ns)
            else:
                self.belt_speed = msg.speed      # screened by the regulator at each step
                self.belt_seen = True

    def _add(self, name, msg):
        stamp_ns = to_ns(msg.header.stamp)
        now_ns = clock_now_ns(self.get_clock())
        if not self.edge.admit(name, stamp_ns, now_ns):
            return
        for stamp_ns, vals in self.sync.add(name, stamp_ns, msg):
            self._step(stamp_ns, vals, now_ns)

    def _step(self, stamp_ns, vals, now_ns):
        if not self.edge.take_step(stamp_ns, now_ns, self.answer):
            return
        pose = vals['pose']
        x, y = pose.pose.position.x, pose.pose.position.y
        if 'belt' in vals:
            belt = belt_in = vals['belt'].speed
        else:   # latest belt speed; none received yet: regulate as from a standing belt
            belt = self.belt_speed
            belt_in = belt if self.belt_seen else 0.0
        xdot = None
        if 'velocity' in vals:
            q = pose.pose.orientation
            psi = yaw_from_quaternion(q.x, q.y, q.z, q.w)
            v = vals['velocity'].twist.linear
            xdot = v.x * math.cos(psi) - v.y * math.sin(psi)
            if math.isfinite(xdot):
                self.velocity_seen = True
            elif not self.velocity_seen:
                if self.velocity_from_ns is None:
                    self.velocity_from_ns = stamp_ns
                if 0 <= stamp_ns - self.velocity_from_ns <= VELOCITY_WARMUP_NS:
                    xdot = None     # the estimator is warming up: no velocity yet
        limit = self.regulator.position_limit
        now = now_ns * 1e-9 if now_ns else None    # clock at 0: no /clock yet (EdgeGate)
        if not (-limit <= x <= limit and -limit <= y <= limit):
            # not a measurement of a car on a 2.44 m belt (NaN included): an input fault
            self.safety.update_position(math.nan, math.nan, stamp_ns * 1e-9, now=now)
        else:
            self.safety.update_position(x, y, stamp_ns * 1e-9, now=now, xdot=xdot)
            self.pose_arrived_ns = now_ns
        out = self.regulator.update(x, belt_in, self.dt, xdot=xdot,
                                    enabled=self.safety.drive_permitted and self.p['enabled'])
        if out.reason:    # logged once while it persists
            self.warner.once('input', f'treadmill input: {out.reason}', time.monotonic())
        elif self.warner.in_episode('input'):
            self.warner.end('input', self._log_info, 'treadmill input valid again',
                            time.monotonic())
        voltage = self.safety.gate(out.voltage) if self.p['enabled'] else 0.0
        self._publish(
            pose.header.stamp, voltage, belt, x, out.voltage == 0.0 and out.speed_setpoint < belt
        )

    def _publish(self, stamp, voltage, belt, x, coasting):
        header = _HEADER(stamp=stamp)
        self.answer.start()
        self.answer.publish(self.pub_drive, _DRIVE(header=header, voltage=float(voltage)))
        if self.safety.faulted:
            mode = TreadmillState.MODE_FAULT
        elif not self.p['enabled']:
            mode = TreadmillState.MODE_OFF
        else:
            mode = TreadmillState.MODE_COAST if coasting else TreadmillState.MODE_DRIVE
        fault_text = self.safety.status_text() if self.safety.faulted else ''
        every = self.p['state_decimation']
        self.steps += 1
        if mode != self.published_mode or (every and self.steps % every == 1 % every):
            self.published_mode = mode
            x_ref = self.regulator.params.x_ref
            self.answer.publish(self.pub_state, _STATE(
                header=header, belt_speed=float(belt), drive_voltage=float(voltage),
                position_setpoint=float(x_ref), position=float(x),
                position_error=float(x - x_ref), mode=mode, fault_code=int(self.safety.fault),
                fault_text=fault_text))
        if self.safety.faulted and self.reported_fault != self.safety.fault:
            self.reported_fault = self.safety.fault
            kind = 'until the input is valid again' if self.safety.fault in TRANSIENT else \
                'latched until reset'
            # once per transition; input faults that come and go with every pose once in all
            # until the drive resumes
            self.fault_warner.once(f'fault-{int(self.safety.fault)}',
                                   f'treadmill fault, drive cut ({kind}): {fault_text}',
                                   time.monotonic())
        elif not self.safety.faulted and self.reported_fault is not None:
            self.fault_warner.end(f'fault-{int(self.reported_fault)}', self._log_info,
                                  f'treadmill input valid again: drive resumes (was: '
                                  f'{self.reported_fault.text})', time.monotonic())
            self.reported_fault = None

    def _check_stale(self):
        """No valid pose *arrived* for ``safety.stale_timeout`` (the node clock since the last
        one, not its stamp: a rig catching up after a stall of its own sends stamps that lag the
        clock, and its poses are not stale).
        """
        now = self.get_clock().now()
        self.edge.expire_unpaired(self.sync)
        if self.safety.faulted or self.pose_arrived_ns is None:
            return
        if self.safety.check_age((now.nanoseconds - self.pose_arrived_ns) * 1e-9):
            self.regulator.reset()
            self._publish(self.edge.own_command_stamp(now.to_msg()), 0.0, self.belt_speed,
                          math.nan, False)

    def _reset(self):
        self.safety.reset()
        self.regulator.reset()
        self.pose_arrived_ns = None
        self.reported_fault = None
        self.fault_warner.forget_episodes()
        self.edge.gate.clear()
        self.answer.clear()
        self.get_logger().info('treadmill fault reset')

    def _on_reset_service(self, _request, response):
        was = self.safety.status_text()
        self._reset()
        response.success = True
        response.message = f'reset (was: {was})'
        return response


def main(args=None):
    return run_node(TreadmillRegulatorNode, args)
