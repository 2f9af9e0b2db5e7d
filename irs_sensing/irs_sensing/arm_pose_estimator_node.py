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

A reading that is NaN, out of the joint ranges, out of the arm's reach, off the belt or an
implausible jump is rejected: no pose is computed from it. The three topics then carry NaN for
that stamp (an explicit "no valid measurement" marker, so that downstream nodes take their safe
action for that step and a lock-step run does not stall), and ``sensing/status`` (SensingStatus,
latched) says why. No reading for ``stale_timeout`` s is reported as STALE.
"""
import math
import time

from geometry_msgs.msg import PointStamped, PoseStamped, TwistStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from irs_common import qos
from irs_common.node_main import run_node
from irs_common.input_checks import ThrottledWarner
from irs_common.params import declare_table, unflatten
from irs_common.stamps import to_ns, to_sec
from irs_msgs.msg import SensingStatus

from .calibration import ArmCalibration, CalibrationError
from .estimator_params import estimator_parameter_table
from .pose_estimator import PoseEstimator, PoseEstimatorParams

NAN = math.nan


class ArmPoseEstimatorNode(Node):
    def __init__(self, **node_options):
        super().__init__('arm_pose_estimator', **node_options)
        values = declare_table(self, estimator_parameter_table())
        nested = unflatten(values)
        self.input = nested.pop('input')
        if self.input not in ('angles', 'raw'):
            raise ValueError(f"input must be 'angles' or 'raw', got {self.input!r}")
        self.frame_id = nested.pop('frame_id')
        self.child_frame_id = nested.pop('child_frame_id')
        self.pose_every = nested.pop('pose_decimation')
        self.readings = 0
        self.calibration = ArmCalibration.from_dict(nested.pop('calibration'))
        self.estimator = PoseEstimator(PoseEstimatorParams.from_ros_params(nested))
        self.accepted = 0
        self.rejected = 0
        self.last_stamp_ns = -1
        self.last_answer = []   # the messages published for last_stamp_ns (re-sent on a repeat)
        self.last_state = None
        self.last_reason = ''
        # rclpy's throttled logging costs ~1 ms per call: per-step warnings are throttled first.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.pub_pose = self.create_publisher(PoseStamped, 'pose', qos.SENSOR)
        self.pub_twist = self.create_publisher(TwistStamped, 'velocity', qos.SENSOR)
        self.pub_point = self.create_publisher(PointStamped, 'lateral_position', qos.SENSOR)
        self.pub_status = self.create_publisher(SensingStatus, 'sensing/status', qos.STATUS)
        self.create_subscription(JointState, 'arm/joint_states', self._on_joints, qos.SENSOR)
        self.create_timer(max(self.estimator.params.stale_timeout / 2.0, 0.001), self._check_stale)

    def _angles(self, msg):
        if len(msg.position) != 3:
            raise CalibrationError(f'expected 3 joint positions, got {len(msg.position)}')
        if self.input == 'raw':
            return self.calibration.to_angles(tuple(msg.position))
        return tuple(msg.position)

    def _on_joints(self, msg):
        stamp_ns = to_ns(msg.header.stamp)
        if stamp_ns <= self.last_stamp_ns:
            if stamp_ns == self.last_stamp_ns:   # the rig repeated a step: repeat our answer
                for pub, out in self.last_answer:
                    pub.publish(out)
            return
        self.last_stamp_ns = stamp_ns
        self.last_answer = []
        stamp = to_sec(msg.header.stamp)
        try:
            angles = self._angles(msg)
            est, reason = self.estimator.update(*angles, stamp)
        except (CalibrationError, ValueError) as exc:
            est, reason = None, str(exc)
        if est is None:
            self.rejected += 1
            self.warner.warn('rejected', f'arm reading rejected: {reason}', time.monotonic())
            self._publish(msg.header.stamp, NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN)
            self._status(msg.header.stamp, SensingStatus.REJECTED, reason, 0.0)
            return
        self.accepted += 1
        vx, vy, r = (est.u, est.v, est.yaw_rate) if est.velocity_valid else (NAN, NAN, NAN)
        self._publish(msg.header.stamp, est.x_cg, est.y_cg, est.psi, est.x_s, est.y_s, vx, vy, r)
        if self.last_state != SensingStatus.OK:
            self._status(msg.header.stamp, SensingStatus.OK, '', 0.0)

    def _publish(self, stamp, x, y, psi, x_s, y_s, vx, vy, r):
        self.readings += 1
        if self.pose_every == 1 or self.readings % self.pose_every == 1:
            self._publish_pose(stamp, x, y, psi, vx, vy, r)
        point = PointStamped()
        point.header.stamp = stamp
        point.header.frame_id = self.frame_id
        point.point.x, point.point.y = float(x_s), float(y_s)
        self.pub_point.publish(point)
        self.last_answer.append((self.pub_point, point))

    def _publish_pose(self, stamp, x, y, psi, vx, vy, r):
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = self.frame_id
        pose.pose.position.x, pose.pose.position.y = float(x), float(y)
        pose.pose.orientation.z = math.sin(psi / 2.0)
        pose.pose.orientation.w = math.cos(psi / 2.0)
        self.pub_pose.publish(pose)
        self.last_answer.append((self.pub_pose, pose))
        twist = TwistStamped()
        twist.header.stamp = stamp
        twist.header.frame_id = self.child_frame_id
        twist.twist.linear.x, twist.twist.linear.y = float(vx), float(vy)
        twist.twist.angular.z = float(r)
        self.pub_twist.publish(twist)
        self.last_answer.append((self.pub_twist, twist))

    def _status(self, stamp, state, reason, age):
        self.last_state, self.last_reason = state, reason
        st = SensingStatus()
        st.header.stamp = stamp
        st.state = state
        st.reason = reason
        st.accepted_count = self.accepted
        st.rejected_count = self.rejected
        st.input_age = float(age)
        self.pub_status.publish(st)

    def _check_stale(self):
        now = self.get_clock().now()
        t = now.nanoseconds * 1e-9
        if self.estimator.last_valid_stamp is None or self.last_state == SensingStatus.STALE:
            return
        if self.estimator.stale(t):
            age = t - self.estimator.last_valid_stamp
            reason = self.estimator.stale_reason(t)
            self.get_logger().warning(f'arm input stale: {reason}')
            self._status(now.to_msg(), SensingStatus.STALE, reason, age)


def main(args=None):
    return run_node(ArmPoseEstimatorNode, args)
