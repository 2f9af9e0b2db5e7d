"""Conversions between ``builtin_interfaces/Time`` and integer nanoseconds / float seconds."""
from builtin_interfaces.msg import Time

from irs_common.msg_builder import builder

_TIME = builder(Time)


def to_ns(stamp) -> int:
    """``builtin_interfaces/Time`` -> int nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def from_ns(ns: int) -> Time:
    """int nanoseconds -> ``builtin_interfaces/Time``."""
    ns = int(ns)
    return _TIME(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def to_sec(stamp) -> float:
    """``builtin_interfaces/Time`` -> float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def clock_now_ns(clock) -> int:
    """``clock.now().nanoseconds`` of an rclpy ``Clock`` without building the ``Time`` object
    (its validating constructor costs more than the clock read; per message at 1 kHz).
    """
    handle = clock.handle
    with handle:
        return handle.get_now().nanoseconds
