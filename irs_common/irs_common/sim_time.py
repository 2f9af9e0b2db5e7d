"""The node's ``/clock`` subscription, validated: bad clock messages are dropped, not fatal.

rclpy's ``TimeSource`` subscribes ``/clock`` for every node with ``use_sim_time`` and converts each
message with ``Time.from_msg``, which raises on a negative time: one bad ``/clock`` message ends
the
node. ``guard_clock(node)`` replaces that subscription (``node._time_source._clock_sub``, rclpy
7.1.6; the one place that knows this internal) by one whose callback

1. drops a clock with a negative ``sec`` or ``nanosec`` >= 1e9, with a throttled warning;
2. hands the valid ones to the ``TimeSource``: every clock of the node follows, and the source
   keeps the time for a clock attached later, as ``TimeSource.clock_callback`` does;
3. calls ``on_clock(stamp, ns)`` if given: the ticker of :mod:`irs_common.ticker` rides on it, so a
   node that acts on every tick receives ``/clock`` once per step, not twice.

Step 2 sets each clock's override through its ``rcl_time_point_t`` handle (rclpy 7.1.6's
``Clock.set_ros_time_override`` without the ``Time`` object's validating constructor, which the
check of step 1 already covers). Every sim-time node takes this callback once per step: four in
a composed Figure 10 graph, 4,000 a second; the nodes of one process share the time point of a
clock value.

``qos`` defaults to rclpy's own (best effort, depth 1: a node only needs the newest time); a ticker
passes ``irs_common.qos.CLOCK`` (reliable, so no tick is lost between processes).
"""
from rclpy.clock_type import ClockType
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

#: rclpy's TimeSource QoS for /clock.
TIME_SOURCE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)


def clock_problem(stamp) -> str | None:
    """Why a ``builtin_interfaces/Time`` cannot be a clock value, or None."""
    if stamp.sec < 0:
        return f'negative time {stamp.sec} s'
    if stamp.nanosec >= 1_000_000_000:
        return f'nanosec {stamp.nanosec} >= 1e9'
    return None


def time_point(ns: int) -> Time:
    """``rclpy.time.Time(nanoseconds=ns, clock_type=ROS_TIME)`` for a checked ``0 <= ns < 2**63``,
    built without the constructor's checks (rclpy 7.1.6: the handle is its only state).
    """
    t = Time.__new__(Time)
    t._time_handle = _rclpy.rcl_time_point_t(ns, ClockType.ROS_TIME)
    return t


#: The last clock value taken [ns] and its time point: the nodes of one process take each step's
#: ``/clock`` one after the other, and a ``Time`` is immutable, so the second to fourth node of a
#: composed Figure 10 step share the first one's.
_last: tuple = (None, None)


def guard_clock(node, on_clock=None, qos=TIME_SOURCE_QOS):
    """Replace the node's ``/clock`` subscription (module docstring); None without sim time."""
    source = node._time_source
    if source._clock_sub is None or (on_clock is None and getattr(source, '_irs_guarded', False)):
        return None     # no sim time, or already guarded (a ticker's subscription stays)
    source._irs_guarded = True
    log = node.get_logger()

    def callback(msg):
        stamp = msg.clock
        sec, nanosec = stamp.sec, stamp.nanosec
        if sec < 0 or nanosec >= 1_000_000_000:
            log.warning(f'/clock message ignored: {clock_problem(stamp)}',
                        throttle_duration_sec=1.0)
            return
        global _last
        ns = sec * 1_000_000_000 + nanosec
        point = _last[1] if _last[0] == ns else None
        if point is None:   # not the time another node of the process has just taken
            point = time_point(ns)
            _last = (ns, point)
        source._last_time_set = point
        handle = point._time_handle
        for clock in source._associated_clocks:
            clock_handle = clock.handle
            with clock_handle:
                clock_handle.set_ros_time_override(handle)
        if on_clock is not None:
            on_clock(stamp, ns)

    node.destroy_subscription(source._clock_sub)
    source._clock_sub = node.create_subscription(Clock, '/clock', callback, qos)
    return source._clock_sub
