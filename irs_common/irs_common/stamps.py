"""Conversions between ``builtin_interfaces/Time`` and integer nanoseconds / float seconds."""
from builtin_interfaces.msg import Time


def to_ns(stamp) -> int:
    """``builtin_interfaces/Time`` -> int nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def from_ns(ns: int) -> Time:
    """int nanoseconds -> ``builtin_interfaces/Time``."""
    ns = int(ns)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def to_sec(stamp) -> float:
    """``builtin_interfaces/Time`` -> float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9
