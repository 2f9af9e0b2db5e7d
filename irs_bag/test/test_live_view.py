"""The live view's core (no ROS): decoded messages in batches -> the entities of run.rrd."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from irs_bag.live_view import LiveFeed, open_stream, viewer_problem
from irs_bag.rerun_entities import ENTITY_PATHS
from irs_bag.run_info import RunInfo

G = get_typestore(Stores.ROS2_JAZZY).types
T_START = 1000.25          # [s] first stamp: the timeline starts there


def _header(t):
    sec = math.floor(t)
    return G['std_msgs/msg/Header'](
        stamp=G['builtin_interfaces/msg/Time'](sec=sec, nanosec=int(round((t - sec) * 1e9))),
        frame_id='treadmill')


def _messages(t):
    """One message of every topic of the entities at stamp ``t`` [s]."""
    h = _header(t)
    y = 0.01 * math.sin(t)
    q = G['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(0.05), w=math.cos(0.05))
    pose = G['geometry_msgs/msg/Pose'](position=G['geometry_msgs/msg/Point'](x=0.1, y=y, z=0.0),
                                       orientation=q)
    cov = np.zeros(36)
    zero = G['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0)
    odom = G['nav_msgs/msg/Odometry'](
        header=h, child_frame_id='base_link',
        pose=G['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=cov),
        twist=G['geometry_msgs/msg/TwistWithCovariance'](
            twist=G['geometry_msgs/msg/Twist'](linear=zero, angular=zero), covariance=cov))
    point = G['geometry_msgs/msg/PointStamped'](
        header=h, point=G['geometry_msgs/msg/Point'](x=0.0, y=y, z=0.0))
    joints = G['sensor_msgs/msg/JointState'](header=h, name=['a', 'b', 'c'],
                                             position=np.array([1.2, -1.0, -0.2]),
                                             velocity=np.zeros(0), effort=np.zeros(0))
    ns = SimpleNamespace
    return {'ground_truth/odom': odom, 'ground_truth/sensor_point': point,
            'lateral_position': point, 'arm/joint_states': joints,
            'lateral/reference': ns(header=h, lateral_position=0.02),
            'steering/command': ns(header=h, front_angle=0.01),
            'steering/state': ns(header=h, front_commanded=0.01, front_achieved=0.009),
            'belt/speed': ns(header=h, speed=2.0),
            'treadmill/state': ns(header=h, belt_speed=2.0)}


def _rows(rrd):
    """Rows per entity (temporal chunks) and the range of the ``time`` timeline [s]."""
    from rerun.chunk import RrdReader
    rows, times = {}, []
    for c in RrdReader(str(rrd)).stream().to_chunks():
        path = c.entity_path.lstrip('/')
        rows.setdefault(path, 0)
        if c.is_static:
            continue
        rows[path] += c.num_rows
        batch = c.to_record_batch()
        if 'time' in batch.schema.names:
            times += [v.total_seconds() for v in batch.column('time').to_pylist()]
    return rows, (min(times), max(times))


def test_batches_of_a_running_graph_become_the_entities_of_run_rrd(tmp_path):
    """1 s of every topic at 1 kHz, flushed in five batches: every entity, every series row
    (series_rate 0), the 3-D entities at about 30 Hz, the timeline from the first stamp.
    """
    rrd = tmp_path / 'live.rrd'
    feed = LiveFeed(RunInfo('live-test'), view_rate=30.0)
    rec = open_stream(feed.info, save=str(rrd))
    sent = {}
    for batch in range(5):
        for k in range(200):
            t = T_START + (batch * 200 + k) * 1e-3
            for suffix, msg in _messages(t).items():
                feed.add(suffix, msg)
        for ent, n in feed.flush(rec).items():
            sent[ent] = sent.get(ent, 0) + n
    assert feed.flush(rec) == {}            # nothing new: nothing sent
    rec.flush()
    rec.disconnect()
    rows, (t_first, t_last) = _rows(rrd)
    assert set(ENTITY_PATHS) <= set(rows)
    for ent in ('series/lateral/ground_truth', 'series/steer/achieved', 'series/belt/speed'):
        assert rows[ent] == sent[ent] == 1000, ent
    for ent in ('world/car', 'world/car/heading', 'world/arm'):
        assert 28 <= rows[ent] == sent[ent] <= 36, (ent, rows[ent])
    assert t_first == pytest.approx(0.0, abs=1e-9)
    assert t_last == pytest.approx(0.999, abs=1e-6)


def test_bad_rows_are_left_out_and_the_rest_is_sent(tmp_path):
    """A NaN value is not sent; a message without the field, or with a NaN stamp, is dropped
    (no error); the rest of the batch is sent.
    """
    feed = LiveFeed(RunInfo('bad'), view_rate=0.0)
    h = _header(T_START)
    feed.add('belt/speed', SimpleNamespace(header=h, speed=2.0))
    feed.add('belt/speed', SimpleNamespace(header=_header(T_START + 0.001), speed=float('nan')))
    feed.add('belt/speed', SimpleNamespace(header=_header(T_START + 0.002)))       # no field
    bad = SimpleNamespace(stamp=SimpleNamespace(sec=float('nan'), nanosec=0))
    feed.add('belt/speed', SimpleNamespace(header=bad, speed=1.0))
    cols = feed.take()
    assert list(cols) == ['belt/speed']
    np.testing.assert_allclose(cols['belt/speed']['t'] - T_START, [0, 0.001], atol=1e-9)
    assert np.isnan(cols['belt/speed']['speed'][1])
    rrd = tmp_path / 'bad.rrd'
    rec = open_stream(feed.info, save=str(rrd))
    feed.add('belt/speed', SimpleNamespace(header=h, speed=2.0))
    feed.add('belt/speed', SimpleNamespace(header=_header(T_START + 0.001), speed=float('nan')))
    assert feed.flush(rec) == {'series/belt/speed': 1}
    rec.flush()
    rec.disconnect()
    assert _rows(rrd)[0]['series/belt/speed'] == 1


def test_batches_shorter_than_a_bin_do_not_raise_the_3d_rate():
    """A lock-step run slower than real time gives batches of a few ms of stamps: the 3-D
    entities still get one row per 1/view_rate s of stamps, not one per batch.
    """
    class Sink:
        def __init__(self):
            self.rows = {}

        def send_columns(self, ent, indexes, columns):
            self.rows[ent] = self.rows.get(ent, 0) + len(indexes[0].times)

    feed, sink = LiveFeed(RunInfo('slow'), view_rate=30.0), Sink()
    for k in range(1000):                      # 1 s of stamps, one 5 ms batch after another
        for suffix, msg in _messages(T_START + k * 1e-3).items():
            feed.add(suffix, msg)
        if k % 5 == 4:
            feed.flush(sink)
    assert sink.rows['world/car'] in (30, 31), sink.rows['world/car']
    assert sink.rows['series/lateral/ground_truth'] == 1000


def test_the_nodes_topic_list_is_the_entities_spec():
    from irs_bag.live_view_params import NODE_PARAMS, OUTSIDE_THE_LOOP, TOPICS
    from irs_bag.rerun_entities import SPEC
    assert TOPICS == list(SPEC)
    topics = next(p for p in NODE_PARAMS if p.name == 'topics')
    assert set(OUTSIDE_THE_LOOP) < set(TOPICS) and topics.default == OUTSIDE_THE_LOOP
    assert topics.validator(['pose', 'belt/speed']) is None
    assert 'wheel_speeds' in topics.validator(['pose', 'wheel_speeds'])


def test_the_car_comes_from_odom_alone_once_odom_was_seen():
    """Tiny batches (a slow lock-step run) that hold odometry or the sensed pose but not both:
    the car is drawn from ``ground_truth/odom`` only (as in run.rrd), not from whichever of the
    two a batch holds, which would double its rows.
    """
    class Sink:
        def __init__(self):
            self.rows = {}

        def send_columns(self, ent, indexes, columns):
            self.rows[ent] = self.rows.get(ent, 0) + len(indexes[0].times)

    feed, sink = LiveFeed(RunInfo('alternate'), view_rate=30.0), Sink()
    for k in range(1000):                      # 1 s of stamps, one message per batch
        msgs = _messages(T_START + k * 1e-3)
        suffix = 'ground_truth/odom' if k % 2 == 0 else 'pose'
        pose = G['geometry_msgs/msg/PoseStamped'](header=msgs['lateral_position'].header,
                                                  pose=msgs['ground_truth/odom'].pose.pose)
        feed.add(suffix, msgs['ground_truth/odom'] if suffix != 'pose' else pose)
        feed.flush(sink)
    assert sink.rows['world/car'] in (30, 31), sink.rows['world/car']


def test_viewer_problem_names_a_port_nothing_listens_on():
    """A listening port: None; a port bound but not listening: its host and port named; a URL
    whose port is not a number: the URL named.
    """
    import socket
    with socket.socket() as server:
        server.bind(('127.0.0.1', 0))
        port = server.getsockname()[1]
        url = f'rerun+http://127.0.0.1:{port}/proxy'
        problem = viewer_problem(url)
        assert problem.startswith(f'no rerun viewer listens at 127.0.0.1:{port} ('), problem
        server.listen()
        assert viewer_problem(url) is None
    bad = 'rerun+http://127.0.0.1:view/proxy'
    assert viewer_problem(bad).startswith(f'{bad}: '), viewer_problem(bad)
