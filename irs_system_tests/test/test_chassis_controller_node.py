"""chassis_controller on its topics, fed by the test (no rig): ABS releases a slipping wheel,
a NaN encoder gives zero torque and a reason, bad parameters are refused in one sentence, and in
lock-step every encoder stamp is answered once, stamped with it, only when its set is complete.

The test process plays the rig and the arm estimator: it publishes ``wheels/encoders``, ``pose``,
``velocity`` and ``belt/speed`` with the same stamp and reads ``wheels/torque_command``,
``steering/command`` and ``chassis/status``. The car stands still on the treadmill at belt speed
(x constant, 1.2 m/s belt), so the node's speed estimate is 1.2 m/s.
"""
import math
import os
import re
import subprocess
import time

import pytest
from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped

from irs_bringup.processes import NodeSpec
from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import BeltSpeed, SteeringCommand, WheelEncoders, WheelTorqueCommand

R = 0.033            # [m] wheel radius (the controller's default)
V = 1.2              # [m/s] belt speed = car speed over the belt
ROLLING = V / R      # [rad/s]
MS = 1_000_000       # [ns]


class ChassisLink:
    """The node's inputs (publishers) and its answers (by stamp)."""

    def __init__(self, ros):
        node = ros.node
        self.ros = ros
        self.enc = node.create_publisher(WheelEncoders, 'wheels/encoders', qos.SENSOR)
        self.pose = node.create_publisher(PoseStamped, 'pose', qos.SENSOR)
        self.vel = node.create_publisher(TwistStamped, 'velocity', qos.SENSOR)
        self.belt = node.create_publisher(BeltSpeed, 'belt/speed', qos.SENSOR)
        self.torques, self.steers, self.status = [], [], []
        self.subs = [
            node.create_subscription(WheelTorqueCommand, 'wheels/torque_command',
                                     self.torques.append, qos.COMMAND),
            node.create_subscription(SteeringCommand, 'steering/command', self.steers.append,
                                     qos.COMMAND),
            node.create_subscription(DiagnosticArray, 'chassis/status', self.status.append,
                                     qos.SENSOR),
        ]
        assert ros.wait_for_matched([self.enc, self.pose, self.vel, self.belt, *self.subs],
                                    timeout=30.0)

    def send(self, stamp_ns, omega, x=0.3, yaw_rate=0.0, order=('enc', 'pose', 'vel', 'belt')):
        stamp = from_ns(stamp_ns)
        msgs = {'enc': WheelEncoders(), 'pose': PoseStamped(), 'vel': TwistStamped(),
                'belt': BeltSpeed()}
        for m in msgs.values():
            m.header.stamp = stamp
        msgs['enc'].velocity = [float(w) for w in omega]
        msgs['pose'].pose.position.x = float(x)
        msgs['pose'].pose.orientation.w = 1.0
        msgs['vel'].twist.angular.z = float(yaw_rate)
        msgs['belt'].speed = V
        for name in order:
            getattr(self, name).publish(msgs[name])

    def answer(self, stamp_ns):
        return next((m for m in reversed(self.torques) if to_ns(m.header.stamp) == stamp_ns),
                    None)

    def step(self, stamp_ns, omega, **kw):
        self.send(stamp_ns, omega, **kw)
        assert self.ros.spin_until(lambda: self.answer(stamp_ns) is not None, 20.0), \
            f'no answer for stamp {stamp_ns}'
        return self.answer(stamp_ns)

    def steer(self, stamp_ns):
        """The steering command answering ``stamp_ns`` (its own topic: may come later)."""
        def find():
            return next((m for m in self.steers if to_ns(m.header.stamp) == stamp_ns), None)
        assert self.ros.spin_until(lambda: find() is not None, 20.0), f'no steer {stamp_ns}'
        return find()

    def last_status(self):
        st = self.status[-1].status[0]
        return st.message, {kv.key: kv.value for kv in st.values}


def start(launch, **params):
    # input_sync as a lock-step graph has it (the node runs on the wall clock here, where its
    # default is false): the test sends each stamp's set and waits for its answer
    base = {'stale_timeout': 10.0, 'status_decimation': 1, 'input_sync': True}
    return launch(NodeSpec('irs_control', 'chassis_controller', params={**base, **params}))


def test_abs_releases_the_slipping_wheel_and_keeps_the_full_brake_on_the_others(ros, launch):
    # the arm's speed as the ABS's reference: the wheels cannot tell it (one slips, the others
    # roll at an unknown slip), the arm can, so the slip is known
    start(launch, **{'brake.start_time': 0.0, 'brake.mode': 'abs', 'brake.torque': 0.3,
                     'abs.reference': 'arm'})
    link = ChassisLink(ros)
    slipping = [0.5 * ROLLING, ROLLING, ROLLING, ROLLING]     # FL at slip -0.5
    for k in range(40):
        cmd = link.step(k * MS, slipping)
    torque = list(cmd.torque)
    assert torque[1:] == [-0.3, -0.3, -0.3], 'rolling wheels: the full brake request'
    assert -0.3 < torque[0] <= 0.0, torque
    assert torque[0] > -0.1, f'FL slips far past the target: ABS must release it ({torque})'
    assert not any(cmd.locked)
    assert all(math.isfinite(t) for t in torque)
    reason, values = link.last_status()
    assert reason == 'ok' and values['braking'] == 'true' and values['brake_mode'] == 'abs'
    assert float(values['slip_FL']) == pytest.approx(-0.5, abs=1e-9)
    assert float(values['v_hat']) == pytest.approx(V, abs=1e-9)
    assert float(values['slip_target_FL']) == -0.10 and math.isfinite(float(values['v_ref']))
    # The same wheel rolling again: ABS gives the brake back (integral towards the request).
    for k in range(40, 200):
        cmd = link.step(k * MS, [ROLLING] * 4)
    assert cmd.torque[0] < torque[0] - 0.1, (cmd.torque[0], torque[0])


def test_nan_encoder_gives_zero_torque_zero_steer_and_a_reason_then_recovers(ros, launch):
    start(launch, **{'steer.amplitude': 0.05, 'steer.start_time': 0.0})
    link = ChassisLink(ros)
    for k in range(20):
        cmd = link.step(k * MS, [ROLLING] * 4)
    assert link.steer(19 * MS).front_angle == 0.05
    cmd = link.step(20 * MS, [math.nan, ROLLING, ROLLING, ROLLING])
    assert list(cmd.torque) == [0.0] * 4 and not any(cmd.locked)
    steer = link.steer(20 * MS)
    assert (steer.front_angle, steer.rear_angle) == (0.0, 0.0)
    assert ros.spin_until(lambda: link.last_status()[0] == 'nonfinite_encoders', 10.0)
    assert link.status[-1].status[0].level != 0
    # recovered: the next valid sample steers and drives again
    cmd = link.step(21 * MS, [ROLLING] * 4)
    assert link.steer(21 * MS).front_angle == 0.05
    assert ros.spin_until(lambda: link.last_status()[0] == 'ok', 10.0)
    cmd = link.step(22 * MS, [ROLLING, ROLLING, math.inf, ROLLING])
    assert list(cmd.torque) == [0.0] * 4
    # a NaN pose (the estimator's rejected reading) too
    cmd = link.step(23 * MS, [ROLLING] * 4, x=math.nan)
    assert list(cmd.torque) == [0.0] * 4
    assert ros.spin_until(lambda: link.last_status()[0] == 'invalid_pose_or_belt_speed', 10.0)


def _set(ros, **values):
    """Set parameters of the node (the call sent again if its answer is lost)."""
    from irs_system_tests.service_calls import set_params
    return set_params(ros, 'chassis_controller', **values)


def test_parameters_refused_in_one_sentence_and_live_ones_applied(ros, launch):
    exe = os.path.join(get_package_prefix('irs_control'), 'lib', 'irs_control',
                       'chassis_controller')
    res = subprocess.run([exe, '--ros-args', '-p', 'brake.mode:=skid'], capture_output=True,
                         text=True, timeout=60)
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert 'Traceback' not in res.stderr, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if 'brake.mode' in ln]
    assert len(lines) == 1 and 'skid' in lines[0], res.stderr

    start(launch)
    link = ChassisLink(ros)
    link.step(0, [ROLLING] * 4)
    [r] = _set(ros, brake__mode='skid')
    assert not r.successful and 'brake.mode' in r.reason and "'abs'" in r.reason, r.reason
    [r] = _set(ros, yaw_control='both')
    assert not r.successful and 'read-only' in r.reason, r.reason
    [r] = _set(ros, brake__torque=-1.0)
    assert not r.successful and 'brake.torque' in r.reason, r.reason
    # a live parameter takes effect at the next step: braking now, locked wheels
    results = _set(ros, brake__start_time=0.0, brake__mode='locked')
    assert all(r.successful for r in results), [r.reason for r in results]
    cmd = link.step(MS, [ROLLING] * 4)
    assert all(cmd.locked) and list(cmd.torque) == [0.0] * 4


def test_lockstep_one_answer_per_encoder_stamp_only_when_its_set_is_complete(ros, launch):
    start(launch, input_sync=True)
    link = ChassisLink(ros)
    orders = [('enc', 'pose', 'vel', 'belt'), ('belt', 'vel', 'pose', 'enc'),
              ('pose', 'enc', 'belt', 'vel'), ('vel', 'belt', 'enc', 'pose')]
    for k in range(12):
        link.step(k * MS, [ROLLING] * 4, order=orders[k % 4])
    # an incomplete set (no belt speed) is not answered ...
    link.send(12 * MS, [ROLLING] * 4, order=('enc', 'pose', 'vel'))
    assert not ros.spin_until(lambda: link.answer(12 * MS) is not None, 1.0)
    # ... until its last input arrives
    link.send(12 * MS, [ROLLING] * 4, order=('belt',))
    assert ros.spin_until(lambda: link.answer(12 * MS) is not None, 20.0)
    stamps = [to_ns(m.header.stamp) for m in link.torques]
    assert stamps == [k * MS for k in range(13)], stamps
    link.steer(12 * MS)
    assert [to_ns(m.header.stamp) for m in link.steers] == stamps
    # a repeated stamp (lock-step resend) is answered again with the same command
    n = len(link.torques)
    link.send(12 * MS, [0.0] * 4)
    assert ros.spin_until(lambda: len(link.torques) > n, 20.0)
    assert to_ns(link.torques[-1].header.stamp) == 12 * MS
    assert list(link.torques[-1].torque) == list(link.torques[n - 1].torque)


def test_real_time_answers_each_encoder_sample_with_the_newest_pose_and_goes_stale(ros, launch):
    proc = start(launch, input_sync=False, stale_timeout=0.2, **{'steer.amplitude': 0.05})
    link = ChassisLink(ros)
    now = lambda: ros.node.get_clock().now().nanoseconds  # noqa: E731

    def sample(stamp_ns):
        """The measurements 1 ms before the encoder sample: the newest, not of its stamp."""
        link.send(stamp_ns - MS, [ROLLING] * 4, order=('pose', 'vel', 'belt'))
        return link.step(stamp_ns, [ROLLING] * 4, order=('enc',))

    def drives_again():
        """After a stale episode: samples with fresh measurements until one is answered with
        the step steer (an encoder sample may overtake its measurements, which travel on other
        topics, and meet the stale pose); its stamp, or None after 20 tries and at least 20 s
        (a stalled machine may spend the tries within one stall).
        """
        deadline, tries = time.monotonic() + 20.0, 0
        while tries < 20 or time.monotonic() < deadline:
            tries += 1
            stamps.append(now())
            sample(stamps[-1])
            if link.steer(stamps[-1]).front_angle == 0.05:
                return stamps[-1]
        return None

    def status_of(stamp_ns):
        """The reason on chassis/status for ``stamp_ns`` (its own topic: may come later)."""
        def find():
            return next((st.status[0].message for st in link.status
                         if to_ns(st.header.stamp) == stamp_ns), None)
        ros.spin_until(lambda: find() is not None, 5.0)
        return find()

    # an encoder sample before any pose, velocity and belt speed is not answered
    stamp = now()
    link.send(stamp, [ROLLING] * 4, order=('enc',))
    assert not ros.spin_until(lambda: link.answer(stamp) is not None, 1.0)
    # samples with their newest measurements, sent until one is answered with the step steer:
    # the first ones may overtake their measurements and find none (no answer) or only those
    # of an earlier try (stale_pose)
    stamps = [now()]
    deadline = time.monotonic() + 20.0
    while True:
        link.send(stamps[-1] - MS, [ROLLING] * 4, order=('pose', 'vel', 'belt'))
        link.send(stamps[-1], [ROLLING] * 4, order=('enc',))
        if ros.spin_until(lambda: link.answer(stamps[-1]) is not None, 0.5) \
                and link.steer(stamps[-1]).front_angle == 0.05:
            break
        assert time.monotonic() < deadline, 'no encoder sample answered with the step steer'
        stamps.append(now())
    for _ in range(5):
        stamps.append(now())
        cmd = sample(stamps[-1])
        assert not any(cmd.locked)
        # the step steer, or zero where the newest pose the node had was too old, as its status
        # says: the measurements travel on topics of their own, which DDS may deliver after the
        # encoder samples sent later (on a loaded machine, 10-15 ms late: several samples)
        steer = link.steer(stamps[-1]).front_angle
        assert steer == 0.05 or (steer == 0.0 and status_of(stamps[-1]) == 'stale_pose'), (
            steer, status_of(stamps[-1]), proc.tail(10))
    # the poses stop, the encoder samples go on: beyond pose_timeout (0.2 s) of the newest pose
    # the answer is zero torque and steer, reason stale_pose; a fresh pose and it drives again
    ros.spin_until(lambda: False, 0.5)      # the newest pose ages 0.5 s (spinning meanwhile)
    stamp = now()
    cmd = link.step(stamp, [ROLLING] * 4, order=('enc',))
    assert list(cmd.torque) == [0.0] * 4 and link.steer(stamp).front_angle == 0.0
    assert ros.spin_until(lambda: link.last_status()[0] == 'stale_pose', 5.0)
    # its warning (throttled: one a second) names the pose's age, beyond pose_timeout
    def stale_ages():
        return [float(a) for a in re.findall(
            r'stale_pose\): .*the newest pose is ([0-9.]+) s older', proc.output())]
    assert ros.spin_until(lambda: stale_ages(), 5.0), proc.tail(10)
    assert min(stale_ages()) > 0.2, proc.tail(10)
    assert drives_again() is not None
    # silence: within the timeout a zero command and the reason STALE; the command carries the
    # last step's stamp (a rig lagging real time keeps taking the steps after it)
    # (torque and steer travel on two topics: wait for a new message on each)
    n, n_steer = len(link.torques), len(link.steers)
    assert ros.spin_until(lambda: link.last_status()[0] == 'stale_encoders', 5.0)
    assert ros.spin_until(lambda: len(link.torques) > n and len(link.steers) > n_steer, 5.0)
    assert list(link.torques[-1].torque) == [0.0] * 4
    assert to_ns(link.torques[-1].header.stamp) == stamps[-1]
    assert (link.steers[-1].front_angle, link.steers[-1].rear_angle) == (0.0, 0.0)
    # the next samples run again
    assert drives_again() is not None


def test_fuzz_every_input_commands_stay_finite_and_the_node_keeps_answering(ros, launch):
    """hypothesis draws one bad field per example (NaN, +-inf, +-1e308, ...) in one input of a
    set whose stamp it draws too (now, zero, a day ahead, the largest time, 0.3 s and 5 s back,
    negative), the other three inputs good; after each a good set stamped now must be answered,
    and every command ever published must be finite and within the limits (as
    irs_system_tests/test/test_bad_input_fuzz.py does for the other nodes).
    """
    from hypothesis import given, strategies as st
    from test_bad_input_fuzz import FLOATS, SETTINGS, STAMPS, STEER_LIMIT, stamp_msg, stamp_of

    proc = launch(NodeSpec('irs_control', 'chassis_controller',
                           params={'input_sync': True, 'yaw_control': 'differential',
                                   'brake.start_time': 0.0, 'stale_timeout': 10.0}))
    link = ChassisLink(ros)
    now = lambda: ros.node.get_clock().now().nanoseconds  # noqa: E731

    def probe():
        stamp = now()
        return link.step(stamp, [ROLLING] * 4)

    probe()

    @SETTINGS
    @given(which=st.sampled_from(['enc', 'pose', 'vel', 'belt']), value=FLOATS,
           wheel=st.integers(0, 3), stamp=STAMPS)
    def example(which, value, wheel, stamp):
        msgs = {'enc': WheelEncoders(), 'pose': PoseStamped(), 'vel': TwistStamped(),
                'belt': BeltSpeed()}
        for m in msgs.values():
            m.header.stamp = stamp_msg(stamp_of(stamp, now()))
        msgs['enc'].velocity = [ROLLING] * 4
        msgs['pose'].pose.position.x = 0.3
        msgs['pose'].pose.orientation.w = 1.0
        msgs['belt'].speed = V
        msg = msgs[which]
        if which == 'enc':
            omega = [ROLLING] * 4
            omega[wheel] = value
            msg.velocity = omega
        elif which == 'pose':
            msg.pose.position.x = value
            msg.pose.orientation.w = 1.0
        elif which == 'vel':
            msg.twist.angular.z = value
        else:
            msg.speed = value
        for name, m in msgs.items():
            getattr(link, name).publish(m)
        probe()
        assert proc.poll() is None, proc.tail(30)

    example()
    for cmd in link.torques:
        assert all(math.isfinite(t) and abs(t) <= 0.3 for t in cmd.torque), cmd
    for s in link.steers:
        assert math.isfinite(s.front_angle) and math.isfinite(s.rear_angle), s
        assert abs(s.rear_angle) <= STEER_LIMIT + 1e-12
