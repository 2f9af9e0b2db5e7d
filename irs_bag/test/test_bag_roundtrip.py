"""Write real CDR messages with BagWriter, read them back with mcap, rosbags and BagReader."""

import sys


import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_typestore

from irs_bag import BagError, BagReader, validate
from irs_bag.reader import deserialize, read_messages
from irs_bag.writer import BagWriter, BagWriterError, qos_profiles_yaml
from irs_bag.msg_definitions import get_message_definition, type_description_hash

TS = get_typestore(Stores.ROS2_JAZZY)
T0 = 1_750_000_000_000_000_000  # ns
JS, POSE = 'sensor_msgs/msg/JointState', 'geometry_msgs/msg/PoseStamped'
TWIST = 'geometry_msgs/msg/TwistStamped'


def _stamp(t):
    return TS.types['builtin_interfaces/msg/Time'](sec=t // 10**9, nanosec=t % 10**9)


def _header(t, frame):
    return TS.types['std_msgs/msg/Header'](stamp=_stamp(t), frame_id=frame)


def make_joint_state(i, t):
    rng = np.random.default_rng(i)
    return TS.types[JS](header=_header(t, 'arm'), name=['theta1', 'theta2', 'theta3'],
                        position=rng.normal(size=3), velocity=rng.normal(size=3),
                        effort=np.zeros(0, dtype=np.float64))


def make_pose(i, t):
    rng = np.random.default_rng(10_000 + i)
    g = TS.types
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return g[POSE](header=_header(t, 'treadmill'), pose=g['geometry_msgs/msg/Pose'](
        position=g['geometry_msgs/msg/Point'](x=float(rng.normal()), y=float(rng.normal()),
                                             z=0.0),
        orientation=g['geometry_msgs/msg/Quaternion'](x=q[0], y=q[1], z=q[2], w=q[3])))


def make_twist(i, t):
    g = TS.types
    v = g['geometry_msgs/msg/Vector3']
    return g[TWIST](header=_header(t, 'car'), twist=g['geometry_msgs/msg/Twist'](
        linear=v(x=0.01 * i, y=0.0, z=0.0), angular=v(x=0.0, y=0.0, z=-0.001 * i)))


def generate(n_ms=1500):
    """1 kHz joint states, 500 Hz poses, 100 Hz twists: list of (topic, type, t, bytes, msg)."""
    out = []
    for k in range(n_ms):
        t = T0 + k * 1_000_000 + 1234
        m = make_joint_state(k, t)
        out.append(('/arm/joint_states', JS, t, bytes(TS.serialize_cdr(m, JS)), m))
        if k % 2 == 0:
            m = make_pose(k, t)
            out.append(('/car/pose', POSE, t, bytes(TS.serialize_cdr(m, POSE)), m))
        if k % 10 == 0:
            m = make_twist(k, t)
            out.append(('/car/twist', TWIST, t, bytes(TS.serialize_cdr(m, TWIST)), m))
    return out


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    msgs = generate()
    bag = tmp_path_factory.mktemp('rt') / 'run1'
    qos = qos_profiles_yaml(reliability='best_effort', depth=5)
    with BagWriter(bag, chunk_size=16 * 1024) as w:
        w.add_topic('/car/pose', POSE, offered_qos_profiles=qos)
        w.add_metadata('experiment', {'file': 'experiments/lane_change.yaml', 'name': 'lc1'})
        w.add_metadata('versions', {'git_commit': 'abc123', 'irs_bringup': '0.0.1'})
        for topic, typ, t, data, _ in msgs:
            w.write(topic, typ, data, t, publish_time_ns=t - 500)
        w.record_drop('/arm/joint_states', 4)
        w.record_drop('/never/declared', 2)
        summary = w.close()
    return bag, msgs, summary


def test_layout_and_summary(recorded):
    bag, msgs, summary = recorded
    assert sorted(p.name for p in bag.iterdir()) == ['metadata.yaml', 'run1_0.mcap']
    assert summary.message_count == len(msgs)
    assert summary.topics['/arm/joint_states'].message_count == 1500
    assert summary.topics['/car/pose'].message_count == 750
    assert summary.topics['/car/twist'].message_count == 150
    assert summary.topics['/arm/joint_states'].dropped == 4
    assert summary.topics['/never/declared'].dropped == 2
    assert summary.dropped_total == 6
    assert summary.late_messages == 0
    assert summary.chunk_count > 20
    assert summary.start_time_ns == msgs[0][2] and summary.end_time_ns == msgs[-1][2]
    assert summary.closed


def test_mcap_library_reads_with_crc_validation(recorded):
    bag, msgs, summary = recorded
    path = bag / 'run1_0.mcap'
    with open(path, 'rb') as f:
        r = make_reader(f, validate_crcs=True)
        header = r.get_header()
        assert header.profile == 'ros2'
        s = r.get_summary()
        assert s.statistics.message_count == len(msgs)
        assert s.statistics.chunk_count == summary.chunk_count == len(s.chunk_indexes)
        assert all(ci.compression == 'zstd' for ci in s.chunk_indexes)
        assert all(ci.message_index_offsets for ci in s.chunk_indexes)
        schemas = {sc.name: sc for sc in s.schemas.values()}
        assert set(schemas) == {JS, POSE, TWIST}
        for name, sc in schemas.items():
            assert sc.encoding == 'ros2msg'
            assert sc.data.decode() == get_message_definition(name)
        chans = {c.topic: c for c in s.channels.values()}
        assert all(c.message_encoding == 'cdr' for c in chans.values())
        assert chans['/car/pose'].metadata['offered_qos_profiles'] == qos_profiles_yaml(
            reliability='best_effort', depth=5)
        assert chans['/car/twist'].metadata['offered_qos_profiles'] == ''
        assert chans['/arm/joint_states'].metadata['topic_type_hash'] == \
            type_description_hash(JS)
        got = [(c.topic, m.log_time, m.publish_time, m.data)
               for _, c, m in r.iter_messages(log_time_order=True)]
        names = [m.name for m in r.iter_metadata()]
    # byte-identical, same order (log time, then write order)
    assert got == [(tp, t, t - 500, d) for tp, _, t, d, _ in msgs]
    assert names == ['experiment', 'versions', 'rosbag2']
    # sequential read checks every chunk CRC and the data-section CRC; all CRCs are present
    with open(path, 'rb') as f:
        recs = list(StreamReader(f, validate_crcs=True, emit_chunks=True).records)
    kinds = {}
    for rec in recs:
        kinds.setdefault(type(rec).__name__, []).append(rec)
    assert all(c.uncompressed_crc != 0 for c in kinds['Chunk'])
    assert kinds['DataEnd'][0].data_section_crc != 0
    assert kinds['Footer'][0].summary_crc != 0
    with open(path, 'rb') as f:
        n = sum(1 for rec in StreamReader(f, validate_crcs=True).records
                if type(rec).__name__ == 'Message')
    assert n == len(msgs)


def test_mcap_ros2_decoder_decodes_our_schemas(recorded):
    bag, msgs, _ = recorded
    with open(bag / 'run1_0.mcap', 'rb') as f:
        r = make_reader(f, decoder_factories=[DecoderFactory()])
        for (_, _, _, dec), (topic, typ, t, _, orig) in zip(
                r.iter_decoded_messages(log_time_order=True), msgs):
            if typ == JS:
                assert list(dec.position) == list(orig.position)
                assert dec.header.stamp.nanosec == orig.header.stamp.nanosec
            elif typ == POSE:
                assert dec.pose.orientation.w == orig.pose.orientation.w


def test_metadata_yaml(recorded):
    bag, msgs, _ = recorded
    doc = yaml.safe_load((bag / 'metadata.yaml').read_text())
    info = doc['rosbag2_bagfile_information']
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['ros_distro'] == 'jazzy'
    assert info['message_count'] == len(msgs)
    assert info['starting_time']['nanoseconds_since_epoch'] == msgs[0][2]
    assert info['duration']['nanoseconds'] == msgs[-1][2] - msgs[0][2]
    assert info['compression_format'] == '' and info['compression_mode'] == ''
    assert info['relative_file_paths'] == ['run1_0.mcap']
    assert info['files'] == [{'path': 'run1_0.mcap',
                              'starting_time': {'nanoseconds_since_epoch': msgs[0][2]},
                              'duration': {'nanoseconds': msgs[-1][2] - msgs[0][2]},
                              'message_count': len(msgs)}]
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == {'/arm/joint_states', '/car/pose', '/car/twist'}
    assert topics['/car/pose']['message_count'] == 750
    tm = topics['/arm/joint_states']['topic_metadata']
    assert tm['type'] == JS and tm['serialization_format'] == 'cdr'
    assert tm['offered_qos_profiles'] == []  # v9: a YAML list, empty when unknown
    pose_qos = topics['/car/pose']['topic_metadata']['offered_qos_profiles']
    assert [(q['reliability'], q['depth'], q['history']) for q in pose_qos] == [
        ('best_effort', 5, 'keep_last')]
    assert tm['type_description_hash'] == get_typestore(Stores.ROS2_JAZZY).hash_rihs01(JS)
    custom = info['custom_data']
    assert custom['irs.dropped_messages'] == '6'
    assert json.loads(custom['irs.dropped_messages_per_topic']) == {
        '/arm/joint_states': 4, '/never/declared': 2}
    # same metadata embedded as the 'rosbag2' MCAP metadata record, as rosbag2 does
    with BagReader(bag) as r:
        rec = dict(r.metadata_records())['rosbag2']
    assert yaml.safe_load(rec['serialized_metadata']) == info


def test_rosbags_reader_opens_bag(recorded):
    bag, msgs, _ = recorded
    with RosbagsReader(bag) as r:
        assert r.message_count == len(msgs)
        conns = {c.topic: c for c in r.connections}
        assert conns['/car/pose'].msgtype == POSE
        assert conns['/car/pose'].msgdef.data == get_message_definition(POSE)
        assert conns['/car/pose'].ext.offered_qos_profiles[0].depth == 5
        assert conns['/arm/joint_states'].digest == type_description_hash(JS)
        got = [(c.topic, t, bytes(raw)) for c, t, raw in r.messages()]
    assert got == [(tp, t, d) for tp, _, t, d, _ in msgs]


def test_rosbags_anyreader_uses_embedded_definitions(recorded):
    """AnyReader builds its types from the definitions stored in the bag (empty default
    store), deserializes every message equal to the original, and its RIHS01 hashes of those
    types equal rosbags' built-in Jazzy hashes.
    """
    bag, msgs, _ = recorded
    with AnyReader([bag], default_typestore=get_typestore(Stores.EMPTY)) as r:
        jazzy = get_typestore(Stores.ROS2_JAZZY)
        for typ in (JS, POSE, TWIST):
            assert r.typestore.hash_rihs01(typ) == jazzy.hash_rihs01(typ)
        it = iter(msgs)
        n = 0
        for conn, t, raw in r.messages():
            topic, typ, t0, data, orig = next(it)
            assert (conn.topic, t) == (topic, t0)
            dec = r.deserialize(raw, conn.msgtype)
            assert bytes(jazzy.serialize_cdr(dec, typ)) == data
            n += 1
    assert n == len(msgs)


def test_bag_reader_iteration_and_filter(recorded):
    bag, msgs, _ = recorded
    with BagReader(bag) as r:
        assert r.message_count == len(msgs)
        assert r.profile == 'ros2'
        topics = r.topics
        assert topics['/car/twist'].message_count == 150
        assert topics['/arm/joint_states'].rate_hz == pytest.approx(1000.0)
        assert topics['/car/pose'].rate_hz == pytest.approx(500.0)
        assert topics['/car/twist'].rate_hz == pytest.approx(100.0)
        got = list(r.messages(topics=['/car/pose', '/car/twist']))
        assert [(m.topic, m.type, m.log_time_ns, m.data) for m in got] == [
            (tp, ty, t, d) for tp, ty, t, d, _ in msgs if tp != '/arm/joint_states']
        m, dec = next(r.decoded('/car/pose'))
        orig = msgs[1][4]
        assert dec.pose.position.x == orig.pose.position.x
        assert dec.header.frame_id == 'treadmill'
    # a single .mcap file also works, and read_messages is the one-liner
    assert sum(1 for _ in read_messages(bag / 'run1_0.mcap', '/car/twist')) == 150


def test_validate_ok(recorded):
    bag, msgs, _ = recorded
    rep = validate(bag, strict=True)
    assert rep.ok and rep.problems == []
    assert rep.message_count == len(msgs)
    assert rep.unordered_chunks == 0
    assert rep.topic_counts == {'/arm/joint_states': 1500, '/car/pose': 750, '/car/twist': 150}
    assert rep.metadata_names == ['experiment', 'versions', 'rosbag2']


def test_validate_detects_metadata_yaml_mismatch(recorded, tmp_path):
    bag, _, _ = recorded
    copy = tmp_path / 'run1'
    copy.mkdir()
    (copy / 'run1_0.mcap').write_bytes((bag / 'run1_0.mcap').read_bytes())
    doc = yaml.safe_load((bag / 'metadata.yaml').read_text())
    doc['rosbag2_bagfile_information']['topics_with_message_count'][0]['message_count'] += 1
    (copy / 'metadata.yaml').write_text(yaml.safe_dump(doc))
    rep = validate(copy)
    assert not rep.ok
    assert any('metadata.yaml topic' in p for p in rep.problems)
    with pytest.raises(BagError, match='invalid bag'):
        validate(copy, strict=True)


def test_validate_detects_flipped_byte_in_chunk(recorded, tmp_path):
    bag, _, _ = recorded
    data = bytearray((bag / 'run1_0.mcap').read_bytes())
    with open(bag / 'run1_0.mcap', 'rb') as f:
        ci = make_reader(f).get_summary().chunk_indexes[3]
    data[ci.chunk_start_offset + ci.chunk_length - 10] ^= 0xFF
    bad = tmp_path / 'bad.mcap'
    bad.write_bytes(bytes(data))
    rep = validate(bad)
    assert not rep.ok
    with pytest.raises(BagError) as ei:
        list(BagReader(bad).messages())
    assert '\n' not in str(ei.value)


def test_out_of_order_within_chunk_is_sorted(tmp_path):
    times = [T0 + d for d in (5, 1, 3, 2, 4, 0, 9, 7, 8, 6)]
    payloads = []
    with BagWriter(tmp_path / 'ooo', chunk_size=10**6) as w:
        for i, t in enumerate(times):
            m = make_twist(i, t)
            b = bytes(TS.serialize_cdr(m, TWIST))
            payloads.append((t, b))
            w.write('/twist', TWIST, b, t)
        s = w.close()
    assert s.late_messages == 0
    with open(tmp_path / 'ooo' / 'ooo_0.mcap', 'rb') as f:
        file_order = [m.log_time for rec in [StreamReader(f).records] for m in rec
                      if type(m).__name__ == 'Message']
    assert file_order == sorted(times)
    assert [m.data for m in read_messages(tmp_path / 'ooo')] == [
        b for _, b in sorted(payloads, key=lambda p: p[0])]
    assert validate(tmp_path / 'ooo').unordered_chunks == 0


def test_late_message_after_flushed_chunk_is_counted_and_readable(tmp_path):
    with BagWriter(tmp_path / 'late', chunk_size=10**6) as w:
        for k in range(10):
            w.write('/t', TWIST, bytes(TS.serialize_cdr(make_twist(k, T0 + k), TWIST)), T0 + k)
        w.flush()
        w.write('/t', TWIST, bytes(TS.serialize_cdr(make_twist(99, T0 + 3), TWIST)), T0 + 3)
        s = w.close()
    assert s.late_messages == 1 and s.chunk_count == 2
    got = [m.log_time_ns for m in read_messages(tmp_path / 'late')]
    assert got == sorted(got) and len(got) == 11
    assert validate(tmp_path / 'late').ok


@pytest.mark.parametrize('compression,expected', [('lz4', 'lz4'), ('none', ''), ('zstd', 'zstd')])
def test_compressions(tmp_path, compression, expected):
    msgs = generate(200)
    with BagWriter(tmp_path / 'c', chunk_size=4096, compression=compression) as w:
        for topic, typ, t, data, _ in msgs:
            w.write(topic, typ, data, t)
    with open(tmp_path / 'c' / 'c_0.mcap', 'rb') as f:
        r = make_reader(f, validate_crcs=True)
        assert {ci.compression for ci in r.get_summary().chunk_indexes} == {expected}
        assert [m.data for _, _, m in r.iter_messages()] == [d for _, _, _, d, _ in msgs]
    assert validate(tmp_path / 'c').ok


def test_empty_bag(tmp_path):
    with BagWriter(tmp_path / 'e') as w:
        w.add_topic('/x', JS)
    with RosbagsReader(tmp_path / 'e') as r:
        assert r.message_count == 0
    with BagReader(tmp_path / 'e') as r:
        assert r.message_count == 0 and r.topics['/x'].message_count == 0
    assert validate(tmp_path / 'e').ok


def test_writer_errors(tmp_path):
    (tmp_path / 'full').mkdir()
    (tmp_path / 'full' / 'x').write_text('x')
    with pytest.raises(BagWriterError, match='not empty'):
        BagWriter(tmp_path / 'full')
    with pytest.raises(BagWriterError, match='compression'):
        BagWriter(tmp_path / 'a', compression='bz2')
    with pytest.raises(BagWriterError, match='chunk_size'):
        BagWriter(tmp_path / 'b', chunk_size=0)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(BagWriterError, match='chunk_messages'):
            BagWriter(tmp_path / 'b', chunk_messages=bad)
    w = BagWriter(tmp_path / 'c')
    data = bytes(TS.serialize_cdr(make_twist(0, T0), TWIST))
    w.write('/t', TWIST, data, T0)
    with pytest.raises(BagWriterError, match='has type'):
        w.write('/t', JS, data, T0)
    for bad in (-1, 2 ** 64, True, 1.5, None):
        with pytest.raises(BagWriterError, match='log_time_ns'):
            w.write('/t', TWIST, data, bad)
    for bad in (-1, 2 ** 64, False, 2.0):
        with pytest.raises(BagWriterError, match='publish_time_ns'):
            w.write('/t', TWIST, data, T0, bad)
    import numpy as np
    w.write('/t', TWIST, data, np.int64(T0 + 1), np.uint64(T0), np.int32(7))  # numpy ints: fine
    with pytest.raises(BagWriterError, match='bytes'):
        w.write('/t', TWIST, 'text', T0)
    with pytest.raises(BagWriterError, match='must be str'):
        w.add_metadata('params', {'gain': 1.5})
    with pytest.raises(BagWriterError, match='reserved'):
        w.add_metadata('rosbag2', {})
    from irs_bag.msg_definitions import MessageDefinitionError
    with pytest.raises(MessageDefinitionError):
        w.write('/u', 'nope_msgs/msg/Nope', data, T0)
    s = w.close()
    assert s.message_count == 2 and s.end_time_ns == T0 + 1
    assert w.close() is s
    with pytest.raises(BagWriterError, match='closed'):
        w.write('/t', TWIST, data, T0)
    assert validate(tmp_path / 'c').ok


def test_deserialize_helper_errors():
    with pytest.raises(BagError, match='cannot decode'):
        deserialize(JS, get_message_definition(JS), b'\x00\x01\x00\x00\x01')


def test_modules_do_not_import_rclpy():
    import subprocess
    code = (
        'import sys; sys.path.insert(0, sys.argv[1]); '
        'import irs_bag.writer, irs_bag.reader, irs_bag.info, '
        'irs_bag.export, irs_bag.msg_definitions; '
        'print("rclpy" in sys.modules)'
    )
    out = subprocess.run([sys.executable, '-c', code, str(Path(__file__).resolve().parents[1])],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == 'False'


def _write_many(directory, background, n=3000):
    """n joint states on one topic, log times out of order in places (every 7th message
    1 ms early), small chunks (many chunk cuts), empty flushes between writes; returns the
    written (log time, data) list.
    """
    written = []
    with BagWriter(directory, chunk_size=8 * 1024, background=background) as w:
        for i in range(n):
            t = T0 + i * 1_000_000 - (1_000_000 if i % 7 == 0 else 0)
            data = TS.serialize_cdr(make_joint_state(i, t), JS)
            w.write('/arm/joint_states', JS, data, t)
            written.append((t, bytes(data)))
            if i == n // 2:
                w.flush()
                w.flush()   # an empty flush: the next messages must be written once
    return written


def test_background_writer_writes_the_same_bag_as_the_foreground_one(tmp_path):
    """``background=True`` moves chunk writing to a thread: the bag holds the same messages
    in the same order, with as many chunks, and passes the CRC checks of the mcap reader.
    """
    fg = _write_many(tmp_path / 'fg', background=False)
    bg = _write_many(tmp_path / 'bg', background=True)
    assert fg == bg
    read = {}
    for name in ('fg', 'bg'):
        path = tmp_path / name / f'{name}_0.mcap'
        with open(path, 'rb') as f:
            reader = make_reader(f, validate_crcs=True)
            read[name] = [(m.log_time, bytes(m.data)) for _, _, m in reader.iter_messages()]
            chunks = len(reader.get_summary().chunk_indexes)
        read[name + '_chunks'] = chunks
        validate(tmp_path / name)
    assert read['fg'] == read['bg'] == sorted(fg, key=lambda m: m[0])
    assert read['fg_chunks'] == read['bg_chunks'] > 10


@pytest.mark.parametrize('background', [False, True])
def test_chunk_messages_bounds_every_chunk(tmp_path, background):
    """``chunk_messages`` cuts a chunk after that many messages, however small they are: 1000
    messages of one topic, 256 per chunk, give chunks of 256, 256, 256 and 232. A message
    earlier than the end of a finished chunk is counted late, one early within its own chunk
    is not, and the bag passes the CRC checks with every message in log-time order.
    """
    written = []
    with BagWriter(tmp_path / 'b', chunk_messages=256, background=background) as w:
        for i in range(1000):
            t = T0 + i * 1_000_000
            if i == 260:
                t = T0 + 200_000_000     # before the first chunk's end (message 255): late
            elif i == 300:
                t -= 3_000_000           # early, but within the second chunk: not late
            data = bytes(TS.serialize_cdr(make_twist(i, t), TWIST))
            w.write('/t', TWIST, data, t)
            written.append((t, data))
        s = w.close()
    assert s.message_count == 1000 and s.chunk_count == 4 and s.late_messages == 1
    with open(tmp_path / 'b' / 'b_0.mcap', 'rb') as f:
        per_chunk = [len(r.records) for r in StreamReader(f).records
                     if type(r).__name__ == 'MessageIndex']
        f.seek(0)
        got = [(m.log_time, bytes(m.data))
               for _, _, m in make_reader(f, validate_crcs=True).iter_messages()]
    assert per_chunk == [256, 256, 256, 232]
    assert got == sorted(written, key=lambda m: m[0])
    assert validate(tmp_path / 'b').ok


def test_background_writer_drains_its_queue_at_close_without_pauses(tmp_path, monkeypatch):
    """While it writes beside a running loop, the writer thread sleeps after every
    ``_YIELD_EVERY`` messages (the loop gets the GIL back); the queue left when ``close`` begins
    is written without those pauses, and the bag holds every message.
    """
    import threading
    import types

    from irs_bag import writer as W
    sleeps = []
    monkeypatch.setattr(W, 'time', types.SimpleNamespace(
        monotonic_ns=W.time.monotonic_ns, sleep=lambda s: sleeps.append(s)))
    w = BagWriter(tmp_path / 'b', chunk_messages=64, background=True)

    def write(first, n):
        for i in range(first, first + n):
            t = T0 + i * 1_000_000
            w.write('/t', TWIST, bytes(TS.serialize_cdr(make_twist(i, t), TWIST)), t)

    write(0, 64)                         # one chunk while running: with its pauses
    assert _wait(lambda: w._chunks == 1)
    assert len(sleeps) == 64 // W._YIELD_EVERY
    with w._io:                          # the thread stalls; 20 chunks queue up behind it
        write(64, 20 * 64)
        closing = threading.Thread(target=w.close)
        closing.start()
        assert _wait(lambda: w._draining)
    closing.join(30)
    assert not closing.is_alive()
    assert len(sleeps) == 64 // W._YIELD_EVERY      # none while draining 1280 messages
    assert w.close().message_count == 21 * 64 and validate(tmp_path / 'b').ok


def _wait(condition, timeout=10.0):
    import time
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.001)
    return condition()


def test_background_writer_reports_a_failed_write_on_the_next_call(tmp_path):
    """An exception in the writer thread is not lost: the next write raises it as a
    BagWriterError naming the bag.
    """
    w = BagWriter(tmp_path / 'bag', chunk_size=1024, background=True)
    data = TS.serialize_cdr(make_joint_state(0, T0), JS)
    w.write('/a', JS, data, T0)

    def broken(**_kwargs):
        raise OSError('disk full')
    w._writer.add_message = broken
    w.flush()
    w._batches.put(None)        # let the thread finish its queue: the failure is now recorded
    w._thread.join()
    with pytest.raises(BagWriterError, match='writer thread failed: disk full'):
        w.write('/a', JS, data, T0 + 1)


def test_background_writer_counts_only_chunks_in_the_file(tmp_path):
    """``summary().chunk_count`` (the recorder's status ``chunks``) counts the chunks written to
    the file, not the ones still queued for the writer thread: a writer killed after the status
    said K chunks leaves at least K complete chunks for ``recover``.
    """
    import time

    from irs_bag import recover
    w = BagWriter(tmp_path / 'bag', chunk_size=1024, background=True)
    data = TS.serialize_cdr(make_joint_state(0, T0), JS)
    w.add_topic('/a', JS)        # declaring writes the channel: before the file lock is taken
    with w._io:                  # the writer thread cannot write while the file lock is held
        w.write('/a', JS, data, T0)
        w.flush()                # one chunk cut and queued, not yet in the file
        assert w.summary().chunk_count == 0
    deadline = time.monotonic() + 10.0
    while w.summary().chunk_count < 1 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert w.summary().chunk_count == 1
    got = recover(tmp_path / 'bag')   # the writer still open: what a kill would leave
    assert not got.complete and got.chunks == 1 and [m.data for m in got] == [bytes(data)]
    assert w.close().chunk_count == 1


@pytest.mark.parametrize('background', [False, True])
def test_an_appender_writes_what_write_writes(tmp_path, background):
    """``appender(topic)(data, t)`` is ``write(topic, type, data, t, t, 0)``: the same records
    in the same chunks (the files are equal byte for byte but for the directory's name in their
    metadata), the same counts and times; an undeclared topic, a time that is no int in
    [0, 2**64) ns and a closed writer are refused.
    """
    times = [T0 + i * 1_000_000 - (20_000_000 if i % 11 == 5 else 0) for i in range(700)]
    summaries, records = {}, {}
    for way in ('write', 'append'):
        with BagWriter(tmp_path / way, chunk_messages=128, background=background) as w:
            w.add_topic('/a', JS)
            w.add_topic('/b', TWIST)
            append = {'/a': w.appender('/a'), '/b': w.appender('/b')}
            for i, t in enumerate(times):
                topic, kind = ('/a', JS) if i % 3 else ('/b', TWIST)
                data = bytes(TS.serialize_cdr(
                    make_joint_state(i, t) if kind == JS else make_twist(i, t), kind))
                if way == 'write':
                    w.write(topic, kind, data, t)
                else:
                    append[topic](data, t)
        summaries[way] = w.summary()
        with open(tmp_path / way / f'{way}_0.mcap', 'rb') as f:
            reader = make_reader(f, validate_crcs=True)
            records[way] = [(c.topic, m.log_time, m.publish_time, m.sequence, bytes(m.data))
                            for _, c, m in reader.iter_messages(log_time_order=False)]
        validate(tmp_path / way)
    assert records['write'] == records['append'] and len(records['write']) == 700
    a, b = summaries['write'], summaries['append']
    assert (a.message_count, a.start_time_ns, a.end_time_ns, a.chunk_count, a.late_messages) == (
        b.message_count, b.start_time_ns, b.end_time_ns, b.chunk_count, b.late_messages)
    assert a.late_messages > 0
    assert {t: (s.message_count, s.first_log_time_ns, s.last_log_time_ns)
            for t, s in a.topics.items()} == {t: (s.message_count, s.first_log_time_ns,
                                                  s.last_log_time_ns) for t, s in b.topics.items()}

    w = BagWriter(tmp_path / 'refused', background=background)
    with pytest.raises(BagWriterError, match="'/nope' is not declared"):
        w.appender('/nope')
    w.add_topic('/a', JS)
    append = w.appender('/a')
    for bad in (-1, 2 ** 64, 1.5e18, None):
        with pytest.raises(BagWriterError, match='time_ns'):
            append(b'\x00\x01\x00\x00', bad)
    with pytest.raises(BagWriterError, match='data must be bytes, got str'):
        append('\x00\x01\x00\x00', T0)
    buffer = bytearray(b'\x00\x01\x00\x00\x07')
    append(buffer, T0)
    buffer[4] = 9                   # the writer copied it: the bag keeps what was appended
    w.close()
    with open(tmp_path / 'refused' / 'refused_0.mcap', 'rb') as f:
        assert [bytes(m.data) for _, _, m in make_reader(f).iter_messages()] == [
            b'\x00\x01\x00\x00\x07']
    with pytest.raises(BagWriterError, match='closed'):
        append(b'\x00\x01\x00\x00', T0)
    assert w.summary().message_count == 1
