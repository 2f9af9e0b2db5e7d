"""``bag play`` reproduces the recorded bytes, publishes /clock at the data's times, waits for
its subscribers, and a sensing node re-run from a replay reproduces the recorded poses.
"""
import math
import struct
import time

from irs_bringup.processes import NodeSpec, wait_until

from test_recorder import LockstepResponder, record_lockstep  # same tests/ directory

N = 400
DT_NS = 1_000_000
LOG0 = 5 * 10**9 + 123  # log times: LOG0 + k ms (+ 1 us for /b); stamps: k ms


def _type_name(msg):
    return f'{type(msg).__module__.split(".")[0]}/msg/{type(msg).__name__}'


def make_bag(path):
    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from irs_bag.writer import BagWriter

    with BagWriter(path, chunk_size=32 * 1024) as w:
        for k in range(N):
            p = PointStamped()
            p.header.stamp.sec, p.header.stamp.nanosec = divmod(k * DT_NS, 10**9)
            p.point.x, p.point.y = float(k), math.sin(k * 1e-2)
            w.write('/a', _type_name(p), serialize_message(p), LOG0 + k * DT_NS)
            js = JointState()
            js.header.stamp = p.header.stamp
            js.name = ['j'] * (k % 5)                  # varying sizes
            js.position = [k * 0.5] * (k % 5)
            w.write('/b', _type_name(js), serialize_message(js), LOG0 + k * DT_NS + 1000)
    return path


def raw_recorder(ros, topics):
    """Raw subscriptions on the watcher node: topic -> list of received bytes."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    got = {t: [] for t in topics}
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                     reliability=ReliabilityPolicy.RELIABLE)
    for topic, mtype in topics.items():
        ros.node.create_subscription(mtype, topic, got[topic].append, qos, raw=True)
    return got


def stamp_ns(data: bytes) -> int:
    sec, nsec = struct.unpack_from('<iI', data, 4)
    return sec * 10**9 + nsec


def last_clock(clocks):
    """The last /clock value received [ns], None before the first."""
    return stamp_ns(clocks[-1]) if clocks else None


def after_lead_in(clocks):
    """The /clock values received, the lead-in's repeats of the first one counted once."""
    first = clocks[0]
    k = 0
    while k < len(clocks) and clocks[k] == first:
        k += 1
    assert k >= 1
    return clocks[k - 1:]


def test_replay_is_byte_exact_with_clock_and_waits_for_subscribers(ros, launch, tmp_path):
    from geometry_msgs.msg import PointStamped
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from irs_bag.reader import BagReader

    bag = make_bag(tmp_path / 'bag')
    with BagReader(bag) as r:
        recorded = {'/a': [], '/b': []}
        for m in r.messages():
            recorded[m.topic].append(m.data)
        log_times = sorted({m.log_time_ns for m in r.messages()})

    # The player starts first and must hold back until our subscriptions matched.
    play = launch(NodeSpec('irs_bag', 'bag', name='play', args=[
        'play', bag, '--clock', '--paused-until-matched', '--remap', '/b:=/b_replayed']))
    assert ros.wait_for_endpoints('/b_replayed', publishers=1, timeout=30.0), play.tail()
    got = raw_recorder(ros, {'/a': PointStamped, '/b_replayed': JointState, '/clock': Clock})
    # (the lead-in's repeats are among the /clock received: done when the last value came)
    done = ros.spin_until(lambda: play.poll() is not None
                          and len(got['/a']) >= N and len(got['/b_replayed']) >= N
                          and last_clock(got['/clock']) == log_times[-1], 60.0)
    out = play.output()
    assert done, (out, {k: len(v) for k, v in got.items()})
    assert play.poll() == 0, out
    # byte for byte, in order, nothing lost at the start
    assert got['/a'] == recorded['/a']
    assert got['/b_replayed'] == recorded['/b']
    # /clock at the data's own (log) times, one per distinct time, increasing, after the
    # lead-in that repeats the first one until the subscribers have it
    assert after_lead_in([stamp_ns(c) for c in got['/clock']]) == log_times
    assert 'timing error mean' in out, out
    # the lead-in's values are acknowledged, not given up on after --ack-timeout (10 s)
    assert 'not acknowledged' not in out, out

    # --clock-from header: /clock follows header.stamp; only /a played, as fast as possible
    got2 = raw_recorder(ros, {'/a': PointStamped, '/clock': Clock})
    got2['/a'].clear()
    play2 = launch(NodeSpec('irs_bag', 'bag', name='play2', args=[
        'play', bag, '--fast', '--topics', '/a', '--clock', '--clock-from', 'header',
        '--wait-for-subscribers', '2']))   # our two /a subscriptions
    assert ros.spin_until(lambda: play2.poll() is not None and len(got2['/a']) >= N
                          and last_clock(got2['/clock']) == (N - 1) * DT_NS, 60.0), \
        (play2.output(), len(got2['/a']), len(got2['/clock']), len(got['/a']),
         play2.write_native_stacks()[-6000:])     # where a player that did not finish waits
    assert play2.poll() == 0
    assert 'not acknowledged' not in play2.output(), play2.output()
    assert got2['/a'] == recorded['/a']
    assert after_lead_in([stamp_ns(c) for c in got2['/clock']]) == [k * DT_NS for k in range(N)]


def test_replay_start_offset_and_usage_errors(ros, launch, tmp_path):
    import subprocess

    from geometry_msgs.msg import PointStamped

    from irs_bringup.executables import resolve_executable

    bag = make_bag(tmp_path / 'bag')
    got = raw_recorder(ros, {'/a': PointStamped})
    play = launch(NodeSpec('irs_bag', 'bag', name='play', args=[
        'play', bag, '--topics', 'a', '--start-offset', '0.2', '--rate', '2',
        '--wait-for-subscribers', '1']))
    assert ros.spin_until(lambda: play.poll() is not None and len(got['/a']) >= N - 200,
                          60.0), play.output()
    assert play.poll() == 0
    assert [stamp_ns(d) for d in got['/a']] == [k * DT_NS for k in range(200, N)]

    exe = resolve_executable('irs_bag', 'bag')
    for args, code in ((['play', bag, '--topics', '/nope'], 2),
                       (['play', tmp_path / 'missing'], 2),
                       (['play', bag, '--remap', 'a=b'], 2),
                       (['play', bag, '--rate', '-1'], 2),
                       (['play', bag, '--ack-timeout', 'nan'], 2),
                       (['play', bag, '--start-offset', 'inf'], 2),
                       # names rcl refuses, and two types on one name: refused before ROS starts
                       (['play', bag, '--remap', '/a:=not/valid/@@'], 2),
                       (['play', bag, '--remap', '/a:=/1a'], 2),
                       (['play', bag, '--clock', '--remap', '/a:=/clock'], 2),
                       # values with no meaning, and options that contradict each other
                       (['play', bag, '--rate', 'inf'], 2),
                       (['play', bag, '--fast', '--rate', '2'], 2),
                       (['play', bag, '--qos-depth', '0'], 2),
                       (['play', bag, '--wait-for-subscribers', '-1'], 2),
                       (['play', bag, '--clock-from', 'header'], 2),
                       # a bad --ros-args: rclpy.init refuses it
                       (['play', bag, '--ros-args', '--bogus'], 2),
                       (['play', bag, '--ros-args', '-p', 'kp'], 2)):
        res = subprocess.run([exe, *map(str, args)], capture_output=True, text=True,
                             timeout=60)
        assert res.returncode == code, (args, res.stderr)
        assert 'Traceback' not in res.stderr and 'error' in res.stderr
        assert 'internal error' not in res.stderr, (args, res.stderr)


def timed_bag(path, n, log_step_ns, stamp_step_ns, lockstep=False, clock=False):
    """Write n PointStamped on /a: log times k * log_step_ns, header stamps k * stamp_step_ns.

    An experiment record whose file says ``clock: lockstep`` (``lockstep=True``) or
    ``clock: realtime`` (False; None: no record), and a /clock topic (Clock = the stamp) if
    asked.
    """
    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    from irs_bag.writer import BagWriter

    with BagWriter(path, chunk_size=16 * 1024) as w:
        if lockstep is not None:
            w.add_metadata('irs_experiment', {
                'experiment_yaml': f'name: t\nclock: {"lockstep" if lockstep else "realtime"}\n'})
        for k in range(n):
            stamp = divmod(k * stamp_step_ns, 10**9)
            if clock:
                c = Clock()
                c.clock.sec, c.clock.nanosec = stamp
                w.write('/clock', 'rosgraph_msgs/msg/Clock', serialize_message(c),
                        LOG0 + k * log_step_ns)
            p = PointStamped()
            p.header.stamp.sec, p.header.stamp.nanosec = stamp
            p.point.x = float(k)
            w.write('/a', _type_name(p), serialize_message(p), LOG0 + k * log_step_ns + 1)
    return path


def receive_times(ros, topic):
    """Subscribe ``topic`` (PointStamped): a list of (DDS receive time [s], point.x)."""
    from geometry_msgs.msg import PointStamped
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    got = []
    ros.node.create_subscription(
        PointStamped, topic, lambda msg, info: got.append((info['received_timestamp'] * 1e-9,
                                                           msg.point.x)),
        QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                   reliability=ReliabilityPolicy.RELIABLE))
    return got


def play_and_time(ros, launch, bag, topic, n, *args):
    """Play ``bag`` (remapping /a to ``topic``) into a subscription; return (span of the
    receive times [s], received points, player output).

    The bags here space their n messages evenly, so the receive time of message k is
    ``t0 + k * span / (n - 1)`` plus scheduling noise. The span is fitted over all n messages
    with the Theil-Sen estimator (the median of the slopes of all pairs): robust to a few late
    messages, e.g. the first samples arriving as one burst of reliable repairs when the
    subscription learns of the player's writer after the player learnt of it.
    """
    from scipy.stats import theilslopes

    got = receive_times(ros, topic)
    play = launch(NodeSpec('irs_bag', 'bag', name=topic.strip('/'), args=[
        'play', bag, '--topics', '/a', '--remap', f'/a:={topic}', '--wait-for-subscribers', '1',
        *args]))
    assert ros.spin_until(lambda: play.poll() is not None and len(got) >= n, 60.0), \
        (play.output(), len(got))
    assert play.poll() == 0, play.output()
    assert [x for _, x in got] == [float(k) for k in range(n)], play.output()
    slope = theilslopes([t for t, _ in got], [x for _, x in got]).slope
    return slope * (n - 1), got, play.output()


def test_replay_rate_and_loop(ros, launch, tmp_path):
    """--rate 2 plays a bag spanning T = 1.6 s in about T / 2 (measured from the receive
    times); --rate 1 in about T; --loop plays it again and again until stopped.
    """
    n, step = 161, 10_000_000                 # 160 x 10 ms = 1.6 s of log time
    bag = timed_bag(tmp_path / 'bag', n, step, step)
    span2, _, out = play_and_time(ros, launch, bag, '/r2', n, '--rate', '2')
    assert 0.65 < span2 < 1.2, (span2, out)          # T / 2 = 0.8 s
    span1, _, out = play_and_time(ros, launch, bag, '/r1', n, '--rate', '1')
    assert 1.35 < span1 < 2.2, (span1, out)          # T = 1.6 s
    assert span1 > 1.4 * span2
    print(f'1.6 s bag: --rate 2 played in {span2:.3f} s, --rate 1 in {span1:.3f} s')

    small = timed_bag(tmp_path / 'small', 20, 5_000_000, 5_000_000)   # 0.1 s
    got = receive_times(ros, '/looped')
    play = launch(NodeSpec('irs_bag', 'bag', name='loop', args=[
        'play', small, '--remap', '/a:=/looped', '--loop', '--wait-for-subscribers', '1']))
    assert ros.spin_until(lambda: len(got) >= 3 * 20, 30.0), (play.output(), len(got))
    assert play.poll() is None, 'a looping player keeps playing'
    assert play.stop(timeout=10.0) == 130, play.output()     # ended by SIGINT: 128 + 2
    # each pass replays the whole bag, in order
    assert [x for _, x in got[:60]] == [float(k % 20) for k in range(60)]
    assert 'loop 2 done' in play.output()


def test_lockstep_bags_replay_on_simulation_time(ros, launch, tmp_path):
    """A lock-step recording paces by its header stamps (sim time) at --rate 1, whatever its
    receive times: 1.2 s of simulated time recorded in 0.3 s (a fast graph) plays in about
    1.2 s; --pace log forces the receive times (0.3 s). Detected by the experiment metadata or
    by /clock.
    """
    import subprocess

    from irs_bringup.executables import resolve_executable

    n = 121
    bag = timed_bag(tmp_path / 'lockstep', n, 2_500_000, 10_000_000, lockstep=True)
    span, _, out = play_and_time(ros, launch, bag, '/sim', n)
    assert 'pacing by header stamps (sim time) (its experiment file says clock: lockstep)' in out
    assert 1.0 < span < 1.8, (span, out)              # 1.2 s of sim time
    print(f'lock-step: 1.2 s sim recorded in 0.3 s played in {span:.3f} s (auto)')
    span_log, _, out = play_and_time(ros, launch, bag, '/logtime', n, '--pace', 'log')
    assert 'pacing by log (receive) times' in out
    assert span_log < 0.6 and span > 2.5 * span_log, (span_log, span)
    # stretched (a slow graph): 0.4 s of sim time over 4 s of receive time
    slow = timed_bag(tmp_path / 'slow', 41, 100_000_000, 10_000_000, lockstep=True)
    span, _, out = play_and_time(ros, launch, slow, '/slow', 41)
    assert 0.25 < span < 1.0, (span, out)             # not 4 s
    print(f'lock-step: 1.2 s sim / 0.3 s log played in {span_log:.3f} s with --pace log; '
          f'0.4 s sim / 4 s log played in {span:.3f} s')

    # a bag with /clock (no experiment record) is lock-step too; a real-time one is not
    exe = resolve_executable('irs_bag', 'bag')
    for path, expect in ((timed_bag(tmp_path / 'clk', n, 2_500_000, 10_000_000, lockstep=None,
                                    clock=True),
                          'pacing by header stamps (sim time) (it has /clock)'),
                         (timed_bag(tmp_path / 'rt', n, 2_500_000, 10_000_000),
                          'pacing by log (receive) times (not a lock-step bag)')):
        res = subprocess.run([exe, 'play', str(path), '--dry-run'], capture_output=True,
                             text=True, timeout=60)
        assert res.returncode == 0 and expect in res.stdout, (res.stdout, res.stderr)


def arm_bag(path, n, t0_ns):
    """A lock-step recording of the arm: n joint states (angles of a car at x = 0 swaying
    5 cm at 0.5 Hz, from ``irs_models.arm_kinematics.inverse_kinematics``) stamped
    ``t0_ns + k ms`` with the /clock of each step, received every 3 ms.
    """
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from irs_bag.writer import BagWriter
    from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

    geometry = ArmGeometry()
    with BagWriter(path, chunk_size=64 * 1024) as w:
        w.add_metadata('irs_experiment', {'clock': 'lockstep'})
        for k in range(n):
            stamp = divmod(t0_ns + k * DT_NS, 10**9)
            c = Clock()
            c.clock.sec, c.clock.nanosec = stamp
            w.write('/clock', 'rosgraph_msgs/msg/Clock', serialize_message(c),
                    LOG0 + k * 3 * DT_NS)
            js = JointState()
            js.header.stamp.sec, js.header.stamp.nanosec = stamp
            js.name = ['theta1', 'theta2', 'theta3']
            js.position = list(inverse_kinematics(
                0.0, 0.05 * math.sin(math.pi * k * 1e-3), 0.0, geometry))
            w.write('/arm/joint_states', 'sensor_msgs/msg/JointState', serialize_message(js),
                    LOG0 + k * 3 * DT_NS + 1000)
    return path


def estimator_on_sim_time(ros, launch, name, topic):
    """A fresh arm_pose_estimator on ``use_sim_time`` named ``name``, its lateral position
    remapped to ``topic``, matched with a reliable subscription of this test's node; returns the
    set its answers' stamps [ns] go into and the estimator's process.
    """
    from geometry_msgs.msg import PointStamped
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    answered = set()
    sub = ros.node.create_subscription(
        PointStamped, topic,
        lambda msg: answered.add(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec),
        QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                   reliability=ReliabilityPolicy.RELIABLE))
    est = launch(NodeSpec('irs_sensing', 'arm_pose_estimator', name=name,
                          params={'use_sim_time': True}, remaps={'lateral_position': topic}))
    # the estimator's answers reach us (both sides matched: the probe of the replay test below)
    assert ros.spin_until(lambda: sub.get_publisher_count() >= 1, 30.0), est.tail()
    assert call_until_answered(ros, f'/{name}/list_parameters', 30.0), est.tail()
    return answered, est


def test_play_clock_into_an_estimator_on_sim_time_loses_no_reading(ros, launch, tmp_path):
    """``bag play --clock`` into a fresh arm_pose_estimator with ``use_sim_time``: the
    estimator answers every reading. The bag's time starts at 5 s, so a
    reading that reached the estimator before the data's /clock (its clock still at 0) would
    be dropped as stamped more than its 0.5 s future tolerance ahead: the player's /clock
    lead-in must reach the estimator's best-effort /clock subscription before the first
    reading does.
    """
    n, t0 = 401, 5 * 10**9
    bag = arm_bag(tmp_path / 'arm', n, t0)
    answered, est = estimator_on_sim_time(ros, launch, 'estimator_on_clock', '/lateral_replayed')
    play = launch(NodeSpec('irs_bag', 'bag', name='play_clock', args=[
        'play', bag, '--topics', '/arm/joint_states', '--clock', '--rate', '0.1',
        '--wait-for-subscribers', '1']))
    # 100 readings per second of wall time: the estimator's 100-deep input queue holds 1 s
    stamps = {t0 + k * DT_NS for k in range(n)}
    assert ros.spin_until(lambda: play.poll() is not None and answered >= stamps,
                          60.0 + n / 100), \
        (play.output(), est.output()[-3000:], len(answered), sorted(stamps - answered)[:5])
    assert play.poll() == 0, play.output()
    assert answered == stamps, (len(stamps - answered), est.tail())
    assert 'ahead' not in est.output(), est.tail()       # nothing dropped as future-stamped
    # what the player cannot see, it says once
    warned = [ln for ln in play.output().splitlines() if 'bag play: warning:' in ln]
    assert len(warned) == 1 and 'the player cannot see' in warned[0], play.output()


def call_until_answered(ros, service, timeout):
    """Call a ListParameters service until a reply arrives (a lost reply is retried)."""
    from rcl_interfaces.srv import ListParameters
    client = ros.node.create_client(ListParameters, service)
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            if not client.wait_for_service(timeout_sec=0.5):
                continue
            future = client.call_async(ListParameters.Request())
            if ros.spin_until(future.done, min(1.0, max(0.0, deadline - time.monotonic()))):
                return True
            client.remove_pending_request(future)
        return False
    finally:
        ros.node.destroy_client(client)


def test_sensing_rerun_from_replay_reproduces_poses(ros, launch, tmp_path):
    """Record arm/joint_states + pose from a lock-step graph, replay only the joint states
    (with /clock from their stamps) into a fresh arm_pose_estimator, compare poses by stamp.
    """
    from geometry_msgs.msg import PoseStamped
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from irs_bag.reader import BagReader

    max_steps = 800
    bag = tmp_path / 'sensing'
    topics = ['/clock', '/arm/joint_states', '/ground_truth/sensor_point', '/pose']
    est = NodeSpec('irs_sensing', 'arm_pose_estimator', params={'use_sim_time': True})
    t_start = time.monotonic()
    # the rig steps when the test answers the *pose* of a step: paced by the estimator
    responder = LockstepResponder(ros, trigger='/pose', trigger_type=PoseStamped)

    def estimator_connected(status):
        # the estimator's pose reaches the responder (both directions matched, see the probe
        # below) and the recorder has subscribed to /pose, before the rig publishes step 0
        assert ros.spin_until(lambda: responder.trigger_sub.get_publisher_count() >= 1, 30.0)
        assert call_until_answered(ros, '/arm_pose_estimator/list_parameters', 30.0)
        assert ros.spin_until(lambda: status.last is not None
                              and '/pose' in status.last['messages'], 30.0), status.last

    code, out, _ = record_lockstep(ros, launch, bag, max_steps, topics, responder=responder,
                                   extra_nodes=[est], before_rig=estimator_connected,
                                   extra_topics_ready=[('/pose', max_steps - 1)])
    assert code == 0, out[-2000:]
    print(f'recording took {time.monotonic() - t_start:.1f} s')

    def key(p):
        return (p.pose.position.x, p.pose.position.y, p.pose.position.z,
                p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z,
                p.pose.orientation.w)

    with BagReader(bag) as r:
        joints = [m for m in r.messages(['/arm/joint_states'])]
        # start the replay at the last re-sent copy of step 0 (the idle time before the run,
        # waiting for the recorder, need not be replayed at 1x)
        last0 = max(m.log_time_ns for m in joints if stamp_ns(m.data) == 0)
        offset = (last0 - r.start_time_ns - 1000) / 1e9
        print(f'joint states span {(joints[-1].log_time_ns - last0) * 1e-9:.3f} s after the '
              f'start offset {offset:.3f} s')
        recorded = {}
        for m, msg in r.decoded(['/pose']):
            recorded[msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = key(msg)
    # The pose of step 0 may be published before the recorder's subscription matched, and the
    # completion check cannot see the very last pose (no count tells which stamp it is).
    assert set(recorded) >= {k * DT_NS for k in range(1, max_steps)}

    replayed = {}
    sub = ros.node.create_subscription(
        PoseStamped, '/pose_replayed',
        lambda msg: replayed.__setitem__(msg.header.stamp.sec * 10**9
                                         + msg.header.stamp.nanosec, key(msg)),
        QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                   reliability=ReliabilityPolicy.RELIABLE))
    fresh = launch(NodeSpec('irs_sensing', 'arm_pose_estimator', name='estimator_rerun',
                            params={'use_sim_time': True}, remaps={'pose': '/pose_replayed'}))
    # Our reader matched the estimator's pose writer; the estimator's side must also have
    # matched our reader, or its first poses are lost. Probe: a service call to the estimator
    # whose reply reader is created *after* the pose subscription. Endpoint discovery data of
    # one participant is processed in order, so once the estimator's reply writer reaches our
    # reply reader, its pose writer knows our pose reader as well.
    assert ros.spin_until(lambda: sub.get_publisher_count() >= 1, 30.0), fresh.tail()
    assert call_until_answered(ros, '/estimator_rerun/list_parameters', 30.0), fresh.tail()
    # The estimator's input queue holds 100 messages (0.1 s at 1 kHz): a replay on sim time at
    # 1x would need it to keep 1 kHz. At --rate 0.1 (100 joint states per second of wall time)
    # it may fall 1 s behind before losing anything; and only what it answered is compared.
    play = launch(NodeSpec('irs_bag', 'bag', name='play', args=[
        'play', bag, '--topics', '/arm/joint_states', '--clock', '--rate', '0.1',
        '--wait-for-subscribers', '1', '--start-offset', f'{max(offset, 0.0):.9f}']))
    # the player exits once the estimator acknowledged every joint state; its poses come in
    # order, so the pose of the last step closes the replay
    assert ros.spin_until(lambda: play.poll() is not None
                          and max_steps * DT_NS in replayed, 60.0 + max_steps / 100), \
        (play.output(), fresh.tail(), len(replayed),
         sorted(set(range(max_steps + 1)) - {k // DT_NS for k in replayed}))
    assert play.poll() == 0
    assert 'pacing by header stamps (sim time) (it has /clock)' in play.output()
    assert set(replayed) <= {k * DT_NS for k in range(max_steps + 1)}
    missing = set(recorded) - set(replayed)
    print(f'estimator answered {len(replayed)} of {max_steps + 1} replayed steps')
    assert len(missing) <= max_steps // 20, sorted(missing)[:20]
    for stamp in set(recorded) & set(replayed):
        pose, again = recorded[stamp], replayed[stamp]
        for a, b in zip(pose, again):
            assert (math.isnan(a) and math.isnan(b)) or abs(a - b) <= 1e-9, (stamp, pose, again)
    assert wait_until(lambda: fresh.poll() is None, 0.1)


def test_play_warns_when_a_subscriber_never_acknowledges(ros, launch, tmp_path):
    """A reliable subscriber that stops answering mid-play (its process frozen): the player
    waits at most ``--ack-timeout`` for its acknowledgements, then names the topic in one
    warning line and ends normally.
    """
    import os
    import signal

    from test_recorder import StatusWatcher, recorder_spec

    bag = timed_bag(tmp_path / 'bag', 40, 10_000_000, 10_000_000)       # 0.4 s
    status = StatusWatcher(ros)
    rec = launch(recorder_spec(tmp_path / 'rec', ['/a']))
    assert ros.spin_until(lambda: status.last is not None, 30.0), rec.tail()
    play = launch(NodeSpec('irs_bag', 'bag', name='play_unacked', args=[
        'play', bag, '--rate', '0.1', '--wait-for-subscribers', '1',      # 4 s of play
        '--ack-timeout', '1.5']))
    assert ros.spin_until(lambda: status.count('/a') >= 1 or play.poll() is not None, 60.0), \
        (play.output(), rec.tail())
    os.kill(rec.pid, signal.SIGSTOP)      # every thread of it: no acknowledgement from now on
    try:
        assert wait_until(lambda: play.poll() is not None, 60.0), play.output()
    finally:
        os.kill(rec.pid, signal.SIGCONT)
    assert play.poll() == 0, play.output()
    warned = [ln for ln in play.output().splitlines() if 'bag play: warning:' in ln]
    assert warned == ['bag play: warning: not every subscriber acknowledged every message on '
                      '/a within 1.5 s'], play.output()


def test_an_estimator_on_sim_time_answers_readings_that_come_before_any_clock(ros, launch,
                                                                              tmp_path):
    """A node on ``use_sim_time`` whose ``/clock`` has not come yet (its clock at 0) cannot
    judge a stamp's future: ``bag play`` without ``--clock`` into a fresh arm_pose_estimator
    with ``use_sim_time``, readings stamped from 5 s on, and every one is answered. Judged
    against time 0 they were all dropped as stamped ahead; the same happens to the first
    readings of a ``--clock`` replay whose lead-in reaches a starved estimator late (the test
    above).
    """
    n, t0 = 101, 5 * 10**9
    bag = arm_bag(tmp_path / 'arm', n, t0)
    answered, est = estimator_on_sim_time(ros, launch, 'estimator_no_clock', '/lateral_noclock')
    play = launch(NodeSpec('irs_bag', 'bag', name='play_no_clock', args=[
        'play', bag, '--topics', '/arm/joint_states', '--rate', '0.1',
        '--wait-for-subscribers', '1']))
    stamps = {t0 + k * DT_NS for k in range(n)}
    assert ros.spin_until(lambda: play.poll() is not None and answered >= stamps, 60.0), \
        (play.output(), est.output()[-2000:], len(answered))
    assert answered == stamps
    assert 'ahead' not in est.output(), est.tail()
