"""Parameters that tell the truth, on the parameter services (what ``ros2 param set`` does).

A writable parameter set through ``/<node>/set_parameters`` changes what the node does: the
treadmill regulator's ``regulator.x_ref`` moves the set point it reports and regulates to,
``enabled: false`` drives 0 V; the lateral controller's ``default_reference`` is the reference at
once. A read-only parameter is refused with a reason and keeps its value; a bad value of a
writable one is refused with a reason too.
"""
from geometry_msgs.msg import PointStamped

from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import SteeringCommand, TreadmillState
from irs_bringup.processes import NodeSpec
from irs_system_tests.service_calls import get_param, set_params

from test_treadmill_node import Feeder, feed_until


def settled(drive) -> bool:
    """The last 5 drive voltages are equal and positive (the regulator's slew is over)."""
    last = [d.voltage for d in drive[-5:]]
    return len(last) == 5 and last[0] > 0.0 and all(v == last[0] for v in last)


def test_regulator_x_ref_and_enabled_change_behaviour_read_only_refused(ros, launch):
    launch(NodeSpec('irs_treadmill', 'treadmill_regulator',
                    params={'safety.stale_timeout': 5.0, 'state_decimation': 1}))
    f = Feeder(ros)
    assert ros.wait_for_matched([f.pose, f.vel, f.belt, *f.subs], timeout=30.0)
    # the car at its set point: the drive slews up from 0 V and settles (the last 5 equal).
    # The two topics' writers match the test's readers one at a time (DDS discovery), so the
    # drive can settle before the first state arrives: wait for both.
    assert feed_until(ros, f, lambda: settled(f.drive) and f.state, x=0.3)
    assert f.state[-1].position_setpoint == 0.3
    assert f.state[-1].mode == TreadmillState.MODE_DRIVE
    drive_at_setpoint = f.drive[-1].voltage
    assert drive_at_setpoint > 0.0

    # x_ref 0.3 -> 0.5 m: the reported set point moves, and the car at 0.3 m is now *behind*
    # it, so the belt is slowed (less drive than with the car at its set point)
    [res] = set_params(ros, 'treadmill_regulator', regulator__x_ref=0.5)
    assert res.successful, res.reason
    assert feed_until(ros, f, lambda: f.state[-1].position_setpoint == 0.5, x=0.3)
    assert f.state[-1].position_error == -0.2 or abs(f.state[-1].position_error + 0.2) < 1e-12
    n = len(f.drive)
    assert feed_until(ros, f, lambda: len(f.drive) > n + 50, x=0.3)
    assert f.drive[-1].voltage < drive_at_setpoint

    # enabled false: 0 V, mode OFF; true again: regulates again
    [res] = set_params(ros, 'treadmill_regulator', enabled=False)
    assert res.successful, res.reason
    assert feed_until(ros, f, lambda: f.state[-1].mode == TreadmillState.MODE_OFF, x=0.5)
    n = len(f.drive)
    assert feed_until(ros, f, lambda: len(f.drive) > n + 20, x=0.6)
    assert all(d.voltage == 0.0 for d in f.drive[n:])
    [res] = set_params(ros, 'treadmill_regulator', enabled=True)
    assert res.successful
    assert feed_until(ros, f, lambda: f.drive[-1].voltage > 0.0, x=0.6)

    # read-only: refused with a reason, value unchanged
    [res] = set_params(ros, 'treadmill_regulator', rate_hz=500.0)
    assert not res.successful and 'read-only' in res.reason, res.reason
    # (without sim time the node runs in real time: the real-time default, 100 Hz)
    assert get_param(ros, 'treadmill_regulator', 'rate_hz').double_value == 100.0
    # writable, bad value: refused with a reason naming parameter and range
    [res] = set_params(ros, 'treadmill_regulator', regulator__x_ref=5.0)
    assert not res.successful and 'regulator.x_ref' in res.reason, res.reason
    [res] = set_params(ros, 'treadmill_regulator', regulator__k_x=0.0)
    assert not res.successful and 'k_x' in res.reason, res.reason
    assert feed_until(ros, f, lambda: f.state[-1].position_setpoint == 0.5, x=0.5)


def test_controller_default_reference_applies_at_once(ros, launch):
    launch(NodeSpec('irs_control', 'lateral_controller', params={'stale_timeout': 10.0}))
    node = ros.node
    meas = node.create_publisher(PointStamped, 'lateral_position', qos.SENSOR)
    cmds = {}
    sub = node.create_subscription(SteeringCommand, 'steering/command',
                                   lambda m: cmds.setdefault(to_ns(m.header.stamp), m),
                                   qos.COMMAND)
    assert ros.wait_for_matched([meas, sub], timeout=30.0)

    def steer(y=0.0):
        m = PointStamped()
        ns = node.get_clock().now().nanoseconds
        m.header.stamp = from_ns(ns)
        m.point.y = y
        meas.publish(m)
        assert ros.spin_until(lambda: ns in cmds, 10.0)
        return cmds[ns].front_angle

    assert steer() == 0.0             # reference 0 m, car at 0 m: no steer
    [res] = set_params(ros, 'lateral_controller', default_reference=0.2)
    assert res.successful, res.reason
    assert steer() > 0.0              # the reference is 0.2 m to the left now: steer left
    [res] = set_params(ros, 'lateral_controller', mode='pi')
    assert not res.successful and 'read-only' in res.reason
    # a name the node does not have: refused, naming it and the closest names
    [res] = set_params(ros, 'lateral_controller', default_referenc=0.1)
    assert not res.successful and res.reason == (
        'Invalid access to undeclared parameter(s): default_referenc (did you mean '
        'default_reference?)'), res.reason
