"""The node's ``/clock`` subscription, validated: bad clock messages are dropped, not fatal.

rclpy's ``TimeSource`` subscribes ``/clock`` for every node with ``use_sim_time`` and converts each
message with ``Time.from_msg``, which raises on a negative time: one bad ``/clock`` message ends
the
node. ``guard_clock(node)`` replaces that subscription (``node._time_source._clock_sub``, rclpy
7.1.6; the one place that knows this internal) by one whose callback

1. drops a clock with a negative ``sec`` or ``nanosec`` >= 1e9, with a throttled warning;
2. hands the valid ones to the ``TimeSource`` (every clock of the node follows, as before);
3. calls ``on_clock(stamp, ns)`` if given: the ticker of :mod:`irs_common.ticker` rides on it, so a
   node that acts on every tick receives ``/clock`` once per step, not twice.

``qos`` defaults to rclpy's own (best effort, depth 1: a node only needs the newest time); a ticker
passes ``irs_common.qos.CLOCK`` (reliable, so no tick is lost between processes).
"""
from rclpy.qos import QoSProfile, ReliabilityPolicy
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


def guard_clock(node, on_clock=None, qos=TIME_SOURCE_QOS):
    """Replace the node's ``/clock`` subscription (module docstring); None without sim time."""
    source = node._time_source
    if source._clock_sub is None or (on_clock is None and getattr(source, '_irs_guarded', False)):
        return None     # no sim time, or already guarded (a ticker's subscription stays)
    source._irs_guarded = True
    log = node.get_logger()

    def callback(msg):
        problem = clock_problem(msg.clock)
        if problem is not None:
            log.warning(f'/clock message ignored: {problem}', throttle_duration_sec=1.0)
            return
        source.clock_callback(msg)
        if on_clock is not None:
            on_clock(msg.clock, msg.clock.sec * 1_000_000_000 + msg.clock.nanosec)

    node.destroy_subscription(source._clock_sub)
    source._clock_sub = node.create_subscription(Clock, '/clock', callback, qos)
    return source._clock_sub
