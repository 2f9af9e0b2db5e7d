"""clock_now_ns: the clock's reading in integer nanoseconds, as ``clock.now().nanoseconds``."""
from rclpy.clock import Clock, ClockType, ROSClock
from rclpy.time import Time

from irs_common.stamps import clock_now_ns


def test_clock_now_ns_reads_the_simulated_time_exactly():
    clock = ROSClock()
    clock._set_ros_time_is_active(True)
    for ns in (0, 1, 1_000_000, 8_000_000_001, 2**62):
        clock.set_ros_time_override(Time(nanoseconds=ns, clock_type=ClockType.ROS_TIME))
        assert clock_now_ns(clock) == clock.now().nanoseconds == ns


def test_clock_now_ns_lies_between_two_readings_of_a_steady_clock():
    clock = Clock(clock_type=ClockType.STEADY_TIME)
    before = clock.now().nanoseconds
    now = clock_now_ns(clock)
    after = clock.now().nanoseconds
    assert isinstance(now, int) and before <= now <= after
