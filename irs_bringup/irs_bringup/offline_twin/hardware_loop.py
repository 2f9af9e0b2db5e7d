"""The lateral and the torque car's loops on the real rig's chain: the hardware node's core on
the emulated devices.

:class:`EmulatedHardwareRig` serves the rig's interface the loop steps (``config``,
``outputs``, ``step``) with what ``rig_hardware`` does in lock-step: each step's commands go
through :class:`~irs_hardware.hardware_rig.HardwareRig` (calibration, servo pulse, drive
set-point) to the emulated drive's registers and board (triggered mode, its lock-step delay),
whose SAMPLE (16-bit ADC counts, belt counter) the core turns back into the joint angles and
belt speed the estimator and regulator read; on the torque car also the wheel torques to the
motor commands and the wheel counters to the encoders' counts and velocities the chassis
controller reads. The emulated rig's ground truth (``y_s``, ``x``, the achieved steer, the
tyres) stays in the outputs, so the Figure 10 and torque car metrics apply. In-process, no ROS:
the graph's ``hil_*`` experiments must reproduce it to the bit (``irs_system_tests``).
"""
from dataclasses import replace

from irs_hardware.calibration import Calibration
from irs_hardware.emulator.board_core import BoardEmulator
from irs_hardware.emulator.loopback import LoopbackIO
from irs_hardware.hardware_rig import HardwareConfig, HardwareRig

from .chassis_loop import ChassisLoop, ChassisLoopConfig
from .lateral_loop import ClosedLoop, LoopConfig


class EmulatedHardwareRig:
    """``RigSimulation``'s stepping interface through the hardware core (module docstring)."""

    def __init__(self, board: BoardEmulator, cal: Calibration, config: HardwareConfig):
        self.board = board
        self.io = LoopbackIO(board, None, cal.servo.centre_us)
        self.core = HardwareRig(self.io, cal, config)
        self.config = board.sim.config
        self.io.start(True)
        self.outputs = self._measure()

    def _measure(self):
        readings = self.io.read(0.0)
        if not readings or not self.core.ok:
            raise RuntimeError(f'the emulated board did not answer ({self.core.fault})')
        m = self.core.measure(readings[-1])
        extra = {}
        if self.core.cfg.wheels:
            extra = dict(encoder_counts=m.wheel_counts, encoder_velocity=m.wheel_velocity)
        return replace(self.board.sim.outputs, arm_angles=m.angles,
                       belt_speed_measured=m.belt_speed, **extra)

    def step(self, inputs):
        """One lock-step: the commands to the devices, the board's answer measured."""
        self.core.command_steer(inputs.front_steer, 0.0)
        self.core.command_drive(inputs.drive_voltage, 0.0)
        if self.core.cfg.wheels:
            self.core.command_wheels(inputs.wheel_torque, inputs.wheel_locked, 0.0)
        self.core.write_outputs(self.core.last_tick, 0.0)
        self.outputs = self._measure()
        return self.outputs


class HardwareClosedLoop(ClosedLoop):
    """:class:`~.lateral_loop.ClosedLoop` with :class:`EmulatedHardwareRig` as its rig."""

    def __init__(self, cfg: LoopConfig, rig: EmulatedHardwareRig):
        super().__init__(cfg)
        self.rig = rig
        self.dt = rig.config.dt
        self.dt_ns = int(round(self.dt * 1e9))


class HardwareChassisLoop(ChassisLoop):
    """:class:`~.chassis_loop.ChassisLoop` with :class:`EmulatedHardwareRig` as its rig."""

    def __init__(self, cfg: ChassisLoopConfig, rig: EmulatedHardwareRig):
        super().__init__(cfg)
        self.rig = rig
        self.dt = rig.config.dt
