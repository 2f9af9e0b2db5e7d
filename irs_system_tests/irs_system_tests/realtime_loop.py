"""The real-time graphs' nodes started the ROS way, each with its own installed parameter file.

:func:`loop_specs` gives the :class:`~irs_bringup.processes.NodeSpec` of the Figure 10 loop (the
rig, the estimator, the treadmill regulator, the controller and optionally the reference
generator, in the README's order) for the real-time graph tests (by hand, the plain start,
starvation); :func:`torque_car_specs` those of the torque car (docs/torque_car.md).
"""
from ament_index_python.packages import get_package_share_directory

from irs_bringup.processes import NodeSpec


def share(package: str, rel: str) -> str:
    """``share/<package>/<rel>`` of the installed package."""
    return f'{get_package_share_directory(package)}/{rel}'


#: The deployment file of the real-time graph: the rig's start pose (irs_bringup/config).
REALTIME = share('irs_bringup', 'config/realtime.yaml')


def loop_specs(rig_files=(), rig_params=None, reference_params=None,
               reference: bool = True) -> list:
    """The loop's node specs: ``rig_files`` after ``rig.yaml`` and ``rig_params`` on the rig,
    ``reference_params`` on the reference generator (left out unless ``reference``).
    """
    specs = [
        NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                 params_files=[share('irs_vehicle_sim', 'config/rig.yaml'), *rig_files],
                 params=dict(rig_params or {})),
        NodeSpec('irs_sensing', 'arm_pose_estimator',
                 params_files=[share('irs_sensing', 'config/sensing.yaml')]),
        NodeSpec('irs_treadmill', 'treadmill_regulator',
                 params_files=[share('irs_treadmill', 'config/treadmill.yaml')]),
        NodeSpec('irs_control', 'lateral_controller',
                 params_files=[share('irs_control', 'config/lateral_controller.yaml')]),
    ]
    if reference:
        specs.append(NodeSpec('irs_control', 'reference_generator',
                              params_files=[share('irs_control',
                                                  'config/reference_generator.yaml')],
                              params=dict(reference_params or {})))
    return specs


def torque_car_specs(rig_params=None) -> list:
    """The torque car's node specs as docs/torque_car.md starts them: the rig (``rig.yaml``,
    ``realtime.yaml``, ``plant: two_track`` and ``rig_params``), the estimator, the treadmill
    regulator and the chassis controller.
    """
    return [
        NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                 params_files=[share('irs_vehicle_sim', 'config/rig.yaml'), REALTIME],
                 params={'plant': 'two_track', **(rig_params or {})}),
        NodeSpec('irs_sensing', 'arm_pose_estimator',
                 params_files=[share('irs_sensing', 'config/sensing.yaml')]),
        NodeSpec('irs_treadmill', 'treadmill_regulator',
                 params_files=[share('irs_treadmill', 'config/treadmill.yaml')]),
        NodeSpec('irs_control', 'chassis_controller',
                 params_files=[share('irs_control', 'config/chassis_controller.yaml')]),
    ]
