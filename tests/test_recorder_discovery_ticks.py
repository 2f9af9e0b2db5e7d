"""The composed recorder's discovery tick: a graph scan rarely once settled, one count per tick.

A full scan plus a publisher count for each of 13 topics took 0.5 ms of the composed 1 kHz loop
ten times a second. Once every explicitly named topic is recorded the recorder scans only every
``SETTLED_EVERY``-th tick, and it counts one topic's publishers per tick, round robin. With a
pattern (``'*'``) it keeps scanning on every tick: a new topic can appear at any time.
"""
import time
import uuid

import pytest
import rclpy
from rclpy.context import Context
from std_msgs.msg import Float64

from irs_bringup.bag.recorder_node import ComposableRecorder


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)


def _recorder(context, tmp_path, topics, names):
    pub_node = rclpy.create_node(f'ticks_pub_{uuid.uuid4().hex[:6]}', context=context)
    for name in names:
        pub_node.create_publisher(Float64, name, 10)
    rec = ComposableRecorder(context=context, parameter_overrides=[
        rclpy.parameter.Parameter('topics', value=topics),
        rclpy.parameter.Parameter('output', value=str(tmp_path / 'bag')),
        rclpy.parameter.Parameter('status_period', value=0.0)])
    return rec, pub_node


def _tick_until_recorded(rec, names, limit=200):
    for _ in range(limit):
        rec._discover()
        if all(n in rec.recorded for n in names):
            return True
        time.sleep(0.02)          # discovery of the publishers by the graph
    return False


def test_settled_recorder_scans_every_tenth_tick_and_counts_round_robin(context, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}_{i}' for i in range(3)]
    rec, pub_node = _recorder(context, tmp_path, names, names)
    try:
        assert _tick_until_recorded(rec, names), 'the three topics were never recorded'
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


def test_a_pattern_keeps_scanning_on_every_tick(context, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}']
    rec, pub_node = _recorder(context, tmp_path, ['/ticks_*'], names)
    try:
        assert _tick_until_recorded(rec, names)
        scans = []
        rec.discover = lambda: scans.append(1) or False
        for _ in range(12):
            rec._discover()
        assert len(scans) == 12
    finally:
        rec.destroy_node()
        pub_node.destroy_node()


def test_the_real_count_still_notices_a_second_publisher(context, tmp_path):
    names = [f'/ticks_{uuid.uuid4().hex[:6]}']
    rec, pub_node = _recorder(context, tmp_path, names, names)
    other = rclpy.create_node('ticks_second_pub', context=context)
    try:
        assert _tick_until_recorded(rec, names)
        other.create_publisher(Float64, names[0], 10)
        end = time.monotonic() + 10.0
        while rec.recorded[names[0]].single_pub and time.monotonic() < end:
            rec._discover()
            time.sleep(0.02)
        assert not rec.recorded[names[0]].single_pub, 'two publishers, loss detection must stop'
    finally:
        rec.destroy_node()
        pub_node.destroy_node()
        other.destroy_node()
