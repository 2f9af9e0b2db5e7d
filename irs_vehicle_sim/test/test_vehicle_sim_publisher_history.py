"""Every per-step output of the lock-step rig, ``/clock`` included, keeps
``irs_common.qos.PUBLISHER_HISTORY`` samples: the rig steps at its controller's pace, and a
reliable reader (the recorder) that falls behind loses what the writer no longer holds.
"""
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter

from irs_common.qos import PUBLISHER_HISTORY

PER_STEP = {'/clock', '/arm/joint_states', '/belt/speed', '/steering/state',
            '/ground_truth/odom', '/ground_truth/sensor_point'}


def test_lockstep_rig_outputs_keep_the_publisher_history():
    from irs_vehicle_sim.vehicle_sim_node import VehicleSimNode
    ctx = Context()
    rclpy.init(context=ctx)
    try:
        node = VehicleSimNode(context=ctx, parameter_overrides=[
            Parameter('clock_mode', value='lockstep')])
        try:
            depth = {p.topic_name: p.qos_profile.depth for p in node.publishers}
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)
    assert PER_STEP <= set(depth), depth
    assert {t: depth[t] for t in PER_STEP if depth[t] < PUBLISHER_HISTORY} == {}
