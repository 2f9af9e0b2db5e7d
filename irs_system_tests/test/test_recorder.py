"""The ``recorder`` node records a lock-step rig at 1 kHz into a valid bag, loses nothing, exits 0
on SIGINT, counts every message it really lost, and a SIGKILLed recorder leaves a bag whose
complete chunks the tools read (with a warning) and ``bag recover`` turns into a valid bag.

The rig (``vehicle_sim``, lock-step) publishes exactly one message per output topic per step
(plus re-sends of a step's outputs while nobody answers it for ``lockstep_resend_period``: step 0
before the responder starts, any step when the machine stalls the responder; the rig names them
when its run is complete); a responder in the test process
answers each step's ``ground_truth/sensor_point`` with a ``steering/command`` of the same stamp,
but only once the recorder has subscribed to everything and received step 0 on every rig topic.
Completion is read from the recorder's own ``recorder/status`` counts, not from a sleep.
"""
from collections import Counter
import json
import math
import os
import re
import signal
import subprocess

import pytest

from irs_bringup.executables import resolve_executable
from irs_bringup.processes import NodeSpec, wait_until
from irs_system_tests.output_lines import own_lines

DT_NS = 1_000_000
RIG_TOPICS = ['/clock', '/arm/joint_states', '/belt/speed', '/steering/state',
              '/ground_truth/odom', '/ground_truth/sensor_point']
CMD_TOPIC = '/steering/command'


def stamp_ns(data: bytes) -> int:
    """header.stamp (or Clock.clock) of a little-endian CDR message: int32 sec, uint32 nsec."""
    import struct
    sec, nsec = struct.unpack_from('<iI', data, 4)
    return sec * 1_000_000_000 + nsec


class StatusWatcher:
    """Subscribes ``recorder/status`` (latched JSON) on the watcher node."""

    def __init__(self, ros):
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String
        self.last = None
        ros.node.create_subscription(
            String, '/recorder/status', self._on,
            QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))

    def _on(self, msg):
        self.last = json.loads(msg.data)

    def count(self, topic):
        return 0 if self.last is None else self.last['messages'].get(topic, 0)


class LockstepResponder:
    """Answers each rig step with a steering command of the same stamp (once per stamp).

    The step is answered when ``trigger`` (a stamped topic computed from the step's outputs,
    e.g. the sensed ``/pose``) arrives, which paces the rig to the slowest node in the chain.
    A trigger received before :meth:`enable` is answered by :meth:`enable`. ``hold``: ``(step,
    copies)``, leave that step unanswered until its trigger has come ``copies`` times (the rig
    re-sends a step's outputs after ``lockstep_resend_period`` without an answer).
    """

    def __init__(self, ros, amplitude=0.05, trigger='/ground_truth/sensor_point',
                 trigger_type=None, hold=None):
        from geometry_msgs.msg import PointStamped
        from rosgraph_msgs.msg import Clock

        from irs_common import qos
        from irs_msgs.msg import SteeringCommand
        self.SteeringCommand = SteeringCommand
        self.enabled = False
        self.answered = -1
        self.pending = None
        self.clock_ns = -1
        self.amplitude = amplitude
        self.hold_ns, self.hold_copies = (hold[0] * DT_NS, hold[1]) if hold else (None, 0)
        self.held = 0
        self.pub = ros.node.create_publisher(SteeringCommand, CMD_TOPIC, qos.COMMAND_PUB)
        self.trigger_sub = ros.node.create_subscription(
            trigger_type or PointStamped, trigger, self._on_trigger, qos.SENSOR)
        ros.node.create_subscription(Clock, '/clock', self._on_clock, qos.CLOCK)

    def _on_clock(self, msg):
        self.clock_ns = max(self.clock_ns, msg.clock.sec * 10**9 + msg.clock.nanosec)

    def _on_trigger(self, msg):
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if not self.enabled:
            self.pending = stamp if self.pending is None else max(self.pending, stamp)
            return
        if stamp == self.hold_ns and self.held < self.hold_copies - 1:
            self.held += 1
            return
        self._answer(stamp)

    def enable(self):
        self.enabled = True
        if self.pending is not None:
            self._answer(self.pending)

    def _answer(self, stamp):
        if stamp <= self.answered:
            return
        self.answered = stamp
        cmd = self.SteeringCommand()
        cmd.header.stamp.sec, cmd.header.stamp.nanosec = divmod(stamp, 10**9)
        cmd.front_angle = self.amplitude * math.sin(2 * math.pi * stamp * 1e-9)
        self.pub.publish(cmd)


def rig_spec(max_steps, **extra):
    return NodeSpec('irs_vehicle_sim', 'vehicle_sim', params={
        'clock_mode': 'lockstep', 'max_steps': max_steps, 'lockstep_resend_period': 0.3,
        **extra})


def recorder_spec(out, topics, **params):
    return NodeSpec('irs_bag', 'recorder', params={
        'topics': topics, 'output': str(out), 'status_period': 0.1, **params})


def record_lockstep(ros, launch, bag, max_steps, topics, responder=None, extra_nodes=(),
                    extra_topics_ready=(), extra_topics_started=(), metadata=None,
                    before_rig=None, freeze_steps=0, rig_output=None):
    """Start recorder + rig, run ``max_steps`` lock-step steps, stop the recorder (SIGINT).

    ``extra_topics_ready``: further (topic, minimal count) the recorder must have before the
    run counts as complete; ``extra_topics_started``: topics that must have a first message
    before the responder starts answering; ``extra_nodes`` start before the rig, and
    ``before_rig(status)`` (if given) runs before the rig starts. ``freeze_steps``: the recorder
    is frozen (SIGSTOP, a recorder starved of CPU) from the first answered step until the rig
    has run that many steps further. Every node started here is stopped before returning; the
    rig's output is appended to the list ``rig_output`` if one is given.
    Returns (exit code, recorder output, final status).
    """
    status = StatusWatcher(ros)
    responder = responder or LockstepResponder(ros)
    # a JSON string as a YAML single-quoted scalar, so that -p does not parse it as a mapping
    # NodeSpec passes params through a YAML params file, so a JSON text stays a string
    rec = launch(recorder_spec(bag, topics, metadata=json.dumps(metadata or {})))
    others = [launch(spec) for spec in extra_nodes]
    if before_rig is not None:
        before_rig(status)
    rig = launch(rig_spec(max_steps))
    rig_topics = [t for t in topics if t in RIG_TOPICS]
    # The recorder has subscribed to everything and the rig's step-0 outputs (re-sent every
    # 0.3 s while nobody answers) reached it on every rig topic.
    need_cmd_subs = 2 if CMD_TOPIC in topics else 1   # the rig (+ the recorder)
    ros.spin_until(
        lambda: rec.poll() is not None or rig.poll() is not None
        or (all(status.count(t) >= 1 for t in [*rig_topics, *extra_topics_started])
            and responder.pub.get_subscription_count() >= need_cmd_subs), 30.0)
    assert rec.poll() is None and rig.poll() is None and all(
        status.count(t) >= 1 for t in [*rig_topics, *extra_topics_started]), \
        f'recorder not ready: {status.last}\n{rec.tail()}\n{rig.tail()}'
    last = max_steps * DT_NS
    if freeze_steps:
        os.killpg(rec.pid, signal.SIGSTOP)
        try:
            responder.enable()
            frozen_from = max(responder.clock_ns, 0)
            assert ros.spin_until(lambda: responder.clock_ns >= frozen_from + freeze_steps * DT_NS
                                  or rig.poll() is not None, 60.0), responder.clock_ns
        finally:
            os.killpg(rec.pid, signal.SIGCONT)
    else:
        responder.enable()
    # The counts include step 0's re-sent copies, so they can be reached before the last step:
    # the run is complete once the rig has published step max_steps (its /clock comes first,
    # the outputs in the same callback; the recorder's final drain on stop takes what is still
    # in flight) and the recorder has at least one message per step on every topic.
    done = ros.spin_until(
        lambda: (responder.clock_ns >= last
                 and all(status.count(t) >= max_steps + 1 for t in rig_topics)
                 and (CMD_TOPIC not in topics or status.count(CMD_TOPIC) >= max_steps + 1)
                 and all(status.count(t) >= n for t, n in extra_topics_ready)),
        90.0)
    assert done, (f'run did not complete: clock {responder.clock_ns} / {last}, status '
                  f'{status.last}\n{rig.tail()}')
    code = rec.stop(timeout=15.0)
    for proc in [rig, *others]:   # the graph is gone when this returns
        proc.stop(timeout=15.0)
    if rig_output is not None:
        rig_output.append(rig.output())
    return code, rec.output(), status.last


def rig_resends(rig_output: str) -> dict:
    """``{step: times}`` the lock-step rig published a step's outputs again (its ``run
    complete`` line): it does so after ``lockstep_resend_period`` s without an answer.
    """
    done = re.search(r'run complete: .*', rig_output)
    assert done, rig_output[-2000:]
    listed = re.search(r'outputs re-sent while no commands came \(step: times\) (.*)', done[0])
    return {int(k): int(n) for k, n in
            (item.split(': ') for item in listed[1].split(', '))} if listed else {}


def test_recorder_lockstep_1khz_no_loss(ros, launch, tmp_path):
    from rosbags.rosbag2 import Reader

    from irs_bag import BagReader, validate

    max_steps = 1500
    bag = tmp_path / 'bag'
    topics = RIG_TOPICS + [CMD_TOPIC]
    meta = {'experiment': 'tests/test_recorder.py', 'git_commit': 'abc123'}
    # frozen for 500 steps: more than a 100-deep writer history holds, less than PUBLISHER_HISTORY
    rig_output = []
    # step 700 is answered only when the rig has published it three times: twice re-sent
    responder = LockstepResponder(ros, hold=(700, 3))
    code, out, status = record_lockstep(ros, launch, bag, max_steps, topics, metadata=meta,
                                        freeze_steps=500, rig_output=rig_output,
                                        responder=responder)
    resends = rig_resends(rig_output[0])
    assert resends.get(700) == 2, rig_output[0][-2000:]
    assert code == 0, out[-3000:]
    assert 'Traceback' not in out, out[-3000:]
    summary = [ln for ln in out.splitlines() if ln.startswith('recorder: closed')]
    assert summary and 'dropped: 0' in summary[-1], out[-2000:]

    rep = validate(bag)
    assert rep.ok, rep.problems
    with BagReader(bag) as r:
        assert set(r.topics) == set(topics)
        by_topic = {t: [] for t in topics}
        for m in r.messages():
            by_topic[m.topic].append(m)
        custom = r.bag_metadata['custom_data']
        assert custom['irs.dropped_messages'] == '0'
        recs = dict(r.metadata_records())
        assert recs['irs_experiment']['experiment'] == 'tests/test_recorder.py'
        assert recs['irs_experiment']['git_commit'] == 'abc123'
    for t in RIG_TOPICS:
        msgs = by_topic[t]
        stamps = [stamp_ns(m.data) for m in msgs]
        # every step 0..max_steps, once and once more for each time the rig re-sent it (a
        # stall of the responder longer than the resend period, which a loaded machine makes):
        # nothing lost, nothing doubled. Step 0 is re-sent before the recorder has matched
        # every topic, so some of its copies may come before the recording does.
        assert sorted(set(stamps)) == [k * DT_NS for k in range(max_steps + 1)], t
        counts = Counter(stamps)
        assert 1 <= counts[0] <= 1 + resends.get(0, 0), (t, counts[0], resends)
        assert {s // DT_NS: n - 1 for s, n in counts.items() if s and n > 1} == \
            {k: n for k, n in resends.items() if k}, t
        for k in {0, *resends}:        # a re-sent step is the same message again
            copies = [m.data for m in msgs if stamp_ns(m.data) == k * DT_NS]
            assert all(d == copies[0] for d in copies), f'{t}: re-sent step {k} differs'
        assert stamps[counts[0]:] == sorted(stamps[counts[0]:]), t
        assert len(msgs) == status['messages'][t]
    cmd_stamps = [stamp_ns(m.data) for m in by_topic[CMD_TOPIC]]
    # the responder answers every step, the last one (max_steps) included
    assert cmd_stamps == [k * DT_NS for k in range(max_steps + 1)]

    with Reader(bag) as rb:
        assert {c.topic for c in rb.connections} == set(topics)
        assert rb.message_count == sum(len(v) for v in by_topic.values())


def file_order_log_times(bag) -> list:
    """Log times [ns] of the messages of a bag's MCAP file in file order, as far as it reads
    (a killed recorder's file ends inside a record).
    """
    import struct

    from mcap.exceptions import McapError
    from mcap.reader import NonSeekingReader
    times = []
    with open(next(bag.glob('*.mcap')), 'rb') as f:
        try:
            for _, _, message in NonSeekingReader(f).iter_messages(log_time_order=False):
                times.append(message.log_time)
        except (McapError, EOFError, ValueError, struct.error):
            pass
    return times


def test_recorder_sigkill_leaves_recoverable_prefix(ros, launch, tmp_path):
    from irs_bag import BagReader, BagError, recover, validate

    bag = tmp_path / 'killed'
    status = StatusWatcher(ros)
    launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                    params={'clock_mode': 'realtime', 'max_steps': 20000}))
    rec = launch(recorder_spec(bag, ['/arm/joint_states', '/belt/speed'], flush_period=0.2))
    assert ros.spin_until(lambda: status.last is not None and status.last['chunks'] >= 2
                          and status.count('/arm/joint_states') > 200, 30.0), rec.tail()
    # the chunks a status reports are in the file (flushed): all of them must come back
    flushed = status.last['chunks']
    os.killpg(rec.pid, signal.SIGKILL)
    assert wait_until(lambda: rec.poll() is not None, 10.0)
    assert rec.poll() == -signal.SIGKILL

    with pytest.raises(BagError, match='recover'):
        BagReader(bag)
    got = recover(bag)
    assert not got.complete and got.chunks >= flushed >= 2, (got.chunks, flushed)
    # every recovered chunk holds messages; which ones, an independent reader says below
    assert len(got) >= got.chunks and {m.topic for m in got} <= {'/arm/joint_states',
                                                                   '/belt/speed'}
    assert any(name == 'irs_experiment' for name, _ in got.metadata)

    # rosbags opens it (provisional metadata.yaml, provisional footer) and reads those chunks
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError
    with Reader(bag) as rb:
        assert {c.topic for c in rb.connections} <= {'/arm/joint_states', '/belt/speed'}
        try:
            # in file order; chunks may overlap in time (late messages), recover() sorts by time
            in_order = sorted(((t, data) for _, t, data in rb.messages()), key=lambda x: x[0])
        except ReaderError as exc:
            # rosbags reads a file without an index only when its messages are in time order;
            # a message the recorder took late is in a later chunk (docs/recording.md)
            assert 'not in timestamp order' in str(exc), exc
            times = file_order_log_times(bag)
            assert any(b < a for a, b in zip(times, times[1:])), 'rosbags refused a bag in order'
        else:
            assert [data for _, data in in_order] == [m.data for m in got]

    bag_exe = resolve_executable('irs_bag', 'bag')
    for cmd in (['info'], ['plots', '--out', str(tmp_path / 'plots')],
                ['export', '--out', str(tmp_path / 'csv')]):
        res = subprocess.run([bag_exe, *cmd[:1], str(bag), *cmd[1:]], capture_output=True,
                             text=True, timeout=60)
        assert res.returncode == 0, (cmd, res.stdout, res.stderr)
        assert 'Traceback' not in res.stderr + res.stdout
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and 'warning' in lines[0] and 'unfinished' in lines[0], lines
    res = subprocess.run([bag_exe, 'validate', str(bag)], capture_output=True, text=True,
                         timeout=60)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 1 and len(lines) == 1, (res.stdout, res.stderr)
    assert 'unfinished' in lines[0] and '`bag recover`' in lines[0], lines
    res = subprocess.run([bag_exe, 'info', str(bag)], capture_output=True, text=True, timeout=60)
    assert f'Messages:     {len(got)}' in res.stdout, res.stdout
    res = subprocess.run([bag_exe, 'recover', str(bag), '--out', str(tmp_path / 'fixed')],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and len(res.stdout.strip().splitlines()) == 1, res
    assert f'{len(got)} messages' in res.stdout, res.stdout
    rep = validate(tmp_path / 'fixed')
    assert rep.ok and rep.complete and rep.message_count == len(got), rep.problems
    with BagReader(tmp_path / 'fixed') as r:
        assert [m.data for m in r.messages()] == [m.data for m in got]


def flood_a_frozen_recorder(ros, launch, bag, topic, pub_qos, frozen, **rec_params):
    """Record ``topic`` (Int64 0, 1, 2, ...); once the recorder has taken a message, freeze it
    (SIGSTOP) while ``frozen`` messages are published, thaw it, publish 20 more, and wait until
    every message after the warm-up is recorded or counted as dropped. Returns the recorder,
    the values in the bag, the bag's custom metadata, how many were published in all, and the
    last warm-up message (the recorder may have missed the ones before it).
    """
    from std_msgs.msg import Int64

    from irs_bag.reader import BagReader

    status = StatusWatcher(ros)
    rec = launch(recorder_spec(bag, [topic], flush_period=0.2, **rec_params))
    pub = ros.node.create_publisher(Int64, topic, pub_qos)
    sent = 0

    def publish(n):
        nonlocal sent
        for _ in range(n):
            pub.publish(Int64(data=sent))
            sent += 1

    # warm up until the recorder has taken a message (its sequence bookkeeping is running)
    while not ros.spin_until(lambda: status.count(topic) >= 1, 0.2):
        assert sent < 500 and rec.poll() is None, rec.tail()
        publish(1)
    first_kept = sent - 1            # at most the messages before this one may be unmatched
    os.killpg(rec.pid, signal.SIGSTOP)
    try:
        publish(frozen)              # nobody takes them while the recorder is frozen
    finally:
        os.killpg(rec.pid, signal.SIGCONT)
    publish(20)
    total = sent
    # every message after the warm-up is either recorded or counted as dropped
    assert ros.spin_until(
        lambda: status.last is not None and status.count(topic)
        + status.last['dropped'].get(topic, 0) >= total - first_kept, 60.0), \
        (f'{status.last}; published {total}, from {first_kept} on; the publisher matched '
         f'{pub.get_subscription_count()} subscription(s)\nrecorder: {rec.tail(30)}')
    assert rec.stop(timeout=15.0) == 0, rec.tail()
    with BagReader(bag) as r:
        values = [m.data for _, m in r.decoded([topic])]
        custom = dict(r.bag_metadata['custom_data'])
    return rec, values, custom, total, first_kept


def test_recorder_counts_a_real_loss(ros, launch, tmp_path):
    """The recorder is stopped (SIGSTOP) while a publisher floods its topic (KEEP_LAST 10 on
    both sides): messages are really lost. After SIGCONT the bag's drop count equals what was
    published minus what was recorded, and the recorded values are exactly the ones it kept.
    """
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    rec, values, custom, total, _ = flood_a_frozen_recorder(
        ros, launch, tmp_path / 'lossy', '/flood', QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE),
        5000, qos_depth=10)          # the 10-deep queues overflow
    dropped = json.loads(custom['irs.dropped_messages_per_topic'])
    assert values == sorted(values) and values[-1] == total - 1, values[-5:]
    published = total - values[0]     # published from the first recorded message on
    lost = published - len(values)
    print(f'published {published}, recorded {len(values)}, lost {lost}, reported {dropped}')
    assert lost > 1000, 'the flood must really lose messages'
    assert dropped == {'/flood': lost}
    assert f'dropped: {lost}' in rec.output()


def test_recorder_bad_output_is_a_configuration_error(tmp_path):
    existing = tmp_path / 'full'
    existing.mkdir()
    (existing / 'x').write_text('x')
    res = subprocess.run([resolve_executable('irs_bag', 'recorder'), '--ros-args',
                          '-p', f'output:={existing}'], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2, res.stderr
    assert 'not empty' in res.stderr and 'Traceback' not in res.stderr


def test_lockstep_experiments_record_clock():
    """/clock (published by the lock-step rig, recorded by the tests above) is in the record
    list of every lock-step experiment, so `bag play` paces their bags by sim time; the
    runner waits for the recorder's /clock subscription before step 0.
    """
    from irs_bringup.experiment import expected_endpoints, load_experiment
    for name in ('figure10_mrc_with_actuator', 'figure10_mrc_without_actuator', 'figure10_pi',
                 'treadmill_regulation'):
        exp = load_experiment(name)
        assert exp.clock == 'lockstep' and '/clock' in exp.record_topics, name
        non_rig = sum(1 for e in exp.nodes if e.key != ('irs_vehicle_sim', 'vehicle_sim'))
        assert expected_endpoints(exp)['/clock'] == (1, non_rig + 1), name


@pytest.mark.parametrize('case', ['under a file', 'in /proc', 'name too long'])
def test_an_output_it_cannot_create_is_one_line_at_start_up(tmp_path, case):
    """Before any topic appears: an output under a file, in /proc (mkdir fails) or with a name
    longer than the file system takes is refused at once, in one line, exit code 2.
    """
    blocker = tmp_path / 'a_file'
    blocker.write_text('not a directory')
    output = {'under a file': f'{blocker}/bag', 'in /proc': '/proc/irs_bag',
              'name too long': str(tmp_path / ('x' * 300))}[case]
    exe = resolve_executable('irs_bag', 'recorder')
    res = subprocess.run([exe, '--ros-args', '-p', f'output:={output}', '-p',
                          "topics:=['/nothing/ever']"], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2, res.stdout + res.stderr
    lines = own_lines(res.stderr)        # (Fast DDS may log a transport problem of its own)
    assert len(lines) == 1 and 'cannot create the bag directory' in lines[0], res.stderr
    assert 'Traceback' not in res.stderr + res.stdout


def test_a_recorder_started_by_hand_writes_under_runs(tmp_path):
    """Without ``output`` the bag goes to runs/bags/irs_bag_<date> under the working
    directory, never into its root; its provisional metadata.yaml is there from the start, and
    SIGINT closes it (exit code 0).
    """
    from irs_bag import validate

    exe = resolve_executable('irs_bag', 'recorder')
    proc = subprocess.Popen([exe, '--ros-args', '-p', "topics:=['/nothing/ever']"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    try:
        assert wait_until(lambda: list(tmp_path.glob('runs/bags/irs_bag_*/metadata.yaml')),
                          30.0), 'no provisional metadata.yaml'
    finally:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
    assert [p.name for p in tmp_path.iterdir()] == ['runs'], list(tmp_path.iterdir())
    [bag] = tmp_path.glob('runs/bags/irs_bag_*')
    assert f'recorder: closed {bag.relative_to(tmp_path)}: 0 messages' in out, out
    assert validate(bag).ok


def test_a_frozen_recorder_loses_nothing_the_publishers_history_still_holds(ros, launch,
                                                                            tmp_path):
    """A recorder starved of CPU (here frozen with SIGSTOP) catches up without loss as long as
    the publishers still hold what it missed: the IRS publisher profile keeps
    ``PUBLISHER_HISTORY`` samples (5 s at 1 kHz) and the recorder subscribes as deep. 3000
    messages (3 s of a 1 kHz stream) published while it is frozen are all in the bag, and no
    loss is reported. With the old 100-deep publisher profile this test fails: the writer can
    no longer repair what the frozen recorder missed.
    """
    from irs_common import qos

    assert qos.PUBLISHER_HISTORY >= 3000
    _, values, custom, total, first_kept = flood_a_frozen_recorder(
        ros, launch, tmp_path / 'frozen', '/stream', qos.SENSOR_PUB, 3000)
    assert values == list(range(values[0], total)), (len(values), values[:3], values[-3:])
    assert values[0] <= first_kept
    assert custom.get('irs.dropped_messages') == '0', custom


@pytest.mark.parametrize('status_profile', ['STATUS_PUB', 'STATUS'])
def test_a_frozen_recorder_keeps_every_status_published_between_a_sensor_flood(
        ros, launch, tmp_path, status_profile):
    """The transitions of a status topic reach a recorder that is short of CPU, beside a 1 kHz
    stream. While the recorder is frozen (SIGSTOP), 3000 messages of a sensor stream fill its
    shared-memory port, and a status topic publishes one message every 100 of them (as the
    rig publishes ``HOLDING`` and then ``STOPPING`` within a burst of 1 kHz telemetry). The
    port overflows; what it lost is repaired from the publishers' histories. The status
    publishers' profile ``qos.STATUS_PUB`` keeps 100, so every status is in the bag. With a
    history of 1 (``qos.STATUS``, the subscribers' profile) only the last survives and the
    recorder reports the others lost: the second case shows that the first can fail.
    """
    from std_msgs.msg import Int64

    from irs_bag.reader import BagReader
    from irs_common import qos

    status_qos = getattr(qos, status_profile)
    bag = tmp_path / 'bag'
    watcher = StatusWatcher(ros)
    rec = launch(recorder_spec(bag, ['/stream', '/some/status'], flush_period=0.2))
    stream = ros.node.create_publisher(Int64, '/stream', qos.SENSOR_PUB)
    status = ros.node.create_publisher(Int64, '/some/status', status_qos)
    sent = {'/stream': 0, '/some/status': 0}

    def publish(pub, topic):
        pub.publish(Int64(data=sent[topic]))
        sent[topic] += 1

    # warm up until the recorder has taken a message of each (its sequence bookkeeping runs)
    while not ros.spin_until(lambda: watcher.count('/stream') >= 1
                             and watcher.count('/some/status') >= 1, 0.2):
        assert sent['/stream'] < 500 and rec.poll() is None, rec.tail()
        publish(stream, '/stream')
        publish(status, '/some/status')
    first_status = sent['/some/status']
    os.killpg(rec.pid, signal.SIGSTOP)
    try:
        for i in range(3000):
            publish(stream, '/stream')
            if i % 100 == 0:
                publish(status, '/some/status')
    finally:
        os.killpg(rec.pid, signal.SIGCONT)
    # every status from the last warm-up one on is recorded or counted as dropped
    assert ros.spin_until(
        lambda: watcher.last is not None and watcher.count('/some/status')
        + watcher.last['dropped'].get('/some/status', 0)
        >= sent['/some/status'] - first_status + 1, 60.0), watcher.last
    assert rec.stop(timeout=15.0) == 0, rec.tail()
    with BagReader(bag) as r:
        values = [m.data for _, m in r.decoded(['/some/status'])]
        dropped = json.loads(dict(r.bag_metadata['custom_data'])
                             ['irs.dropped_messages_per_topic'])
    burst = [v for v in values if v >= first_status]
    print(f'{status_profile}: {len(burst)} of 30 statuses recorded, dropped {dropped}')
    if status_profile == 'STATUS_PUB':
        assert burst == list(range(first_status, first_status + 30)), burst
        assert dropped.get('/some/status', 0) == 0, dropped
    else:
        assert len(burst) < 30, burst
    # what is missing since the first recorded status is what the recorder reports lost
    assert dropped.get('/some/status', 0) == sent['/some/status'] - values[0] - len(values), \
        (values, dropped)


def test_a_recorder_started_by_hand_writes_the_parameters_of_the_nodes_beside_it(launch,
                                                                                  tmp_path):
    """A recorder started by hand beside a lateral controller started with its file (PI mode,
    as ``-p`` gives it) asks it for its parameters: the bag has them as a metadata record, and
    the plots' title names the controller from them.
    """
    from pathlib import Path

    from ament_index_python.packages import get_package_share_directory
    import yaml

    from irs_bag import BagReader, validate
    from irs_bag.node_parameters import node_parameters_from_records
    from irs_bag.run_info import run_info

    config = Path(get_package_share_directory('irs_control')) / 'config' / \
        'lateral_controller.yaml'
    file_params = yaml.safe_load(config.read_text())['lateral_controller']['ros__parameters']
    ctrl = launch(NodeSpec('irs_control', 'lateral_controller', params_files=[config],
                           params={'mode': 'pi'}))
    bag = tmp_path / 'bag'
    rec = launch(recorder_spec(bag, ['/lateral/status']))
    assert wait_until(lambda: '/lateral_controller: its' in rec.output(), 60.0), \
        rec.tail() + '\n' + ctrl.tail()
    assert rec.stop() == 0, rec.tail()
    assert validate(bag).ok
    with BagReader(bag) as reader:
        params = node_parameters_from_records(reader.metadata_records())
        info = run_info(reader)
    ctrl_params = params['lateral_controller']
    assert ctrl_params['mode'] == 'pi'
    assert ctrl_params['kp'] == file_params['kp'] and ctrl_params['ki'] == file_params['ki']
    assert ctrl_params['reference_model_den'] == file_params['reference_model_den']
    assert info.controller == f"PI (kp {file_params['kp']:g}, ki {file_params['ki']:g})"
