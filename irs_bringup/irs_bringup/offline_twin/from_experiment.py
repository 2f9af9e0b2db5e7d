"""An experiment file as the offline twin's configuration, and its run without ROS.

The twin's loops take, per node, the same flat parameters the graph's nodes get
(:func:`~irs_bringup.experiment.node_parameters`: the node's parameter files, then the
experiment's ``params``), so one experiment file drives both. No rclpy.
"""
from ..experiment import RIG_KEY, Experiment, ExperimentError, load_experiment, node_parameters
from .chassis_loop import ChassisLoop, ChassisLoopConfig
from .lateral_loop import ClosedLoop, LoopConfig


def _params(exp: Experiment, package: str, executable: str):
    entry = exp.node(package, executable)
    return None if entry is None else node_parameters(entry)


def loop_config_from_experiment(exp: Experiment) -> LoopConfig:
    """The same parameters the graph's nodes get, per node, for the lateral loop."""
    rig = _params(exp, *RIG_KEY) or {}
    return LoopConfig(
        rig=rig,
        estimator=_params(exp, 'irs_sensing', 'arm_pose_estimator') or {},
        controller=_params(exp, 'irs_control', 'lateral_controller'),
        reference=_params(exp, 'irs_control', 'reference_generator'),
        regulator=_params(exp, 'irs_treadmill', 'treadmill_regulator'),
        driver=_params(exp, 'irs_bringup', 'driver'),
        default_drive_voltage=float(rig.get('default_drive_voltage', 0.0)))


def chassis_loop_config(exp: Experiment) -> ChassisLoopConfig:
    """The parameters an experiment file gives each node of the torque-car graph."""
    rig = _params(exp, *RIG_KEY) or {}
    return ChassisLoopConfig(
        rig=rig, estimator=_params(exp, 'irs_sensing', 'arm_pose_estimator') or {},
        regulator=_params(exp, 'irs_treadmill', 'treadmill_regulator'),
        chassis=_params(exp, 'irs_control', 'chassis_controller') or {},
        default_drive_voltage=float(rig.get('default_drive_voltage', 0.0)))


def offline_run(experiment) -> dict:
    """The experiment's loop without ROS: arrays as :meth:`ClosedLoop.run` returns them (the
    torque car's, with a ``chassis_controller``: as :meth:`ChassisLoop.run` returns them).

    ``experiment``: a loaded :class:`~irs_bringup.experiment.Experiment`, or a name or path.
    A parameter the cores refuse (what the tables could not check) is an
    :class:`~irs_bringup.experiment.ExperimentError` line naming the file.
    """
    exp = experiment if isinstance(experiment, Experiment) else load_experiment(str(experiment))
    torque_car = exp.node('irs_control', 'chassis_controller') is not None
    try:
        loop = ChassisLoop(chassis_loop_config(exp)) if torque_car \
            else ClosedLoop(loop_config_from_experiment(exp))
    except (ValueError, TypeError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        what = 'the offline torque-car loop' if torque_car else 'the offline closed loop'
        raise ExperimentError(f'{exp.path}: nodes: {what} refuses a parameter: '
                              f'{" ".join(str(msg).split())}') from None
    return loop.run(exp.duration)
