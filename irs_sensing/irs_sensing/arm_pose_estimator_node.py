"""``arm_pose_estimator`` node: the arm's potentiometer angles to the car's pose and velocities.

Subscribes ``arm/joint_states`` (sensor_msgs/JointState; ``position`` = the three joint angles
[rad], or raw volts/counts with ``input: raw``). For each reading, stamped with the reading's own
stamp, publishes

- ``pose`` (geometry_msgs/PoseStamped): the c.g. pose in the treadmill frame;
- ``velocity`` (geometry_msgs/TwistStamped): longitudinal and lateral velocity of the c.g. in the
  car frame and yaw rate, relative to the treadmill frame (add the belt speed for the speed over
  the belt), by numerical differentiation (see docs/sensing.md for delay and noise gain);
- ``lateral_position`` (geometry_msgs/PointStamped): the sensor point ``ds`` ahead of the c.g.;
  ``point.y`` is the lateral displacement the lateral controller regulates.

A rejected reading gives NaN on the three topics for its stamp (so downstream nodes take their
safe action and lock-step does not stall) and its reason on ``sensing/status``. The node exists
so that :class:`~irs_sensing.pose_estimator.PoseEstimator` runs in the graph unchanged; bad
readings, staleness, stamps and the writable parameter: :class:`ArmPoseEstimatorNode`.
"""
import dataclasses
import math
import time

from geometry_msgs.msg import (Point, PointStamped, Pose, PoseStamped, Quaternion, Twist,
                               TwistStamped, Vector3)
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from irs_common import qos
from irs_common.answer_cache import AnswerCache
from irs_common.node_main import run_node
from irs_common.orientation import quaternion_from_yaw
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_edge import EdgeGate, StaleTimer
from irs_common.params import declare_table
from irs_common.stamps import clock_now_ns, to_ns, to_sec
from irs_msgs.msg import SensingStatus

from .calibration import CalibrationError
from .estimator_params import estimator_config, estimator_parameter_table
from .pose_estimator import PoseEstimator

# Builders of the messages published every step (irs_common.msg_builder).
_HEADER, _POINT, _POINT_STAMPED = builder(Header), builder(Point), builder(PointStamped)
_POSE, _POSE_STAMPED, _QUATERNION = builder(Pose), builder(PoseStamped), builder(Quaternion)
_TWIST, _TWIST_STAMPED, _VECTOR3 = builder(Twist), builder(TwistStamped), builder(Vector3)
_STATUS = builder(SensingStatus)

NAN = math.nan


class ArmPoseEstimatorNode(Node):
    """Arm joint angles in, car pose, velocity and lateral position out.

    A reading that is NaN, out of the joint ranges, out of the arm's reach, off the belt or an
    implausible jump is rejected: no pose is computed from it. The three topics then carry NaN for
    that stamp (an explicit "no valid measurement" marker, so that downstream nodes take their safe
    action for that step and a lock-step run does not stall), and ``sensing/status``
    (SensingStatus, latched) says why. No valid reading for ``stale_timeout`` s is reported as
    STALE (logged once per transition, and once when valid readings return); while rejected
    readings keep arriving the status stays REJECTED, and once no reading at all has arrived for
    ``stale_timeout`` s it is STALE, so the latched status ends as STALE whatever came before.
    ``sensing/status`` is published on every change of state and at most once a second while
    readings keep being rejected.

    Stamps (irs_common.stamp_gate, against the node clock): a reading stamped more than
    ``future_tolerance`` s ahead is dropped (no answer, not stored: it cannot silence the input);
    one older than the last is dropped as out of order unless it is more than 1 s older (a replay
    loop, a restarted rig): then the estimator's history restarts and the reading is taken; a
    reading with the last stamp is answered again with the same messages (lock-step resend). The
    node clock jumping back (``/clock`` of ``bag play --loop --clock``) restarts the history too.

    Writable parameter: ``stale_timeout`` (``ros2 param set``; applied at once).
    """

    def __init__(self, **node_options):
        super().__init__('arm_pose_estimator', **node_options)
        values = declare_table(self, estimator_parameter_table(), on_change=self._on_parameter)
        config = estimator_config(values)
        self.input = config.input
        self.frame_id = values['frame_id']
        self.child_frame_id = values['child_frame_id']
        self.pose_every = values['pose_decimation']
        future_tolerance = values['future_tolerance']
        self.readings = 0
        self.calibration = config.calibration
        self.estimator = PoseEstimator(config.params, future_tolerance=future_tolerance)
        self.accepted = 0
        self.rejected = 0
        self.answer = AnswerCache()   # what was published for the last stamp (re-sent on a repeat)
        self.last_state = None
        self.last_reason = ''
        self.last_status_wall = 0.0
        self.last_rejected_ns = None   # node clock at the last rejected reading
        # rclpy's throttled logging costs ~1 ms per call: per-step warnings are throttled first.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.edge = EdgeGate(self, future_tolerance, 'arm reading', self._reset_time_state,
                             self.warner)
        self.pub_pose = self.create_publisher(PoseStamped, 'pose', qos.SENSOR_PUB)
        self.pub_twist = self.create_publisher(TwistStamped, 'velocity', qos.SENSOR_PUB)
        self.pub_point = self.create_publisher(PointStamped, 'lateral_position', qos.SENSOR_PUB)
        self.pub_status = self.create_publisher(SensingStatus, 'sensing/status', qos.STATUS_PUB)
        self.create_subscription(JointState, 'arm/joint_states', self._on_joints, qos.SENSOR)
        self.stale = StaleTimer(self, self.estimator.params.stale_timeout, self._check_stale)


    # rclpy fixes a logging call site's severity at its first call (a later call with another
    # severity raises ValueError): warners that log at other severities than warning call rclpy
    # from these lines, not from ThrottledWarner's one.
    def _log_info(self, text):
        self.get_logger().info(text)

    def _on_parameter(self, name, value):
        if name == 'stale_timeout':
            self.estimator.params = dataclasses.replace(self.estimator.params, stale_timeout=value)
            self.stale.set_timeout(value)
        self.get_logger().info(f'parameter {name} = {value!r} applied')

    def _reset_time_state(self):
        """Time went back: forget the estimator's history (the edge gate has forgotten the
        stamps).
        """
        self.estimator.reset()
        self.answer.clear()
        self.last_rejected_ns = None

    def _angles(self, msg):
        if len(msg.position) != 3:
            raise CalibrationError(f'expected 3 joint positions, got {len(msg.position)}')
        if self.input == 'raw':
            return self.calibration.to_angles(tuple(msg.position))
        return tuple(msg.position)

    def _on_joints(self, msg):
        stamp_ns = to_ns(msg.header.stamp)
        now_ns = clock_now_ns(self.get_clock())
        # a repeated step is answered again by the answer cache (StampGate.take_step)
        if not self.edge.take_step(stamp_ns, now_ns, self.answer):
            return
        self.answer.start()
        stamp = to_sec(msg.header.stamp)
        try:
            angles = self._angles(msg)
            # a clock at 0 (sim time, no /clock yet) judges no stamp's future (EdgeGate)
            est, reason = self.estimator.update(*angles, stamp,
                                                now=now_ns * 1e-9 if now_ns else None)
        except (CalibrationError, ValueError) as exc:
            est, reason = None, str(exc)
        if est is None:
            self.rejected += 1
            self.last_rejected_ns = now_ns
            # a persisting rejection (a car off the belt) is logged once, not every second
            self.warner.once('rejected', f'arm reading rejected: {reason}', time.monotonic())
            self._publish(msg.header.stamp, NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN)
            wall = time.monotonic()
            if self.last_state != SensingStatus.REJECTED or wall - self.last_status_wall >= 1.0:
                self.last_status_wall = wall
                self._status(msg.header.stamp, SensingStatus.REJECTED, reason, 0.0)
            return
        self.accepted += 1
        if self.warner.in_episode('rejected'):
            self.warner.end('rejected', self._log_info, 'arm readings accepted again',
                            time.monotonic())
        vx, vy, r = (est.u, est.v, est.yaw_rate) if est.velocity_valid else (NAN, NAN, NAN)
        self._publish(msg.header.stamp, est.x_cg, est.y_cg, est.psi, est.x_s, est.y_s, vx, vy, r)
        if self.last_state != SensingStatus.OK:
            self._status(msg.header.stamp, SensingStatus.OK, '', 0.0)
        if self.warner.in_episode('stale'):
            # logged once the input has stayed valid for 1 s: a flapping input is one episode
            self.warner.end_settled('stale', self._log_info, 'arm input valid again',
                                    time.monotonic())

    def _publish(self, stamp, x, y, psi, x_s, y_s, vx, vy, r):
        # lateral_position first: it closes the 1 kHz lateral loop; pose and velocity feed the
        # treadmill loop (100 Hz in real time), which must not sit between the two
        self.readings += 1
        header = _HEADER(stamp=stamp, frame_id=self.frame_id)
        self.answer.publish(self.pub_point, _POINT_STAMPED(
            header=header, point=_POINT(x=float(x_s), y=float(y_s))))
        if self.pose_every == 1 or self.readings % self.pose_every == 1:
            self._publish_pose(header, x, y, psi, vx, vy, r)

    def _publish_pose(self, header, x, y, psi, vx, vy, r):
        qx, qy, qz, qw = quaternion_from_yaw(psi)
        self.answer.publish(self.pub_pose, _POSE_STAMPED(header=header, pose=_POSE(
            position=_POINT(x=float(x), y=float(y)),
            orientation=_QUATERNION(x=qx, y=qy, z=qz, w=qw))))
        self.answer.publish(self.pub_twist, _TWIST_STAMPED(
            header=_HEADER(stamp=header.stamp, frame_id=self.child_frame_id),
            twist=_TWIST(linear=_VECTOR3(x=float(vx), y=float(vy)),
                         angular=_VECTOR3(z=float(r)))))

    def _status(self, stamp, state, reason, age):
        self.last_state, self.last_reason = state, reason
        self.pub_status.publish(_STATUS(
            header=_HEADER(stamp=stamp), state=state, reason=reason,
            accepted_count=self.accepted, rejected_count=self.rejected, input_age=float(age)))

    def _check_stale(self):
        """STALE once per transition: no valid reading for ``stale_timeout`` s, and no rejected
        one either if the status says REJECTED (rejected readings that keep arriving are the
        better answer; a STALE published before them is not current any more).
        """
        if self.last_state == SensingStatus.STALE or self.estimator.last_valid_stamp is None:
            return
        now = self.get_clock().now()
        t = now.nanoseconds * 1e-9
        timeout = self.estimator.params.stale_timeout
        if (self.last_state == SensingStatus.REJECTED and self.last_rejected_ns is not None
                and (now.nanoseconds - self.last_rejected_ns) * 1e-9 <= timeout):
            return
        if self.estimator.stale(t):
            age = t - self.estimator.last_valid_stamp
            reason = self.estimator.stale_reason(t)
            self.warner.once('stale', f'arm input stale: {reason}', time.monotonic())
            self._status(now.to_msg(), SensingStatus.STALE, reason, age)


def main(args=None):
    return run_node(ArmPoseEstimatorNode, args)
