"""guard_clock: the node's ``/clock`` callback sets its clocks as rclpy's ``TimeSource`` does,
and drops a clock that is not a time. The callback is called directly (no DDS needed).
"""
from builtin_interfaces.msg import Time as TimeMsg
from hypothesis import given, settings, strategies as st
import pytest
from rclpy.clock import ROSClock
from rclpy.clock_type import ClockType
from rclpy.node import Node
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

from irs_common.sim_time import guard_clock, time_point


@pytest.fixture
def node(context):
    made = Node('sim_time_test', context=context,
                cli_args=['--ros-args', '-p', 'use_sim_time:=true'])
    yield made
    made.destroy_node()


def _clock(sec, nanosec):
    return Clock(clock=TimeMsg(sec=sec, nanosec=nanosec))


@settings(max_examples=200, deadline=None)
@given(sec=st.integers(0, 2**31 - 1), nanosec=st.integers(0, 999_999_999))
def test_time_point_equals_rclpys_time(sec, nanosec):
    ns = sec * 1_000_000_000 + nanosec
    ours, theirs = time_point(ns), Time(nanoseconds=ns, clock_type=ClockType.ROS_TIME)
    assert ours == theirs and ours.clock_type == theirs.clock_type
    assert ours.to_msg() == TimeMsg(sec=sec, nanosec=nanosec)


def test_the_guarded_callback_sets_every_clock_and_calls_on_clock(node):
    ticks = []
    sub = guard_clock(node, lambda stamp, ns: ticks.append((stamp.sec, stamp.nanosec, ns)))
    later = ROSClock()
    sub.callback(_clock(12, 345_678_901))
    assert node.get_clock().now().nanoseconds == 12_345_678_901
    assert ticks == [(12, 345_678_901, 12_345_678_901)]
    # a clock attached after the message starts at the last time, as with TimeSource's callback
    node._time_source.attach_clock(later)
    assert later.now() == Time(nanoseconds=12_345_678_901, clock_type=ClockType.ROS_TIME)
    sub.callback(_clock(13, 0))
    assert later.now().nanoseconds == node.get_clock().now().nanoseconds == 13_000_000_000


def test_two_nodes_taking_one_clock_value_in_turn_both_follow_every_value(context, node):
    other = Node('sim_time_other', context=context,
                 cli_args=['--ros-args', '-p', 'use_sim_time:=true'])
    try:
        subs = (guard_clock(node), guard_clock(other))
        for sec, nanosec in ((3, 0), (3, 1_000_000), (3, 1_000_000), (2, 999_999_999)):
            for sub in subs:
                sub.callback(_clock(sec, nanosec))
            ns = sec * 1_000_000_000 + nanosec
            assert node.get_clock().now().nanoseconds == ns
            assert other.get_clock().now().nanoseconds == ns
            # the TimeSource's last time (for a clock attached later) is that value too
            assert node._time_source._last_time_set.nanoseconds == ns
            assert other._time_source._last_time_set.nanoseconds == ns
    finally:
        other.destroy_node()


@pytest.mark.parametrize('sec, nanosec', [(-1, 0), (5, 1_000_000_000)])
def test_a_clock_that_is_no_time_is_dropped_and_the_clock_stays(node, sec, nanosec):
    ticks = []
    sub = guard_clock(node, lambda stamp, ns: ticks.append(ns))
    sub.callback(_clock(7, 0))
    sub.callback(_clock(sec, nanosec))
    assert node.get_clock().now().nanoseconds == 7_000_000_000
    assert ticks == [7_000_000_000]
