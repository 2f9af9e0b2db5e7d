"""An experiment file as the offline twin's configuration, and its run without ROS.

The twin's loops take, per node, the same flat parameters the graph's nodes get
(:func:`~irs_bringup.experiment.node_parameters`: the node's parameter files, then the
experiment's ``params``), so one experiment file drives both. No rclpy.
"""
from ..experiment import (HARDWARE_RIG_KEY, RIG_KEY, Experiment, ExperimentError,
                          load_experiment, node_parameters)
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


def refuse_as_the_node_does(exp: Experiment, log=print) -> None:
    """The ``lateral_controller``'s start-up design check on the experiment's controller: the
    ``ValueError`` the node raises for a design unstable on its configured plant (unless
    ``allow_unstable_design``), so that ``experiment run --offline`` refuses what the graph
    refuses. The offline loop itself does not check (a sweep explores unstable designs too).
    """
    entry = exp.node('irs_control', 'lateral_controller')
    if entry is None:
        return
    from irs_control.controller_factory import make_controller
    from irs_control.design_check import require_stable
    from irs_control.lateral_params import controller_config
    try:
        cfg = controller_config(node_parameters(entry))
        spec = make_controller(cfg)
        _check, message, ok = require_stable(cfg, spec.controller, spec.design,
                                             f"{cfg['mode'].upper()} design")
    except ValueError as exc:
        raise ValueError(f'nodes.{entry.name}: {exc}') from None
    if not ok:
        log(f'[experiment] warning: {message}')


def chassis_loop_config(exp: Experiment) -> ChassisLoopConfig:
    """The parameters an experiment file gives each node of the torque-car graph."""
    rig = _params(exp, *RIG_KEY) or {}
    return ChassisLoopConfig(
        rig=rig, estimator=_params(exp, 'irs_sensing', 'arm_pose_estimator') or {},
        regulator=_params(exp, 'irs_treadmill', 'treadmill_regulator'),
        chassis=_params(exp, 'irs_control', 'chassis_controller') or {},
        default_drive_voltage=float(rig.get('default_drive_voltage', 0.0)))


def hardware_loop(exp: Experiment):
    """The hardware loop of an experiment whose rig is ``rig_hardware``: its ``board`` device's
    arguments build the emulated board, the node's parameters the core and its calibration
    (the torque car's loop with a ``chassis_controller``).
    """
    from irs_hardware.calibration import load_calibration
    from irs_hardware.emulator.board_main import board_from_args
    from irs_hardware.hardware_params import hardware_config
    from irs_hardware.paths import resolve

    from .hardware_loop import EmulatedHardwareRig, HardwareChassisLoop, HardwareClosedLoop
    if 'board' not in exp.devices:
        raise ValueError('a rig_hardware experiment needs a devices.board entry (the emulator)')
    _package, _executable, args = exp.devices['board']
    node = node_parameters(exp.rig())
    rig = EmulatedHardwareRig(board_from_args(args), load_calibration(
        resolve(node.get('calibration', ''))), hardware_config(node))
    if exp.node('irs_control', 'chassis_controller') is not None:
        return HardwareChassisLoop(chassis_loop_config(exp), rig)
    return HardwareClosedLoop(loop_config_from_experiment(exp), rig)


def offline_run(experiment) -> dict:
    """The experiment's loop without ROS: arrays as :meth:`ClosedLoop.run` returns them (the
    torque car's, with a ``chassis_controller``: as :meth:`ChassisLoop.run` returns them; on
    ``rig_hardware``: the hardware core on the emulated devices, :func:`hardware_loop`).

    ``experiment``: a loaded :class:`~irs_bringup.experiment.Experiment`, or a name or path.
    A parameter the cores refuse (what the tables could not check) is an
    :class:`~irs_bringup.experiment.ExperimentError` line naming the file.
    """
    exp = experiment if isinstance(experiment, Experiment) else load_experiment(str(experiment))
    torque_car = exp.node('irs_control', 'chassis_controller') is not None
    try:
        if exp.rig() is not None and exp.rig().key == HARDWARE_RIG_KEY:
            loop = hardware_loop(exp)
        elif torque_car:
            loop = ChassisLoop(chassis_loop_config(exp))
        else:
            loop = ClosedLoop(loop_config_from_experiment(exp))
    except (ValueError, TypeError, KeyError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        what = 'the offline torque-car loop' if torque_car else 'the offline closed loop'
        raise ExperimentError(f'{exp.path}: nodes: {what} refuses a parameter: '
                              f'{" ".join(str(msg).split())}') from None
    return loop.run(exp.duration)
