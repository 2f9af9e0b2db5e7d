"""Call a node's handler when its clock jumps back (``/clock`` going backwards).

``bag play --loop --clock`` (or a restarted rig in lock-step) sends ``/clock`` back in time. A node
that keeps stamps, histories, filters or stale timers must forget them then, or it would drop
every later message as out of order. ``on_time_jump_back(node, handler)`` registers rclpy's clock
jump callback on the node's clock (``JumpThreshold(min_backward=-1 ns)``, not on a change of the
clock type) and calls ``handler(delta_ns)`` (``delta_ns < 0``) after the new time is set. It
returns the ``JumpHandle``; the caller keeps it (the callback lives as long as the handle).

The callback runs inside the node's ``/clock`` callback (same thread as every other callback of
the node's executor), so the handler needs no locking. An exception in the handler is logged,
not raised: a clock jump must not end the node.
"""
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration


def on_time_jump_back(node, handler):
    """Register ``handler(delta_ns)`` for backward jumps of ``node``'s clock (module docstring)."""
    threshold = JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1),
                              on_clock_change=False)
    log = node.get_logger()

    def post(jump):
        delta = jump.delta.nanoseconds
        log.warning(f'clock jumped back by {-delta * 1e-9:.6f} s: time state reset')
        try:
            handler(delta)
        except Exception as exc:     # noqa: BLE001 -- must not propagate into the clock update
            log.error(f'resetting after the clock jump failed: {exc!r}')

    return node.get_clock().create_jump_callback(threshold, post_callback=post)
