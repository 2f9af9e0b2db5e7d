"""arm_pose_estimator on its topics: angles in, pose/velocity/lateral displacement out."""
import math

from geometry_msgs.msg import PointStamped, PoseStamped, TwistStamped
import numpy as np
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import SensingStatus
from irs_bringup.processes import NodeSpec
from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

DS = 0.33
X0, Y0, PSI = 0.1, -0.05, 0.1          # [m], [m], [rad]
XDOT, YDOT = 0.3, 0.1                  # [m/s] straight-line motion in the treadmill frame


#: The latched ``sensing/status`` with a history deep enough to keep every transition a test
#: causes (``qos.STATUS`` keeps only the last, which a busy test process may take too late).
STATUS_ALL = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)


def truth(t):
    return X0 + XDOT * t, Y0 + YDOT * t, PSI


def joint_state(stamp_ns, angles):
    msg = JointState()
    msg.header.stamp = from_ns(stamp_ns)
    msg.name = ['arm_joint1', 'arm_joint2', 'arm_joint3']
    msg.position = [float(a) for a in angles]
    return msg


def test_angles_give_expected_pose_velocity_and_lateral_displacement(ros, launch):
    # pose and velocity for every reading (without sim time the default is every 10th)
    launch(NodeSpec('irs_sensing', 'arm_pose_estimator', params={'ds': DS, 'pose_decimation': 1}))
    node = ros.node
    got = {'pose': {}, 'velocity': {}, 'lateral': {}, 'status': []}
    pub = node.create_publisher(JointState, 'arm/joint_states', qos.SENSOR)
    subs = [
        node.create_subscription(PoseStamped, 'pose',
                                 lambda m: got['pose'].__setitem__(to_ns(m.header.stamp), m),
                                 qos.SENSOR),
        node.create_subscription(TwistStamped, 'velocity',
                                 lambda m: got['velocity'].__setitem__(to_ns(m.header.stamp), m),
                                 qos.SENSOR),
        node.create_subscription(PointStamped, 'lateral_position',
                                 lambda m: got['lateral'].__setitem__(to_ns(m.header.stamp), m),
                                 qos.SENSOR),
        node.create_subscription(
            SensingStatus, 'sensing/status', lambda m: got['status'].append(m), STATUS_ALL
        ),
    ]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)
    geo = ArmGeometry()
    n = 60
    for k in range(n):
        x, y, psi = truth(k * 0.001)
        pub.publish(joint_state(k * 1_000_000, inverse_kinematics(x, y, psi, geo)))
    assert ros.spin_until(lambda: len(got['lateral']) == n and len(got['velocity']) == n, 20.0)
    for k in range(n):
        stamp = k * 1_000_000
        x, y, psi = truth(k * 0.001)
        pose = got['pose'][stamp].pose
        assert abs(pose.position.x - x) < 1e-9 and abs(pose.position.y - y) < 1e-9
        assert abs(2 * math.atan2(pose.orientation.z, pose.orientation.w) - psi) < 1e-9
        lat = got['lateral'][stamp].point
        assert abs(lat.y - (y + DS * math.sin(psi))) < 1e-9
    # Velocities: in the car frame; exact for straight-line motion once the fit window is full.
    u = XDOT * math.cos(PSI) + YDOT * math.sin(PSI)
    v = -XDOT * math.sin(PSI) + YDOT * math.cos(PSI)
    tw = got['velocity'][(n - 1) * 1_000_000].twist
    assert abs(tw.linear.x - u) < 1e-6 and abs(tw.linear.y - v) < 1e-6 and abs(tw.angular.z) < 1e-6
    first = got['velocity'][0].twist.linear.x
    assert math.isnan(first), 'velocity must be NaN (invalid) until the differentiator has settled'

    # A NaN reading is rejected: NaN markers on the outputs, REJECTED status with a reason.
    pub.publish(joint_state(n * 1_000_000, (math.nan, 0.0, 0.0)))
    assert ros.spin_until(
        lambda: any(s.state == SensingStatus.REJECTED for s in got['status']), 10.0
    )
    assert ros.spin_until(lambda: n * 1_000_000 in got['pose'], 10.0)
    assert math.isnan(got['pose'][n * 1_000_000].pose.position.x)
    rejected = [s for s in got['status'] if s.state == SensingStatus.REJECTED][-1]
    assert 'finite' in rejected.reason and rejected.rejected_count == 1

    # An out-of-reach reading (arm stretched beyond the belt) is rejected too.
    pub.publish(joint_state((n + 1) * 1_000_000, (0.0, 0.0, 0.0)))
    assert ros.spin_until(lambda: (n + 1) * 1_000_000 in got['pose'], 10.0)
    assert math.isnan(got['pose'][(n + 1) * 1_000_000].pose.position.x)

    # No more readings: the input goes stale (wall clock here) and the latched status says so.
    assert ros.spin_until(lambda: got['status'][-1].state == SensingStatus.STALE, 10.0), \
        [(s.state, s.reason) for s in got['status']]
    assert np.isfinite(got['status'][-1].input_age)


def test_stale_input_after_rejected_readings_ends_as_stale_status(ros, launch):
    # STALE, then a rejected reading (REJECTED), then silence: the latched status returns to STALE
    launch(NodeSpec('irs_sensing', 'arm_pose_estimator', params={'ds': DS}))
    node = ros.node
    states = []
    pub = node.create_publisher(JointState, 'arm/joint_states', qos.SENSOR)
    sub = node.create_subscription(SensingStatus, 'sensing/status',
                                   lambda m: states.append(m.state), STATUS_ALL)
    assert ros.wait_for_matched([pub, sub], timeout=30.0)
    x, y, psi = truth(0.0)
    pub.publish(joint_state(1_000_000, inverse_kinematics(x, y, psi, ArmGeometry())))
    # stamps near 0 against the wall clock: the valid reading is stale at the next check
    assert ros.spin_until(lambda: SensingStatus.STALE in states, 10.0), states
    pub.publish(joint_state(2_000_000, (math.nan, 0.0, 0.0)))
    assert ros.spin_until(lambda: SensingStatus.REJECTED in states, 10.0), states
    assert ros.spin_until(lambda: states[-1] == SensingStatus.STALE
                          and states.index(SensingStatus.REJECTED) < len(states) - 1, 10.0), states
