"""``chassis_controller`` node: ABS and integrated chassis control of the torque car.

A thin wrapper of :class:`~irs_control.torque_car_control.TorqueCarController` (equations
there): measurements in (``wheels/encoders`` at 1 kHz, ``pose``, ``velocity``, ``belt/speed``),
one answer per encoder sample, stamped with it, out (``wheels/torque_command`` [N m],
``steering/command`` [rad], ``chassis/status``). With ``input_sync`` (lock-step) a sample waits
for the measurements of its stamp, so a run does not depend on DDS delivery order. Bad, stale or
mis-stamped input gives zero torques and steer; published values are always finite. Topics,
pairing and the bad-input rule: :class:`ChassisControllerNode`.
"""
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.node import Node
from std_msgs.msg import Header

from irs_common import qos
from irs_common.answer_cache import AnswerCache
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.orientation import yaw_from_quaternion
from irs_common.node_edge import EdgeGate, StaleTimer
from irs_common.params import declare_table
from irs_common.stamp_sync import StampSync
from irs_common.stamps import to_ns
from irs_msgs.msg import BeltSpeed, SteeringCommand, WheelEncoders, WheelTorqueCommand

from .chassis_params import LIVE, PARAMS, chassis_config
from .torque_car_control import TorqueCarController

WHEELS = ('FL', 'FR', 'RL', 'RR')
STALE = 'stale_encoders'
# Builders of the messages published every step (irs_common.msg_builder).
_HEADER, _TORQUE, _STEERING = (builder(Header), builder(WheelTorqueCommand),
                               builder(SteeringCommand))


class ChassisControllerNode(Node):
    """Encoders, pose, velocity and belt speed in; wheel torques and steer out.

    A thin wrapper of :class:`~irs_control.torque_car_control.TorqueCarController` (speed estimate
    from the arm, the driver's brake and steer schedule, :class:`ChassisController`,
    :class:`AbsController`; equations there). Subscribes the measurements only: ``wheels/encoders``
    (irs_msgs/WheelEncoders, 1 kHz), ``pose`` (PoseStamped, treadmill frame), ``velocity``
    (TwistStamped, ``angular.z`` = yaw rate [rad/s]) and ``belt/speed`` (irs_msgs/BeltSpeed).
    Publishes, one answer per encoder sample and stamped with it: ``wheels/torque_command``
    (irs_msgs/WheelTorqueCommand: torques [N m] FL, FR, RL, RR, + drives; ``locked`` flags) and
    ``steering/command`` (front = the driver's step steer, rear = the chassis controller's);
    ``chassis/status`` (diagnostic_msgs/DiagnosticArray: mode, braking, v_hat (arm), v_ref
    (wheels), slips, slip targets, friction estimates, r_ref, reason) every ``status_decimation``
    steps and when the reason or braking changes.

    Pairing: with ``input_sync`` (lock-step) an encoder sample t_k is answered once the pose,
    velocity and belt speed stamped t_k have arrived (:class:`~irs_common.stamp_sync.StampSync`),
    so a run does not depend on DDS delivery order; otherwise (real time) each encoder sample is
    answered with the newest pose, velocity and belt speed. Time is the time since the first
    answered sample (sim time in lock-step).

    Bad input: non-finite encoder speeds, a NaN pose (a rejected arm reading), a non-finite belt
    speed or yaw rate (with yaw control), a newest pose more than ``pose_timeout`` older than the
    encoder sample (the estimator stopped or fell behind) -> zero torques, no wheel locked, zero
    steer, the reason on ``chassis/status`` and a throttled warning; the next valid sample runs
    again. No encoder sample for ``stale_timeout`` -> the same zero command, stamped now
    (STALE). A set of inputs paired by stamp (``input_sync``) that never completes is dropped
    after 1 s with a line naming what was missing. Stamps follow
    :mod:`irs_common.stamp_gate` (future -> dropped; older -> dropped; a repeat -> the same answer
    again; more than 1 s back or ``/clock`` jumping back -> everything restarts). Published values
    are always finite.
    """

    def __init__(self, **node_options):
        super().__init__('chassis_controller', **node_options)
        self.p = declare_table(self, PARAMS, on_change=self._on_parameter)
        self.core = TorqueCarController(chassis_config(self.p))
        self.sync = StampSync(('enc', 'pose', 'vel', 'belt')) if self.p['input_sync'] else None
        self.latest = {'pose': None, 'vel': None, 'belt': None}   # real time: the newest
        self.waiting_said = False     # real time: the wait for the first pose was logged (once)
        self.answer = AnswerCache()   # what was published for the last stamp (re-sent on a repeat)
        self.last_enc_time = None
        self.reason = None            # of the last published step
        self.braking = None
        self.steps = 0
        # rclpy's throttled logging costs ~1 ms per call: per-step warnings are throttled first
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.edge = EdgeGate(self, self.p['future_tolerance'], 'encoders', self._reset_time_state,
                             self.warner)
        # COMMAND: every command answers one step (lock-step waits for it): reliable, none lost
        self.pub_torque = self.create_publisher(WheelTorqueCommand, 'wheels/torque_command',
                                                qos.COMMAND_PUB)
        self.pub_steer = self.create_publisher(SteeringCommand, 'steering/command',
                                               qos.COMMAND_PUB)
        # SENSOR, not the latched STATUS role: a 100 Hz telemetry stream the recorder must keep
        # whole (slips, v_hat for the plots), as lateral/status
        self.pub_status = self.create_publisher(DiagnosticArray, 'chassis/status', qos.SENSOR_PUB)
        # SENSOR: the 1 kHz measurement streams, reliable (lock-step must not lose a sample)
        self.create_subscription(WheelEncoders, 'wheels/encoders',
                                 lambda m: self._on_input('enc', m), qos.SENSOR)
        self.create_subscription(PoseStamped, 'pose', lambda m: self._on_input('pose', m),
                                 qos.SENSOR)
        self.create_subscription(TwistStamped, 'velocity', lambda m: self._on_input('vel', m),
                                 qos.SENSOR)
        self.create_subscription(BeltSpeed, 'belt/speed', lambda m: self._on_input('belt', m),
                                 qos.SENSOR)
        self.stale = StaleTimer(self, self.p['stale_timeout'], self._check_stale)

    # ------------------------------------------------------------------ parameters, time
    def _on_parameter(self, name, value):
        if name == 'stale_timeout':
            self.stale.set_timeout(value)
        elif name in LIVE:
            setattr(self.core.config, LIVE[name], value)
        self.get_logger().info(f'parameter {name} = {value!r} applied')

    def _reset_time_state(self):
        """Time went back: forget time origin, speed estimate and integrals (the edge gate has
        forgotten the stamps).
        """
        self.core.reset()
        self.answer.clear()
        self.last_enc_time = None
        self.latest = {'pose': None, 'vel': None, 'belt': None}

    # ------------------------------------------------------------------ inputs
    def _on_input(self, name, msg):
        stamp_ns = to_ns(msg.header.stamp)
        now_ns = self.get_clock().now().nanoseconds
        if not self.edge.admit(name, stamp_ns, now_ns, self.sync is not None):
            return
        if self.sync is not None:
            for step_ns, vals in self.sync.add(name, stamp_ns, msg):
                self._step(step_ns, vals, now_ns)
        elif name == 'enc':
            if None not in self.latest.values():
                self._step(stamp_ns, {'enc': msg, **self.latest}, now_ns)
            elif not self.waiting_said:     # at start-up, once: pose comes at 100 Hz
                self.waiting_said = True
                self.get_logger().info('waiting for pose, velocity and belt speed before the '
                                       'first answer')
        else:
            self.latest[name] = msg
            if name != 'vel' and None not in (self.latest['pose'], self.latest['belt']):
                self._pose(self.latest['pose'], self.latest['belt'])

    def _pose(self, pose, belt):
        q = pose.pose.orientation
        self.core.update_pose(to_ns(pose.header.stamp), pose.pose.position.x,
                              yaw_from_quaternion(q.x, q.y, q.z, q.w), belt.speed)

    def _log_info(self, text):
        self.get_logger().info(text)

    def _step(self, stamp_ns, vals, now_ns):
        if not self.edge.take_step(stamp_ns, now_ns, self.answer):
            return
        if self.sync is not None:
            self._pose(vals['pose'], vals['belt'])
        enc = vals['enc']
        out = self.core.step(stamp_ns, enc.velocity, vals['vel'].twist.angular.z)
        if out.ok:
            self.last_enc_time = self.get_clock().now()
            if self.warner.in_episode('stale'):   # logged once fresh for 1 s (flapping: one)
                self.warner.end_settled('stale', self._log_info, 'wheel encoders fresh again',
                                        time.monotonic())
        else:
            self.warner.warn(out.reason, self._bad_input_text(out.reason, stamp_ns),
                             time.monotonic())
        self._publish(enc.header.stamp, out.torques, out.locked, out.front_steer, out.rear_steer,
                      out)

    def _bad_input_text(self, reason, stamp_ns):
        """The warning for a step answered with zero commands; a stale pose names its age."""
        text = f'bad input ({reason}): zero torque, zero steer'
        if reason == 'stale_pose':
            age = (stamp_ns - self.core.last_pose_ns) * 1e-9
            text += (f' (the newest pose is {age:.3f} s older than the encoder sample; '
                     f'pose_timeout {self.core.config.pose_timeout:g} s)')
        return text

    # ------------------------------------------------------------------ outputs
    def _publish(self, stamp, torques, locked, front, rear, out, reason=None):
        reason = reason or out.reason
        header = _HEADER(stamp=stamp)
        self.answer.start()
        self.answer.publish(self.pub_torque, _TORQUE(
            header=header, torque=[float(v) for v in torques],
            torque_limit=float(self.p['torque_limit']), locked=[bool(v) for v in locked]))
        self.answer.publish(self.pub_steer, _STEERING(header=header, front_angle=float(front),
                                                      rear_angle=float(rear)))
        every = self.p['status_decimation']
        self.steps += 1
        braking = out is not None and out.braking
        if reason != self.reason or braking != self.braking or (
                every and self.steps % every == 1 % every):
            self.reason, self.braking = reason, braking
            self.answer.publish(self.pub_status, self._status(stamp, out, reason))

    def _status(self, stamp, out, reason):
        st = DiagnosticStatus(name='chassis_controller', hardware_id='torque_car')
        ok = reason in ('ok', 'low_speed')
        st.level = DiagnosticStatus.OK if ok else DiagnosticStatus.WARN
        st.message = reason
        c = self.core.config
        values = {'brake_mode': c.brake_mode, 'yaw_control': c.yaw_control,
                  'braking': str(bool(out is not None and out.braking)).lower()}
        if out is not None:
            values.update({'t': out.t, 'v_hat': out.v_hat, 'v_ref': out.v_ref, 'r_ref': out.r_ref,
                           'front_steer': out.front_steer, 'rear_steer': out.rear_steer})
            values.update({f'slip_{w}': float(s) for w, s in zip(WHEELS, out.slips)})
            values.update({f'slip_target_{w}': float(s) for w, s in zip(WHEELS, out.slip_target)})
            values.update({f'mu_{w}': float(s) for w, s in zip(WHEELS, out.mu)})
            values.update({f'torque_{w}': float(v) for w, v in zip(WHEELS, out.torques)})
        st.values = [KeyValue(key=k, value=f'{v:.9g}' if isinstance(v, float) else v)
                     for k, v in values.items()]
        array = DiagnosticArray(status=[st])
        array.header.stamp = stamp
        return array

    def _check_stale(self):
        now = self.get_clock().now()
        if self.sync is not None:
            self.edge.expire_unpaired(self.sync)
        if self.last_enc_time is None or self.reason == STALE:
            return
        age = (now - self.last_enc_time).nanoseconds * 1e-9
        if age > self.p['stale_timeout']:
            self.core.reset_controllers()
            self.warner.once('stale', f'wheel encoders stale ({age:.3f} s old): zero torque, '
                             'zero steer', time.monotonic())
            self._publish(self.edge.own_command_stamp(now.to_msg()), (0.0,) * 4, (False,) * 4,
                          0.0, 0.0, None, reason=STALE)


def main(args=None):
    return run_node(ChassisControllerNode, args)
