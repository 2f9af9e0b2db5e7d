"""Property-style fuzz of every input topic of the data-driven nodes, on their topics.

One long-lived node process per node type; hypothesis draws the messages (fields from floats with
NaN, +-inf, +-1e308, subnormals; stamps zero, now, a day ahead, the largest time, 0.3 s and 5 s
back, negative). After every drawn example a genuine probe message must be answered (the node is
alive and not silenced), and no command the node ever published may be non-finite or beyond its
limit (``steering/command``, ``treadmill/drive``, ``lateral/reference``). After the examples the
node must give, on good data, exactly what it gave on the same good data at the start (each
good run starts from a state that does not depend on timing: a NaN measurement or
``treadmill/reset_fault`` restarts the controller from rest, never a stale timeout). Every test
counts the examples that reached its checks and asserts that all of them did.

Bounded: ``EXAMPLES`` per node (generation only, no shrinking: a failing example is printed by
hypothesis as drawn), about 40 s for the five nodes on two cores.
"""
import math

from geometry_msgs.msg import PointStamped, PoseStamped, TwistStamped
from hypothesis import HealthCheck, Phase, given, settings, strategies as st
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import (BeltSpeed, DriverCommand, LateralControllerStatus, LateralReference,
                          SteeringActuatorState, SteeringCommand, TreadmillDriveCommand)
from irs_bringup.processes import NodeSpec
from irs_system_tests.service_calls import call_trigger
from irs_control.reference import CONSOLE_LIMIT
from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics
from irs_models.constants import STEER_LIMIT
from irs_treadmill.regulator import RegulatorParams
from irs_vehicle_sim.rig import RigConfig

EXAMPLES = 10
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None, derandomize=True,
                    phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck))
DAY_NS = 86_400 * 1_000_000_000
SPECIAL = [math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0, -0.0, 5e-324, 0.3, -0.3]
FLOATS = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True),
                   st.floats(-2.0, 2.0))
STAMPS = st.sampled_from(['now', 'zero', 'future', 'max', 'old', 'back', 'negative'])
ANGLES = inverse_kinematics(0.1, -0.05, 0.0, ArmGeometry())


def stamp_of(kind, now_ns):
    return {'now': now_ns, 'zero': 0, 'future': now_ns + DAY_NS,
            'max': (2**31 - 1) * 1_000_000_000 + 999_999_999, 'old': now_ns - 300_000_000,
            'back': now_ns - 5_000_000_000, 'negative': -5_000_000_000}[kind]


def stamp_msg(ns):
    from builtin_interfaces.msg import Time
    if ns < 0:
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    return from_ns(ns)


def _now(ros):
    return ros.node.get_clock().now().nanoseconds


def _alive(proc):
    assert proc.poll() is None, f'the node died:\n{proc.tail(30)}'


# ---------------------------------------------------------------------------------- controller
def test_fuzz_lateral_controller(ros, launch):
    # a long stale timeout: a pause of the test (load) must not restart the controller between
    # the probes of a good run (the good run restarts it itself, with a NaN measurement)
    proc = launch(NodeSpec('irs_control', 'lateral_controller', params={'stale_timeout': 10.0}))
    node = ros.node
    meas = node.create_publisher(PointStamped, 'lateral_position', qos.SENSOR)
    ref = node.create_publisher(LateralReference, 'lateral/reference', qos.COMMAND)
    cmds, status = {}, []
    subs = [
        node.create_subscription(SteeringCommand, 'steering/command',
                                 lambda m: cmds.setdefault(to_ns(m.header.stamp), m), qos.COMMAND),
        node.create_subscription(
            LateralControllerStatus, 'lateral/status', status.append, qos.SENSOR
        ),
    ]
    assert ros.wait_for_matched([meas, ref, *subs], timeout=30.0)

    def send_ref(value, ns):
        r = LateralReference()
        r.header.stamp = stamp_msg(ns)
        r.lateral_position = value
        ref.publish(r)

    def send_meas(y, ns):
        m = PointStamped()
        m.header.stamp = stamp_msg(ns)
        m.point.y = y
        meas.publish(m)
        return ns

    def probe(y=0.01):
        ns = send_meas(y, _now(ros))
        assert ros.spin_until(lambda: ns in cmds, 10.0), (
            f'no answer to a good measurement\n{proc.tail()}'
        )
        return cmds[ns]

    def good_run():
        """Reference 0 m, a NaN measurement (INVALID: zero steer, the controller restarts from
        rest at the next valid one), then 5 steps.
        """
        send_ref(0.0, _now(ros))
        # the reference and the measurements come on two topics: under load the node may take
        # a NaN probe before the new reference, so probe until a step shows both
        for _ in range(20):
            n = len(status)
            assert probe(math.nan).front_angle == 0.0
            if ros.spin_until(lambda: any(s.state == LateralControllerStatus.STATE_INVALID
                                          and s.reference == 0.0 for s in status[n:]), 1.0):
                break
        else:
            raise AssertionError(f'no INVALID step with the reference 0 m: {status[-1:]}')
        return [probe(y).front_angle for y in (0.01, 0.02, 0.03, 0.02, -0.01)]

    probe()
    baseline = good_run()
    reached = []

    @SETTINGS
    @given(ref_value=FLOATS, ref_stamp=STAMPS, y=FLOATS, y_stamp=STAMPS)
    def example(ref_value, ref_stamp, y, y_stamp):
        now = _now(ros)
        send_ref(ref_value, stamp_of(ref_stamp, now))
        send_meas(y, stamp_of(y_stamp, now))
        probe()
        _alive(proc)
        reached.append(1)

    example()
    assert len(reached) == EXAMPLES
    for c in cmds.values():
        assert math.isfinite(c.front_angle) and abs(c.front_angle) <= STEER_LIMIT + 1e-12, c
        assert c.rear_angle == 0.0
    assert good_run() == baseline


# ---------------------------------------------------------------------------------- estimator
def test_fuzz_arm_pose_estimator(ros, launch):
    proc = launch(NodeSpec('irs_sensing', 'arm_pose_estimator'))
    node = ros.node
    arm = node.create_publisher(JointState, 'arm/joint_states', qos.SENSOR)
    got = {}
    sub = node.create_subscription(PointStamped, 'lateral_position',
                                   lambda m: got.setdefault(to_ns(m.header.stamp), m), qos.SENSOR)
    assert ros.wait_for_matched([arm, sub], timeout=30.0)

    def send(positions, ns):
        js = JointState()
        js.header.stamp = stamp_msg(ns)
        js.position = [float(a) for a in positions]
        arm.publish(js)
        return ns

    def probe():
        # best effort: one reading may be lost on a loaded machine, so the same good pose is
        # sent again (a new stamp) each second; a silenced node answers none of them
        for _ in range(10):
            ns = send(ANGLES, _now(ros))
            if ros.spin_until(lambda: ns in got, 1.0):
                return got[ns].point.y
        raise AssertionError(f'no answer to 10 good readings\n{proc.tail()}')

    y_good = probe()
    assert math.isfinite(y_good)
    reached = []

    @SETTINGS
    @given(angles=st.lists(FLOATS, min_size=0, max_size=4), stamp=STAMPS)
    def example(angles, stamp):
        send(angles, stamp_of(stamp, _now(ros)))
        probe()          # answered (NaN allowed: a plausibility rejection after a jump)
        _alive(proc)
        reached.append(1)

    example()
    assert len(reached) == EXAMPLES
    # good readings again: the same answer as before, once the jump bound has grown (a drawn
    # reading may have been a valid pose elsewhere on the belt)
    assert ros.spin_until(lambda: probe() == y_good, 10.0), 'no recovery on good readings'
    assert all(probe() == y_good for _ in range(5))


# ---------------------------------------------------------------------------------- regulator
def test_fuzz_treadmill_regulator(ros, launch):
    proc = launch(NodeSpec('irs_treadmill', 'treadmill_regulator',
                           params={'safety.stale_timeout': 5.0}))
    node = ros.node
    pose_pub = node.create_publisher(PoseStamped, 'pose', qos.SENSOR)
    vel_pub = node.create_publisher(TwistStamped, 'velocity', qos.SENSOR)
    belt_pub = node.create_publisher(BeltSpeed, 'belt/speed', qos.SENSOR)
    drive = {}
    sub = node.create_subscription(TreadmillDriveCommand, 'treadmill/drive',
                                   lambda m: drive.setdefault(to_ns(m.header.stamp), m),
                                   qos.COMMAND)
    assert ros.wait_for_matched([pose_pub, vel_pub, belt_pub, sub], timeout=30.0)

    def send(ns, x=0.0, y=0.0, qz=0.0, qw=1.0, vx=0.0, vy=0.0, belt=1.0):
        stamp = stamp_msg(ns)
        b = BeltSpeed()
        b.header.stamp = stamp
        b.speed = belt
        v = TwistStamped()
        v.header.stamp = stamp
        v.twist.linear.x, v.twist.linear.y = vx, vy
        p = PoseStamped()
        p.header.stamp = stamp
        p.pose.position.x, p.pose.position.y = x, y
        p.pose.orientation.z, p.pose.orientation.w = qz, qw
        for pub, msg in ((belt_pub, b), (vel_pub, v), (pose_pub, p)):
            pub.publish(msg)
        return ns

    def probe(x=0.0):
        ns = send(_now(ros), x=x)
        assert ros.spin_until(lambda: ns in drive, 10.0), (
            f'no answer to a good pose\n{proc.tail()}'
        )
        return drive[ns].voltage

    def good_run():
        """After treadmill/reset_fault (faults cleared, regulator from rest): 8 steps."""
        assert call_trigger(ros, 'treadmill/reset_fault').success
        return [probe(x) for x in (0.0, 0.1, 0.2, 0.3, 0.4, 0.3, 0.2, 0.1)]

    probe()
    baseline = good_run()
    assert any(v > 0.0 for v in baseline)
    reached = []

    @SETTINGS
    @given(x=FLOATS, y=FLOATS, qz=FLOATS, qw=FLOATS, vx=FLOATS, vy=FLOATS, belt=FLOATS,
           stamp=STAMPS)
    def example(x, y, qz, qw, vx, vy, belt, stamp):
        send(stamp_of(stamp, _now(ros)), x, y, qz, qw, vx, vy, belt)
        probe()
        _alive(proc)
        reached.append(1)

    example()
    assert len(reached) == EXAMPLES
    u_max = RegulatorParams().u_max         # the regulator's own limit (the belt's range)
    for d in drive.values():
        assert math.isfinite(d.voltage) and 0.0 <= d.voltage <= u_max, d
    assert good_run() == baseline


# ---------------------------------------------------------------------------------- reference
def test_fuzz_reference_generator_console(ros, launch):
    proc = launch(NodeSpec('irs_control', 'reference_generator',
                           params={'source': 'console', 'rate': 100.0}))
    node = ros.node
    console = node.create_publisher(Float64, 'console/lateral_position', qos.COMMAND)
    refs = []
    sub = node.create_subscription(LateralReference, 'lateral/reference', refs.append, qos.COMMAND)
    assert ros.wait_for_matched([console, sub], timeout=30.0)
    counter = iter(range(10**6))

    def probe():
        value = 0.001 * (next(counter) % 400 + 1)      # a new good value each time
        console.publish(Float64(data=value))
        n = len(refs)
        assert ros.spin_until(lambda: any(r.lateral_position == value for r in refs[n:]), 10.0), \
            f'the good console value {value} did not become the reference\n{proc.tail()}'

    probe()
    reached = []

    @SETTINGS
    @given(value=FLOATS)
    def example(value):
        console.publish(Float64(data=value))
        probe()
        _alive(proc)
        reached.append(1)

    example()
    assert len(reached) == EXAMPLES
    assert refs
    for r in refs:
        assert math.isfinite(r.lateral_position) and abs(r.lateral_position) <= CONSOLE_LIMIT, r


# ---------------------------------------------------------------------------------- rig
def test_fuzz_vehicle_sim(ros, launch):
    proc = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                           params={'clock_mode': 'realtime', 'dt': 0.005, 'start_inputs': [''],
                                   'command_timeout': 1.0, 'ground_truth_decimation': 0,
                                   # the values and stamps are fuzzed here, not the silences
                                   # (a drawn drive command stamped ahead is dropped: the drive
                                   # goes silent, which would stop the rig: test_starvation.py)
                                   'stall_grace': 3600.0}))
    node = ros.node
    pubs = {'steering': node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND),
            'drive': node.create_publisher(TreadmillDriveCommand, 'treadmill/drive', qos.COMMAND),
            'driver': node.create_publisher(DriverCommand, 'driver/command', qos.COMMAND)}
    states, arm = [], []
    subs = [
        node.create_subscription(
            SteeringActuatorState, 'steering/state', states.append, qos.SENSOR
        ),
        node.create_subscription(JointState, 'arm/joint_states', arm.append, qos.SENSOR),
    ]
    assert ros.wait_for_matched([*pubs.values(), *subs], timeout=30.0)
    counter = iter(range(10**6))

    def steer(front, rear, ns):
        c = SteeringCommand()
        c.header.stamp = stamp_msg(ns)
        c.front_angle, c.rear_angle = front, rear
        pubs['steering'].publish(c)

    def probe():
        """A good steering command (a new value each time) is applied; the sensors keep coming."""
        value = 0.001 * (next(counter) % 100 + 1)
        steer(value, 0.0, _now(ros))
        n, m = len(states), len(arm)
        assert ros.spin_until(lambda: any(s.front_commanded == value for s in states[n:])
                              and len(arm) > m, 10.0), \
            f'the good steering command {value} was not applied\n{proc.tail()}'

    probe()
    reached = []

    @SETTINGS
    @given(front=FLOATS, rear=FLOATS, s_stamp=STAMPS, voltage=FLOATS, d_stamp=STAMPS,
           speed=FLOATS, v_stamp=STAMPS)
    def example(front, rear, s_stamp, voltage, d_stamp, speed, v_stamp):
        now = _now(ros)
        steer(front, rear, stamp_of(s_stamp, now))
        d = TreadmillDriveCommand()
        d.header.stamp = stamp_msg(stamp_of(d_stamp, now))
        d.voltage = voltage
        pubs['drive'].publish(d)
        v = DriverCommand()
        v.header.stamp = stamp_msg(stamp_of(v_stamp, now))
        v.speed = speed
        pubs['driver'].publish(v)
        probe()
        _alive(proc)
        reached.append(1)

    example()
    assert len(reached) == EXAMPLES
    # what the rig applies: a command beyond steer_reject is refused (0 rad), the servo
    # saturates its reference at STEER_LIMIT, so the wheels never pass 15 deg
    reject = RigConfig().steer_reject
    for s in states:
        for commanded, achieved in ((s.front_commanded, s.front_achieved),
                                    (s.rear_commanded, s.rear_achieved)):
            assert math.isfinite(commanded) and abs(commanded) <= reject, s
            assert math.isfinite(achieved) and abs(achieved) <= STEER_LIMIT, s
    for a in arm[-50:]:
        assert len(a.position) == 3
