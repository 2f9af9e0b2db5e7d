"""The composed recorder's discovery tick: a graph scan rarely once settled, one count per tick.

A full scan plus a publisher count for each of 13 topics took 0.5 ms of the composed 1 kHz loop
ten times a second. Once every explicitly named topic is recorded the recorder scans only every
``SETTLED_EVERY``-th tick, and it counts one topic's publishers per tick, round robin. With a
pattern (``'*'``) it keeps scanning on every tick: a new topic can appear at any time.
"""
import uuid

import rclpy
from std_msgs.msg import Float64

from irs_bag.recorder_node import ComposableRecorder


def _recorder(ros, tmp_path, topics, names):
    context = ros.node.context
    pub_node = rclpy.create_node(f'ticks_pub_{uuid.uuid4().hex[:6]}', context=context)
    for name in names:
        pub_node.create_publisher(Float64, name, 10)
    rec = ComposableRecorder(context=context, parameter_overrides=[
        rclpy.parameter.Parameter('topics', value=topics),
        rclpy.parameter.Parameter('output', value=str(tmp_path / 'bag')),
        rclpy.parameter.Parameter('status_period', value=0.0)])
    return rec, pub_node


def _tick_until_recorded(ros, rec, names):
    """Discovery ticks while the watcher spins, until every topic is recorded (10 s at most)."""
    return ros.spin_until(lambda: (rec._discover(), all(n in rec.recorded for n in names))[1],
                          10.0)


def test_settled_recorder_scans_every_tenth_tick_and_counts_round_robin(ros, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}_{i}' for i in range(3)]
    rec, pub_node = _recorder(ros, tmp_path, names, names)
    try:
        assert _tick_until_recorded(ros, rec, names), 'the three topics were never recorded'
        scans, counted = [], []
        rec.discover = lambda: scans.append(1) or False
        rec.update_publisher_counts = lambda recs=None: counted.extend(r.topic for r in recs)
        for _ in range(30):
            rec._discover()
        assert len(scans) == 30 // ComposableRecorder.SETTLED_EVERY
        assert len(counted) == 30, 'one topic counted per tick'
        assert set(counted) == set(names) and all(counted.count(n) == 10 for n in names)
    finally:
        rec.destroy_node()
        pub_node.destroy_node()


def test_a_pattern_keeps_scanning_on_every_tick(ros, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}']
    rec, pub_node = _recorder(ros, tmp_path, ['/ticks_*'], names)
    try:
        assert _tick_until_recorded(ros, rec, names)
        scans = []
        rec.discover = lambda: scans.append(1) or False
        for _ in range(12):
            rec._discover()
        assert len(scans) == 12
    finally:
        rec.destroy_node()
        pub_node.destroy_node()


def test_the_real_count_still_notices_a_second_publisher(ros, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}']
    rec, pub_node = _recorder(ros, tmp_path, names, names)
    other = rclpy.create_node('ticks_second_pub', context=ros.node.context)
    try:
        assert _tick_until_recorded(ros, rec, names)
        other.create_publisher(Float64, names[0], 10)
        assert ros.spin_until(
            lambda: (rec._discover(), not rec.recorded[names[0]].single_pub)[1], 10.0), \
            'two publishers, loss detection must stop'
    finally:
        rec.destroy_node()
        pub_node.destroy_node()
        other.destroy_node()
