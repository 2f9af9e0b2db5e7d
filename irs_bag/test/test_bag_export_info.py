"""bag info / export commands."""



import csv
import io

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from irs_bag import export as bag_export, info as bag_info
from irs_bag.export import flatten, topic_file_name
from irs_bag.writer import BagWriter

TS = get_typestore(Stores.ROS2_JAZZY)
G = TS.types
JS, POSE = 'sensor_msgs/msg/JointState', 'geometry_msgs/msg/PoseStamped'
ARR = 'std_msgs/msg/Float64MultiArray'
T0 = 1_760_000_000_123_456_789


def _time(t):
    return G['builtin_interfaces/msg/Time'](sec=t // 10**9, nanosec=t % 10**9)


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    rng = np.random.default_rng(7)
    d = tmp_path_factory.mktemp('exp') / 'b'
    orig = {'/js': [], '/pose': [], '/arr': []}
    with BagWriter(d, chunk_size=8192) as w:
        w.add_metadata('parameters', {'kp': '1.5', 'multi': 'line1\nline2'})
        for k in range(400):
            t = T0 + k * 1_000_000
            js = G[JS](header=G['std_msgs/msg/Header'](stamp=_time(t - 77), frame_id='arm'),
                       name=['j1', 'j2'], position=rng.normal(size=2),
                       velocity=rng.normal(size=2), effort=np.zeros(0))
            w.write('/js', JS, bytes(TS.serialize_cdr(js, JS)), t)
            orig['/js'].append((t, js))
            if k % 4 == 0:
                p = G[POSE](header=G['std_msgs/msg/Header'](stamp=_time(t), frame_id='tm'),
                            pose=G['geometry_msgs/msg/Pose'](
                                position=G['geometry_msgs/msg/Point'](
                                    x=float(rng.normal()), y=1e-300, z=-0.0),
                                orientation=G['geometry_msgs/msg/Quaternion'](
                                    x=0.0, y=0.0, z=float(np.sin(k)), w=float(np.cos(k)))))
                w.write('/pose', POSE, bytes(TS.serialize_cdr(p, POSE)), t)
                orig['/pose'].append((t, p))
            if k % 50 == 0:
                n = 1 + (k // 50) % 3  # variable length
                a = G[ARR](layout=G['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0),
                           data=rng.normal(size=n))
                w.write('/arr', ARR, bytes(TS.serialize_cdr(a, ARR)), t)
                orig['/arr'].append((t, a))
    return d, orig


def _read(path):
    with open(path, newline='') as f:
        return list(csv.DictReader(f))


def test_export_values_equal_originals(bag, tmp_path):
    d, orig = bag
    out = io.StringIO()
    assert bag_export.main([str(d), '--topics', '/js', '/pose', '--out',
                            str(tmp_path / 'csv')], out=out) == 0
    assert sorted(p.name for p in (tmp_path / 'csv').iterdir()) == ['js.csv', 'pose.csv']
    rows = _read(tmp_path / 'csv' / 'js.csv')
    assert list(rows[0]) == ['log_time_ns', 'log_time', 'header.stamp', 'header.frame_id',
                             'name[0]', 'name[1]', 'position[0]', 'position[1]',
                             'velocity[0]', 'velocity[1]']
    assert len(rows) == len(orig['/js'])
    for row, (t, m) in zip(rows, orig['/js']):
        assert int(row['log_time_ns']) == t
        assert float(row['log_time']) == t / 1e9
        st = m.header.stamp
        assert float(row['header.stamp']) == st.sec + st.nanosec * 1e-9
        assert row['header.frame_id'] == 'arm'
        assert [row['name[0]'], row['name[1]']] == ['j1', 'j2']
        assert [float(row[f'position[{i}]']) for i in range(2)] == list(m.position)
        assert [float(row[f'velocity[{i}]']) for i in range(2)] == list(m.velocity)
    prow = _read(tmp_path / 'csv' / 'pose.csv')
    assert len(prow) == len(orig['/pose'])
    for row, (t, m) in zip(prow, orig['/pose']):
        assert float(row['pose.position.x']) == m.pose.position.x
        assert float(row['pose.position.y']) == 1e-300
        assert float(row['pose.orientation.z']) == m.pose.orientation.z
        assert float(row['pose.orientation.w']) == m.pose.orientation.w
    assert '/js: 400 rows' in out.getvalue()


def test_export_variable_length_arrays_union_columns(bag, tmp_path):
    d, orig = bag
    assert bag_export.main([str(d), '--topics', '/arr', '--out', str(tmp_path)]) == 0
    rows = _read(tmp_path / 'arr.csv')
    assert [c for c in rows[0] if c.startswith('data[')] == ['data[0]', 'data[1]', 'data[2]']
    for row, (_, m) in zip(rows, orig['/arr']):
        vals = [float(row[f'data[{i}]']) for i in range(len(m.data))]
        assert vals == list(m.data)
        assert all(row[f'data[{i}]'] == '' for i in range(len(m.data), 3))


def test_export_all_topics_default(bag, tmp_path):
    d, _ = bag
    assert bag_export.main([str(d), '--out', str(tmp_path / 'all')]) == 0
    assert sorted(p.name for p in (tmp_path / 'all').iterdir()) == ['arr.csv', 'js.csv',
                                                                     'pose.csv']


def test_export_errors_are_messages(bag, tmp_path, capsys):
    d, _ = bag
    assert bag_export.main([str(d), '--topics', '/nope', '--out', str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert 'topics not in the bag: /nope' in err and 'Traceback' not in err
    assert bag_export.main([str(tmp_path / 'missing'), '--out', str(tmp_path)]) == 2
    assert 'no such bag' in capsys.readouterr().err
    with pytest.raises(SystemExit) as ei:
        bag_export.main([str(d)])  # --out missing
    assert ei.value.code == 2
    assert '--out' in capsys.readouterr().err


def test_info_output(bag):
    d, orig = bag
    out = io.StringIO()
    assert bag_info.main([str(d), '--validate'], out=out) == 0
    text = out.getvalue()
    assert 'Messages:     508' in text  # 400 + 100 + 8
    lines = {ln.split()[0]: ln.split() for ln in text.splitlines() if ln.startswith('  /')}
    assert lines['/js'][1:3] == [JS, '400']
    assert float(lines['/js'][3]) == pytest.approx(1000.0)
    assert float(lines['/pose'][3]) == pytest.approx(250.0)
    assert lines['/arr'][1:3] == [ARR, '8']
    assert f'Duration:     {399 * 1e-3:.6f} s' in text
    assert 'Start:        2025-10-09T08:53:20.123456+00:00 (1760000000.123456789 s)' in text
    assert '[parameters]' in text and 'kp: 1.5' in text and 'line1\\nline2' in text
    assert 'Validation:   OK' in text
    assert '[rosbag2]' not in text


def test_info_errors(tmp_path, capsys):
    assert bag_info.main([str(tmp_path / 'nothing')]) == 2
    assert 'no such bag' in capsys.readouterr().err
    (tmp_path / 'junk.mcap').write_bytes(b'not an mcap file at all' * 10)
    assert bag_info.main([str(tmp_path / 'junk.mcap')]) == 2
    err = capsys.readouterr().err
    assert 'not an MCAP file' in err and 'Traceback' not in err
    with pytest.raises(SystemExit) as ei:
        bag_info.main(['--bogus'])
    assert ei.value.code == 2


def test_flatten_and_file_names():
    m = G[JS](header=G['std_msgs/msg/Header'](stamp=_time(1_500_000_000), frame_id='x'),
              name=['a'], position=np.array([1.0]), velocity=np.zeros(0), effort=np.zeros(0))
    # rosbags objects have no __slots__ list of fields -> use the decoder's objects instead
    from irs_bag.reader import deserialize
    from irs_bag.msg_definitions import get_message_definition
    dec = deserialize(JS, get_message_definition(JS), bytes(TS.serialize_cdr(m, JS)))
    assert list(flatten(dec)) == [('header.stamp', 1.5), ('header.frame_id', 'x'),
                                  ('name[0]', 'a'), ('position[0]', 1.0)]
    assert topic_file_name('/arm/joint_states') == 'arm__joint_states.csv'


def _lockstep_bag(path, steps, log_step_ns, record):
    """A lock-step recording: /clock and /arm/joint_states stamped k ms (simulated time),
    received every ``log_step_ns`` (the graph's stepping speed), with ``record`` as the
    irs_experiment metadata record (or none).
    """
    clock_t = 'rosgraph_msgs/msg/Clock'
    with BagWriter(path, chunk_size=64 * 1024) as w:
        if record is not None:
            w.add_metadata('irs_experiment', record)
        for k in range(steps):
            stamp = _time(k * 1_000_000)
            log = T0 + k * log_step_ns
            w.write('/clock', clock_t, bytes(TS.serialize_cdr(G[clock_t](clock=stamp), clock_t)),
                    log)
            js = G[JS](header=G['std_msgs/msg/Header'](stamp=stamp, frame_id='arm'),
                       name=['j1'], position=np.array([0.1]), velocity=np.zeros(0),
                       effort=np.zeros(0))
            w.write('/arm/joint_states', JS, bytes(TS.serialize_cdr(js, JS)), log + 1000)
    return path


@pytest.mark.parametrize('record, why', [
    ({'clock': 'lockstep', 'experiment_yaml': 'name: x\n'}, 'the experiment record says'),
    ({'experiment_yaml': 'name: x\nclock: lockstep\n'}, 'its experiment file says'),
    (None, 'it has /clock'),
])
def test_info_of_a_lockstep_bag_gives_its_simulated_time(tmp_path, record, why):
    """2 s of simulated time at 1 kHz, received over 8 s: info says lock-step (and why), the
    simulated span and step rate, both rates per topic, and what every counter means.
    """
    bag = _lockstep_bag(tmp_path / 'ls', 2001, 4_000_000, record)
    out = io.StringIO()
    assert bag_info.main([str(bag)], out=out) == 0
    text = out.getvalue()
    assert 'Clock:        lock-step (' + why in text, text
    assert 'Sim time:     2.000000 s (0.000000 .. 2.000000 s; /clock: 2001 steps at 1000.0 Hz)' \
        in text, text
    assert 'Duration:     8.000001 s (receive time)' in text, text
    row = {ln.split()[0]: ln.split() for ln in text.splitlines()
           if ln.startswith('  /')}['/arm/joint_states']
    assert float(row[3]) == pytest.approx(250.0)       # per second of receive time
    assert float(row[4]) == pytest.approx(1000.0)      # per second of simulated time
    for key in ('irs.dropped_messages', 'irs.dropped_messages_per_topic', 'irs.late_messages'):
        [line] = [ln for ln in text.splitlines() if ln.startswith(f'  {key}: ')]
        assert line.split('   -- ')[1] == bag_info.COUNTERS[key]


def test_info_of_a_realtime_bag_says_so(bag):
    d, _ = bag
    out = io.StringIO()
    assert bag_info.main([str(d)], out=out) == 0
    text = out.getvalue()
    assert 'Clock:        real time (assumed): no experiment record and no /clock' in text
    assert 'Sim time' not in text


def test_a_run_directory_stands_for_its_bag(tmp_path):
    """``bag info runs/<run>`` reads ``runs/<run>/bag``; a directory with neither is refused."""
    import shutil
    from irs_bag.errors import BagError
    from irs_bag.layout import resolve_bag
    run = tmp_path / 'figure10_pi-20261204'
    with BagWriter(run / 'bag') as w:
        w.write('/js', JS, bytes(TS.serialize_cdr(G[JS](
            header=G['std_msgs/msg/Header'](stamp=_time(T0), frame_id='arm'), name=['j1'],
            position=np.zeros(1), velocity=np.zeros(1), effort=np.zeros(0)), JS)), T0)
    (run / 'logs').mkdir()
    path, files, meta = resolve_bag(run)
    assert path == run / 'bag' and [f.parent for f in files] == [run / 'bag'] and meta
    out = io.StringIO()
    assert bag_info.main([str(run)], out=out) == 0
    assert 'Messages:     1' in out.getvalue()
    shutil.rmtree(run / 'bag')
    with pytest.raises(BagError, match='no metadata.yaml and no .mcap file'):
        resolve_bag(run)
