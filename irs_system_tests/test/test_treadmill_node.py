"""treadmill_regulator on its topics: drive commands, fault latching on stale, off-belt input."""
import math

from geometry_msgs.msg import PoseStamped, TwistStamped

from irs_common import qos
from irs_msgs.msg import BeltSpeed, TreadmillDriveCommand, TreadmillState
from irs_bringup.processes import NodeSpec
from irs_system_tests.service_calls import call_trigger
from irs_treadmill.safety import FaultCode


class Feeder:
    """Publishes pose + velocity + belt speed with the same stamp, as the rig and estimator do."""

    def __init__(self, ros):
        node = ros.node
        self.ros = ros
        self.pose = node.create_publisher(PoseStamped, 'pose', qos.SENSOR)
        self.vel = node.create_publisher(TwistStamped, 'velocity', qos.SENSOR)
        self.belt = node.create_publisher(BeltSpeed, 'belt/speed', qos.SENSOR)
        self.drive, self.state = [], []
        self.subs = [
            node.create_subscription(
                TreadmillDriveCommand, 'treadmill/drive', self.drive.append, qos.COMMAND
            ),
            node.create_subscription(
                TreadmillState, 'treadmill/state', self.state.append, qos.SENSOR
            ),
        ]

    def publish(self, x, y=0.0, belt=1.0, vx=0.0):
        stamp = self.ros.node.get_clock().now().to_msg()
        p = PoseStamped()
        p.header.stamp = stamp
        p.pose.position.x, p.pose.position.y, p.pose.orientation.w = x, y, 1.0
        v = TwistStamped()
        v.header.stamp = stamp
        v.twist.linear.x = vx
        b = BeltSpeed()
        b.header.stamp = stamp
        b.speed = belt
        for pub, msg in ((self.belt, b), (self.vel, v), (self.pose, p)):
            pub.publish(msg)


def feed_until(ros, feeder, predicate, x, y=0.0, timeout=15.0, vx=0.0):
    def step():
        feeder.publish(x, y, vx=vx)
        ros.executor.spin_once(timeout_sec=0.005)
        return predicate()
    return ros.spin_until(step, timeout)


def test_regulates_then_latches_stale_and_off_belt_faults(ros, launch):
    launch(NodeSpec('irs_treadmill', 'treadmill_regulator', params={'safety.stale_timeout': 1.0,
                                                                  'state_decimation': 1}))
    f = Feeder(ros)
    assert ros.wait_for_matched([f.pose, f.vel, f.belt, *f.subs], timeout=30.0)

    # Car behind the set point (x_ref = 0.3 m) on a belt at 1 m/s: the belt must slow (drive
    # below the 1.89 V that holds 1 m/s); car ahead: the belt must speed up.
    assert feed_until(ros, f, lambda: len(f.state) > 50, x=0.0)
    assert f.state[-1].mode in (TreadmillState.MODE_DRIVE, TreadmillState.MODE_COAST)
    assert f.drive[-1].voltage < 1.0 / (2.38 / 4.5)
    n = len(f.state)
    assert feed_until(ros, f, lambda: len(f.state) > n + 300, x=0.6)
    assert f.drive[-1].voltage > 1.0 / (2.38 / 4.5)
    assert all(d.voltage >= 0.0 for d in f.drive)

    # Stale input: stop publishing; the drive is cut while no pose comes ...
    assert ros.spin_until(lambda: f.state[-1].mode == TreadmillState.MODE_FAULT, 10.0)
    assert f.state[-1].fault_code == FaultCode.STALE_POSITION and f.drive[-1].voltage == 0.0
    assert 'stale' in f.state[-1].fault_text
    # ... and resumes with fresh input: a missing input is not a dangerous car (not latched).
    assert feed_until(ros, f, lambda: f.state[-1].mode != TreadmillState.MODE_FAULT, x=0.3)
    assert f.state[-1].fault_code == FaultCode.NONE

    # Off-belt excursion: the car near the front end latches a fault and cuts the drive; fresh
    # input at the set point does not clear it ...
    assert feed_until(ros, f, lambda: f.state[-1].mode == TreadmillState.MODE_FAULT, x=1.15)
    assert f.state[-1].fault_code == FaultCode.NEAR_FRONT_END and 'front' in f.state[-1].fault_text
    n = len(f.drive)
    assert feed_until(ros, f, lambda: len(f.drive) > n + 20, x=0.3)
    assert (
        all(d.voltage == 0.0 for d in f.drive[n:])
        and f.state[-1].mode == TreadmillState.MODE_FAULT
    )
    # ... the reset service does.
    assert call_trigger(ros, 'treadmill/reset_fault').success
    assert feed_until(ros, f, lambda: f.state[-1].mode != TreadmillState.MODE_FAULT, x=0.3)
    # NaN position: INVALID fault, drive cut, then recovered with the next valid position.
    assert feed_until(ros, f, lambda: f.state[-1].mode == TreadmillState.MODE_FAULT and
                      f.state[-1].fault_code == FaultCode.INVALID_INPUT, x=math.nan)
    assert f.drive[-1].voltage == 0.0
    assert feed_until(ros, f, lambda: f.state[-1].mode != TreadmillState.MODE_FAULT, x=0.3)


def test_a_pose_published_without_its_velocity_is_reported_not_answered(ros, launch):
    """Pose and velocity are paired by stamp: a pose alone (``ros2 topic pub`` of one input,
    NaN or not) gets no drive command; after 1 s the regulator says what was missing.
    """
    proc = launch(NodeSpec('irs_treadmill', 'treadmill_regulator', name='regulator_lone'))
    f = Feeder(ros)
    assert ros.wait_for_matched([f.pose, f.vel, *f.subs[:1]], timeout=30.0), proc.tail()
    stamp = ros.node.get_clock().now().to_msg()
    p = PoseStamped()
    p.header.stamp = stamp
    p.pose.position.x, p.pose.orientation.w = math.nan, 1.0
    f.pose.publish(p)
    assert ros.spin_until(lambda: 'dropped unanswered' in proc.output(), 10.0), proc.tail()
    line = next(ln for ln in proc.output().splitlines() if 'dropped unanswered' in ln)
    assert 'pose stamped' in line and 'had no velocity of the same stamp' in line, line
    assert not any(d.header.stamp == stamp for d in f.drive)


def test_a_velocity_not_yet_finite_at_start_is_the_estimators_warm_up_not_bad_input(ros, launch):
    """The pose estimator publishes NaN velocities until its differentiators have filled: at
    start that is no velocity yet, not a fault to report. Once a finite velocity has come, a
    NaN one is bad input again, reported once while it lasts.
    """
    proc = launch(NodeSpec('irs_treadmill', 'treadmill_regulator', name='regulator_warmup',
                           params={'state_decimation': 1}))
    f = Feeder(ros)
    assert ros.wait_for_matched([f.pose, f.vel, f.belt, *f.subs], timeout=30.0), proc.tail()

    def feed(n, vx):
        """``n`` steps answered (drive commands received) with velocity ``vx``."""
        k = len(f.drive)
        assert feed_until(ros, f, lambda: len(f.drive) >= k + n, x=0.3, vx=vx), proc.tail()

    feed(20, math.nan)                  # the estimator warming up
    feed(20, 0.0)                       # its first finite velocities
    assert 'xdot' not in proc.output(), proc.tail()
    feed(20, math.nan)                  # a velocity lost after it had been valid
    assert ros.spin_until(lambda: 'xdot is not finite' in proc.output(), 5.0), proc.tail()
    assert all(math.isfinite(d.voltage) for d in f.drive)
