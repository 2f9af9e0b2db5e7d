"""In-process handover between composed nodes (irs_common.intra_process), over real rclpy.

Two nodes share one LeanExecutor with ``intra_process=True``. A second rclpy context in the same
process plays the subscriber from outside (its own DDS participant, as another process would
be): the graph counts it, the executor does not own it.
"""
import time
import uuid

import pytest
import rclpy
from rclpy.context import Context
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64, String

from irs_common.executor import LeanExecutor
from irs_common.intra_process import HANDOVER_SINK, enabled_by_env


def _pair(context, qos_pub=10, qos_sub=10, raw=False, topic='ipc_x'):
    topic = f'{topic}_{uuid.uuid4().hex[:8]}'   # no stale endpoint of another test on it
    a = rclpy.create_node('ipc_a', context=context)
    b = rclpy.create_node('ipc_b', context=context)
    got = []
    pub = a.create_publisher(Float64, topic, qos_pub)
    b.create_subscription(Float64, topic, got.append, qos_sub, raw=raw)
    ex = LeanExecutor(context=context, intra_process=True)
    ex.add_node(a)
    ex.add_node(b)
    ex.spin_once(timeout_sec=0)        # gathers the entities and routes the publisher
    return ex, pub, got, (a, b, topic)


def _spin_until(ex, cond, timeout=10.0):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    return cond()


def test_handover_delivers_every_message_once_in_order_without_dds(context):
    ex, pub, got, nodes = _pair(context)
    assert ex._bus.routes and not ex._bus.routes[0].remote
    for i in range(200):
        pub.publish(Float64(data=float(i)))
    assert len(ex._bus.queue) == 200, 'a handover is queued, not sent'
    assert _spin_until(ex, lambda: len(got) == 200)
    assert [m.data for m in got] == [float(i) for i in range(200)]
    # nothing arrives later through DDS: each message went one way only
    end = time.monotonic() + 0.5
    while time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    assert len(got) == 200


def test_outside_subscriber_switches_the_topic_to_dds_for_good(context):
    ex, pub, got, nodes = _pair(context, qos_pub=100, qos_sub=100)   # DDS keeps the last 100
    outside_ctx = Context()
    rclpy.init(context=outside_ctx)
    try:
        outside = rclpy.create_node('ipc_outside', context=outside_ctx)
        seen = []
        outside_sub = outside.create_subscription(Float64, nodes[2], seen.append, 100)
        # the executor's slow cycle notices the outside subscriber in the graph
        assert _spin_until(ex, lambda: ex._bus.routes[0].remote), 'never switched to DDS'
        assert _spin_until(ex, lambda: pub.get_subscription_count() >= 2)
        for i in range(50):
            pub.publish(Float64(data=float(i)))
        assert not ex._bus.queue, 'a remote route must publish through DDS'
        end = time.monotonic() + 10.0
        while (len(got) < 50 or len(seen) < 50) and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
            while outside_sub.handle.take_message(Float64, False) is not None:
                seen.append(1)
        assert [m.data for m in got] == [float(i) for i in range(50)]
        assert len(seen) == 50
        outside.destroy_node()
        # gone again: the route stays on DDS (no reordering of in-flight messages)
        for _ in range(30):
            ex.spin_once(timeout_sec=0.02)
        assert ex._bus.routes[0].remote
    finally:
        rclpy.try_shutdown(context=outside_ctx)


def test_raw_subscription_gets_the_serialised_message(context):
    ex, pub, got, nodes = _pair(context, raw=True)
    pub.publish(Float64(data=2.5))
    assert _spin_until(ex, lambda: len(got) == 1)
    assert isinstance(got[0], bytes)
    assert deserialize_message(got[0], Float64).data == 2.5


def test_raw_subscription_with_info_gets_bytes_and_a_receive_time(context):
    a = rclpy.create_node('ipc_c', context=context)
    got = []
    pub = a.create_publisher(Float64, 'ipc_info', 10)
    a.create_subscription(Float64, 'ipc_info', lambda data, info: got.append((data, info)), 10,
                          raw=True)
    ex = LeanExecutor(context=context, intra_process=True)
    ex.add_node(a)
    ex.spin_once(timeout_sec=0)
    pub.publish(Float64(data=-1.0))
    assert _spin_until(ex, lambda: len(got) == 1)
    data, info = got[0]
    assert deserialize_message(data, Float64).data == -1.0
    assert info['received_timestamp'] > 0 and info['publication_sequence_number'] is None


def test_a_handover_sink_takes_the_raw_handovers_instead_of_the_callback(context):
    a = rclpy.create_node('ipc_sink', context=context)
    pub = a.create_publisher(Float64, 'ipc_sink', 10)
    called, sunk = [], []
    sub = a.create_subscription(Float64, 'ipc_sink', lambda data, info: called.append(data), 10,
                                raw=True)
    setattr(sub, HANDOVER_SINK, lambda data, t: sunk.append((data, t)))
    ex = LeanExecutor(context=context, intra_process=True)
    ex.add_node(a)
    ex.spin_once(timeout_sec=0)
    before = time.time_ns()
    for x in (1.5, -2.0, 3.25):
        pub.publish(Float64(data=x))
    assert _spin_until(ex, lambda: len(sunk) == 3)
    assert called == []
    assert [deserialize_message(d, Float64).data for d, _ in sunk] == [1.5, -2.0, 3.25]
    assert all(type(d) is bytes for d, _ in sunk)
    times = [t for _, t in sunk]
    assert before <= times[0] <= times[1] <= times[2] <= time.time_ns()


def test_a_handover_sink_is_served_in_the_background_lanes_slices(context):
    """The lane's time slice holds with a sink too: a sink that takes 1 ms a message gets at
    most 3 of 20 in a 2 ms slice, and the rest, in order, in later slices.
    """
    a = rclpy.create_node('ipc_sink_slices', context=context)
    pub = a.create_publisher(Float64, 'ipc_sink_slices', 30)
    sub = a.create_subscription(Float64, 'ipc_sink_slices', lambda data, info: None, 30,
                                raw=True)
    sunk = []

    def slow_sink(data, t):
        time.sleep(0.001)
        sunk.append(deserialize_message(data, Float64).data)
    setattr(sub, HANDOVER_SINK, slow_sink)
    ex = LeanExecutor(context=context, intra_process=True)
    ex.add_node(a)
    ex.spin_once(timeout_sec=0)
    for i in range(20):
        pub.publish(Float64(data=float(i)))
    assert len(ex._bus.background) == 20
    assert 1 <= ex._bus.deliver(None, 2_000_000) <= 3
    while ex._bus.background:
        ex._bus.deliver(None, 2_000_000)
    assert sunk == [float(i) for i in range(20)]


def test_incompatible_qos_and_transient_local_are_not_routed(context):
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    ex, pub, got, nodes = _pair(context, qos_pub=best_effort, qos_sub=reliable)
    assert ex._bus.routes == [], 'DDS would not match a best-effort writer to a reliable reader'
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    a = nodes[0]
    a.create_publisher(String, 'ipc_latched', latched)
    nodes[1].create_subscription(String, 'ipc_latched', lambda m: None, latched)
    ex.spin_once(timeout_sec=0)
    assert all(r.topic != '/ipc_latched' for r in ex._bus.routes)


def test_wrong_type_still_raises(context):
    ex, pub, got, nodes = _pair(context)
    with pytest.raises(TypeError):
        pub.publish(String(data='x'))


def test_env_switch():
    assert enabled_by_env({})
    assert enabled_by_env({'IRS_INTRA_PROCESS': '1'})
    for off in ('0', 'false', 'OFF', 'no'):
        assert not enabled_by_env({'IRS_INTRA_PROCESS': off})


def _chain_and_recorder(context, limit):
    """Node ``ctl`` answers each message on ``ping`` with ``data + 1`` on ``ping`` until
    ``limit`` (a control chain); node ``rec`` takes ``ping`` raw (a composed recorder). Both log
    into one list of events, in call order.
    """
    topic = f'ping_{uuid.uuid4().hex[:8]}'
    ctl = rclpy.create_node('ipc_ctl', context=context)
    rec = rclpy.create_node('ipc_rec', context=context)
    events = []
    pub = ctl.create_publisher(Float64, topic, 10)

    def on_ping(msg):
        events.append(('ctl', msg.data))
        if msg.data < limit:
            pub.publish(Float64(data=msg.data + 1.0))
    ctl.create_subscription(Float64, topic, on_ping, 10)
    def on_raw(data):
        events.append(('rec', deserialize_message(data, Float64).data))
    rec.create_subscription(Float64, topic, on_raw, 10, raw=True)
    ex = LeanExecutor(context=context, intra_process=True)
    ex.add_node(ctl)
    ex.add_node(rec)
    ex.spin_once(timeout_sec=0)
    return ex, pub, events


def test_recorder_copies_wait_until_the_control_chain_is_done(context):
    """Raw subscriptions are a background lane: a 10-hop chain runs to its end before the
    recorder's first copy is serialised, and the recorder still gets every message, in order.
    """
    ex, pub, events = _chain_and_recorder(context, limit=10.0)
    pub.publish(Float64(data=0.0))
    assert _spin_until(ex, lambda: sum(e[0] == 'rec' for e in events) == 11)
    kinds = [k for k, _ in events]
    assert kinds == ['ctl'] * 11 + ['rec'] * 11, kinds
    assert [v for k, v in events if k == 'rec'] == [float(i) for i in range(11)]


def test_background_lane_is_not_starved_by_an_endless_chain(context):
    """A lock-step loop never empties the first queue; when the handover budget runs out the
    background lane is delivered whole, so the recorder keeps up with the chain.
    """
    ex, pub, events = _chain_and_recorder(context, limit=float('inf'))
    ex._handover_budget_ns = 1_000_000           # 1 ms per spin_once
    pub.publish(Float64(data=0.0))
    for _ in range(5):
        ex.spin_once(timeout_sec=0)
        n_ctl = sum(k == 'ctl' for k, _ in events)
        n_rec = sum(k == 'rec' for k, _ in events)
        assert n_ctl > 0 and n_rec >= n_ctl - 1, (n_ctl, n_rec)   # at most the newest pending


def test_background_lane_is_delivered_when_spin_stops(context):
    """A stop request ends ``spin``; the copies still queued for the recorder are delivered
    before it returns (the bag gets them before the recorder closes it).
    """
    ex, pub, events = _chain_and_recorder(context, limit=0.0)
    raw_target = next(t for t in ex._bus.routes[0].targets if t[1])   # (sub, raw, info)
    for i in range(3):
        ex._bus.background.append((raw_target, Float64(data=float(i))))
    ex.request_stop()
    ex.spin()
    assert [v for k, v in events if k == 'rec'] == [0.0, 1.0, 2.0]
