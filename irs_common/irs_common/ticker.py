"""Call a function once per simulation tick (lock-step) or at a fixed wall rate (real time).

With ``use_sim_time`` the callback runs once per new ``/clock`` time, with that time as stamp:
in lock-step runs every tick gets exactly one publication, stamped like the rig's outputs of that
step. A tick the rig publishes again (vehicle_sim's ``lockstep_resend_period``) is answered
again, so that a consumer that missed the first answer gets it; older ticks are ignored. Without sim time, a timer at ``rate_hz`` calls it with the node clock's time.
"""
from rosgraph_msgs.msg import Clock

from . import qos


def create_ticker(node, rate_hz: float, callback):
    """Arrange ``callback(stamp: builtin_interfaces/Time)`` per tick; returns the entity."""
    if node.get_parameter('use_sim_time').value:
        last = [-1]

        def on_clock(msg):
            ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
            if ns >= last[0]:
                last[0] = ns
                callback(msg.clock)
        return node.create_subscription(Clock, '/clock', on_clock, qos.CLOCK)
    return node.create_timer(1.0 / rate_hz, lambda: callback(node.get_clock().now().to_msg()))
