"""The LeanExecutor's slow chores: services, QoS events and the route lookup, one per spin_once.

A 1 kHz loop composed with the recorder has about 45 services, 200 QoS event handlers and 15
in-process routes. Adding all of them to one wait set, and asking the graph about every route,
cost 0.5 ms in one ``spin_once`` every 10 ms: a deadline miss each time. The executor now polls
services every ``slow_period``, the event handlers every ``event_period`` and the graph every
``graph_period``, never two of them in the same ``spin_once``. These tests spin real nodes.
"""
import time
import uuid

import numpy as np
import pytest
import rclpy
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64

from irs_common.executor import LeanExecutor


def _composed_pair(context, **periods):
    topic = f'chores_{uuid.uuid4().hex[:8]}'
    a = rclpy.create_node('chores_a', context=context)
    b = rclpy.create_node('chores_b', context=context)
    a.create_publisher(Float64, topic, 10)
    b.create_subscription(Float64, topic, lambda _m: None, 10)
    ex = LeanExecutor(context=context, intra_process=True, **periods)
    ex.add_node(a)
    ex.add_node(b)
    ex.spin_once(timeout_sec=0)      # gathers the entities and routes the publisher
    return ex, (a, b)


@pytest.mark.exclusive   # spins for 1 s of wall time: the other worker's load would stretch it
def test_each_chore_keeps_its_period_and_no_two_share_a_spin(context):
    periods = {'services': 0.01, 'events': 0.1, 'graph': 0.05}
    ex, nodes = _composed_pair(context, slow_period=periods['services'],
                               event_period=periods['events'], graph_period=periods['graph'])
    waitables = ex._entities.waitables
    assert waitables, 'every publisher and subscription has QoS event handlers'
    spin = [0]
    chores = {}                      # spin index -> chores done in it
    times = {name: [] for name in periods}    # chore -> the executor's time [ns] of each turn

    def mark(name):
        chores.setdefault(spin[0], set()).add(name)

    first = waitables[0]
    add_events = first.add_to_wait_set
    first.add_to_wait_set = lambda ws: (mark('events'), add_events(ws))[1]
    refresh = ex._bus.refresh
    ex._bus.refresh = lambda: (mark('graph'), refresh())[1]
    due = {'services': '_next_slow_ns', 'events': '_next_event_ns', 'graph': '_next_graph_ns'}
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        spin[0] += 1
        before = {name: getattr(ex, attr) for name, attr in due.items()}
        ex.spin_once(timeout_sec=0.002)
        for name, attr in due.items():   # a turn sets the next one a period after its start
            if getattr(ex, attr) != before[name]:
                times[name].append(getattr(ex, attr) - int(periods[name] * 1e9))
        if ex._next_slow_ns != before['services']:
            mark('services')
    assert all(len(done) == 1 for done in chores.values()), \
        [sorted(d) for d in chores.values() if len(d) > 1]
    # every interval between two turns of a chore: never shorter than its period (exact: the
    # next turn is due a period after the last), and over all of them, on the median, within
    # twice the period (a loaded machine stretches single ones)
    for name, period in periods.items():
        gaps = np.diff(np.asarray(times[name], dtype=np.int64)) * 1e-9
        assert gaps.size >= 3, (name, times[name])
        assert gaps.min() >= period - 1e-6, (name, gaps.min())
        assert np.median(gaps) <= 2.0 * period, (name, np.median(gaps))
    for node in nodes:
        node.destroy_node()


def test_a_qos_event_is_still_delivered(context):
    """A reliable subscription to a best-effort publisher: the incompatible-QoS event arrives."""
    topic = f'chores_qos_{uuid.uuid4().hex[:8]}'
    node = rclpy.create_node('chores_qos', context=context)
    seen = []
    node.create_publisher(Float64, topic,
                          QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    node.create_subscription(
        Float64, topic, lambda _m: None,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
        event_callbacks=SubscriptionEventCallbacks(incompatible_qos=seen.append))
    ex = LeanExecutor(context=context, event_period=0.05)
    ex.add_node(node)
    end = time.monotonic() + 10.0
    while not seen and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.01)
    assert seen, 'the incompatible-QoS event never reached its callback'
    assert seen[0].total_count >= 1
    node.destroy_node()


def test_a_service_is_answered_within_the_slow_period(context):
    """A parameter request (one of every node's services) is answered while the executor spins."""
    from rcl_interfaces.srv import GetParameters
    server = rclpy.create_node('chores_server', context=context)
    server.declare_parameter('gain', 2.5)
    client_node = rclpy.create_node('chores_client', context=context)
    cli = client_node.create_client(GetParameters, '/chores_server/get_parameters')
    ex = LeanExecutor(context=context)
    ex.add_node(server)
    ex.add_node(client_node)
    end = time.monotonic() + 10.0
    while not cli.service_is_ready() and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.01)
    future = cli.call_async(GetParameters.Request(names=['gain']))
    end = time.monotonic() + 10.0
    while not future.done() and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.01)
    assert future.done(), 'the parameter service never answered'
    assert future.result().values[0].double_value == 2.5
    server.destroy_node()
    client_node.destroy_node()
