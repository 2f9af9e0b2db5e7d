"""An experiment file as an offline :class:`~irs_bringup.paper.closed_loop.LoopConfig`.

No rclpy.
"""
from ..paper.closed_loop import LoopConfig
from .experiment import Experiment, RIG_KEY, node_parameters


def loop_config_from_experiment(exp: Experiment) -> LoopConfig:
    """The same parameters the graph's nodes get, per node, for the offline closed loop."""
    def params(package, executable):
        entry = exp.node(package, executable)
        return None if entry is None else node_parameters(entry)

    rig = params(*RIG_KEY) or {}
    return LoopConfig(
        rig=rig,
        estimator=params('irs_sensing', 'arm_pose_estimator') or {},
        controller=params('irs_control', 'lateral_controller'),
        reference=params('irs_control', 'reference_generator'),
        regulator=params('irs_treadmill', 'treadmill_regulator'),
        driver=params('irs_bringup', 'driver'),
        default_drive_voltage=float(rig.get('default_drive_voltage', 0.0)))
