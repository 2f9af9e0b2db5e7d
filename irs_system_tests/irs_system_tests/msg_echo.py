"""Echo every irs_msgs message type: ``echo_in/<Type>`` -> ``echo_out/<Type>`` (test helper).

Run as a separate process (``python -m irs_system_tests.msg_echo``) by
test_irs_msgs_transport.py, so each message crosses Fast DDS twice between two processes.
"""
import importlib
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)


def main():
    names = sys.argv[1:]
    msgs = importlib.import_module('irs_msgs.msg')
    rclpy.init()
    node = rclpy.create_node('irs_msg_echo')
    pubs = {}
    for name in names:
        mtype = getattr(msgs, name)
        pubs[name] = node.create_publisher(mtype, f'echo_out/{name}', QOS)
        node.create_subscription(mtype, f'echo_in/{name}',
                                 lambda m, n=name: pubs[n].publish(m), QOS)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
