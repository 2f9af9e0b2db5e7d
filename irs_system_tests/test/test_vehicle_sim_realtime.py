"""vehicle_sim in real time: invalid and stale commands fall back to the safe value, reported."""
import math

from irs_common import qos
from irs_msgs.msg import RigStatus, SteeringActuatorState, SteeringCommand
from irs_bringup.processes import NodeSpec


def test_invalid_and_stale_steering_commands_give_zero_steer(ros, launch):
    launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                    params={'clock_mode': 'realtime', 'command_timeout': 0.2,
                            'start_inputs': ['steering']}))
    node = ros.node
    states, status = [], []
    pub = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)
    subs = [
        node.create_subscription(
            SteeringActuatorState, 'steering/state', states.append, qos.SENSOR
        ),
        node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS),
    ]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)

    def send(angle):
        cmd = SteeringCommand()
        cmd.header.stamp = node.get_clock().now().to_msg()
        cmd.front_angle = angle
        pub.publish(cmd)

    def keep_sending(angle, predicate, timeout=10.0):
        def step():
            send(angle)
            ros.executor.spin_once(timeout_sec=0.01)
            return predicate()
        return ros.spin_until(step, timeout)

    # A fresh valid command is applied.
    assert keep_sending(0.1, lambda: states and states[-1].front_commanded == 0.1)
    # A NaN command is rejected: zero steer, counted on rig/status.
    assert keep_sending(math.nan, lambda: states[-1].front_commanded == 0.0)
    assert ros.spin_until(lambda: status and status[-1].rejected_steer_count > 0, 5.0)
    # Valid again, then silence: after command_timeout the rig steers 0.
    assert keep_sending(0.1, lambda: states[-1].front_commanded == 0.1)
    n = len(states)
    assert ros.spin_until(lambda: len(states) > n and states[-1].front_commanded == 0.0, 5.0)
