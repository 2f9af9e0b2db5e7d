"""The live view's Foxglove bridge, read back by a WebSocket client speaking Foxglove's protocol
(:class:`irs_system_tests.foxglove_client.Client`: subscribes to every advertised channel as the
Foxglove app does). Payloads are decoded with rclpy as the advertised ``ros2msg`` type.
"""
import socket
import time

import pytest

from irs_bag.msg_definitions import get_message_definition
from irs_system_tests.foxglove_client import SUBPROTOCOLS, Client

DEADLINE = 60.0          # [s] longest wait for messages


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def test_bridge_serves_cdr_channels_with_ros2msg_schemas_to_a_client():
    """Two topics on a bridge of its own: the client sees both advertised as ``cdr`` with the
    rosbag2 definition as ``ros2msg`` schema, and every message it gets decodes to one that was
    forwarded, with the log time given.
    """
    from geometry_msgs.msg import PointStamped
    from irs_msgs.msg import SteeringActuatorState
    from rclpy.serialization import deserialize_message, serialize_message

    from irs_bag.foxglove_bridge import FoxgloveBridge
    types = {'/ground_truth/sensor_point': PointStamped, '/steering/state': SteeringActuatorState}
    names = {'/ground_truth/sensor_point': 'geometry_msgs/msg/PointStamped',
             '/steering/state': 'irs_msgs/msg/SteeringActuatorState'}
    bridge = FoxgloveBridge('ws://127.0.0.1:0', names, name='test')
    client = None
    try:
        client = Client(f'ws://127.0.0.1:{bridge.port}')
        client.wait(lambda: len(client.channels) == 2, 'advertisement')
        assert client.subprotocol in SUBPROTOCOLS
        assert client.server_info['name'] == 'test'
        for ch in client.channels.values():
            assert ch['encoding'] == 'cdr' and ch['schemaEncoding'] == 'ros2msg'
            assert ch['schemaName'] == names[ch['topic']]
            assert ch['schema'] == get_message_definition(ch['schemaName'])
        sent = {}                       # (topic, log time) -> message
        k = 0
        deadline = time.monotonic() + DEADLINE
        while min(len(client.of(t)) for t in names) < 20:   # until subscribed and flowing
            assert time.monotonic() < deadline, 'no messages within the deadline'
            k += 1
            p = PointStamped()
            p.header.stamp.sec, p.point.y = k, 0.001 * k
            s = SteeringActuatorState()
            s.header.stamp.nanosec, s.front_commanded, s.front_achieved = k, 0.01 * k, -0.5 * k
            for topic, msg in (('/ground_truth/sensor_point', p), ('/steering/state', s)):
                t_ns = 1_000_000_000 + k
                bridge.forward(topic, serialize_message(msg), t_ns)
                sent[(topic, t_ns)] = msg
            with client.changed:            # pace: the next frame read, or 10 ms
                client.changed.wait(0.01)
        for topic in names:
            got = client.of(topic)
            for t_ns, data in got:
                assert deserialize_message(data, types[topic]) == sent[(topic, t_ns)]
            assert len({t for t, _ in got}) == len(got)       # each once
    finally:
        if client is not None:
            client.stop()
        bridge.close()


def test_a_client_connecting_while_the_bridge_starts_gets_every_channel():
    """A client that keeps trying to connect (as the test of a running graph does) while the
    bridge starts, ten times with the start 0-50 ms after the first attempt: its first
    ``advertise`` holds every channel, and it receives messages on each one.
    """
    import random

    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import serialize_message

    from irs_bag.foxglove_bridge import FoxgloveBridge
    names = {f'/t{i}': 'geometry_msgs/msg/PointStamped' for i in range(4)}
    data = serialize_message(PointStamped())
    rng = random.Random(1)
    for _ in range(10):
        url = f'ws://127.0.0.1:{_free_port()}'
        client = Client(url)
        bridge = None
        try:
            time.sleep(rng.uniform(0.0, 0.05))      # the stimulus: a start at a random phase
            bridge = FoxgloveBridge(url, names)
            deadline = time.monotonic() + DEADLINE
            while min(len(client.of(t)) for t in names) == 0:
                assert time.monotonic() < deadline, \
                    {t: len(client.of(t)) for t in names}    # a channel never delivered
                for topic in names:
                    bridge.forward(topic, data, 1)
                with client.changed:
                    client.changed.wait(0.01)
            assert client.error is None, repr(client.error)
            assert sorted(client.advertised[0]) == sorted(client.channels), client.advertised
        finally:
            client.stop()
            if bridge is not None:
                bridge.close()


def test_a_bad_foxglove_url_is_refused_in_one_line():
    from irs_bag.foxglove_bridge import parse_ws_url
    from irs_bag.live_view_params import NODE_PARAMS
    assert parse_ws_url('ws://0.0.0.0:8765') == ('0.0.0.0', 8765)
    for bad in ('http://127.0.0.1:8765', 'ws://127.0.0.1', 'ws://:8765', 'ws://h:99999',
                'ws://h:1/path'):
        with pytest.raises(ValueError, match='is not ws://host:port'):
            parse_ws_url(bad)
    validator = next(p for p in NODE_PARAMS if p.name == 'foxglove').validator
    assert validator('') is None and validator('ws://127.0.0.1:0') is None
    assert 'is not ws://host:port' in validator('localhost:8765')


def test_view_serves_a_running_graph_to_a_foxglove_client(tmp_path):
    """A lock-step Figure 10 run with ``--view ws://127.0.0.1:P`` (Foxglove only, the default
    topics): a client connected while it runs gets the topics advertised with their types, and
    the decoded ``ground_truth/sensor_point`` messages it receives are the bag's, stamp for
    stamp (CDR doubles: exact). Best effort drops what a loaded machine cannot carry: how many
    of the 1 kHz messages arrive is a throughput figure (1216 of 3001 in a slow phase of the
    2-core VM), so the test asks for a sample of at least 500, spanning the run's steps.
    """
    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import deserialize_message

    from irs_bag.columns import read_columns
    from irs_bag.live_view_params import OUTSIDE_THE_LOOP
    from irs_bringup.experiment_cli import run_experiment
    duration = 3.0
    url = f'ws://127.0.0.1:{_free_port()}'
    client = Client(url)
    try:
        result = run_experiment('figure10_mrc_with_actuator', runs_dir=tmp_path,
                                deployment='composed', duration=duration, view=url,
                                plots=False, log=lambda *_: None)
    finally:
        client.stop()
    assert result.completed, result.message
    assert result.exit_codes.get('live_view') == 0, result.exit_codes
    assert client.error is None, repr(client.error)
    topics = {ch['topic']: ch['schemaName'] for ch in client.channels.values()}
    assert {t.lstrip('/') for t in topics} == set(OUTSIDE_THE_LOOP), topics
    assert topics['/ground_truth/sensor_point'] == 'geometry_msgs/msg/PointStamped'
    bag = read_columns(result.bag_dir, {'ground_truth/sensor_point': {'y': 'point.y'}})
    bag_y = dict(zip(bag['ground_truth/sensor_point']['t'].round(9),
                     bag['ground_truth/sensor_point']['y']))
    got = client.of('/ground_truth/sensor_point')
    assert len(got) >= 500, (len(got), len(bag_y))
    ys = []
    for _, data in got:
        msg = deserialize_message(data, PointStamped)
        t = round(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec, 9)
        assert msg.point.y == bag_y[t], t
        ys.append(msg.point.y)
    assert max(ys) - min(ys) > 0.005          # the run's steps are in it, not a constant
