"""Run a node the way the ROS 2 examples do, so that SIGINT/SIGTERM end it with exit code 0."""
import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor


def run_node(node_factory, args=None) -> int:
    """``rclpy.init``, build the node, spin until shutdown, clean up; return the exit code.

    Configuration errors raised by the node's constructor (``ValueError``) are reported as one
    log line and exit code 2, not a traceback. A SIGINT/SIGTERM at any moment, also while the node
    is still being built, ends it with exit code 0.
    """
    rclpy.init(args=args)
    node = None
    try:
        node = node_factory()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ValueError as exc:
        if not rclpy.ok():
            return 0  # shut down by a signal while starting up
        print(f'[FATAL] configuration error: {exc}', file=sys.stderr)
        return 2
    except Exception:
        if rclpy.ok():
            raise
        return 0  # a signal shut the context down while the node was being built
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
