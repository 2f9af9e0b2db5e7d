"""The torque car's experiment graph as one offline, ROS-free simulation.

The same cores as the lock-step graph, composed as :mod:`.lateral_loop` composes the Figure 10
loop; data flow per step k:

1. rig outputs at t_k (``vehicle_sim``, ``plant: two_track``): arm angles, belt encoder speed,
   wheel encoder velocities;
2. ``arm_pose_estimator``: pose and velocity from the angles (NaN when rejected); the heading
   goes through the quaternion the node publishes;
3. ``chassis_controller``: :class:`~irs_control.torque_car_control.TorqueCarController` with the
   pose, belt speed, yaw rate and encoder velocities of t_k -> wheel torques, locked flags, front
   and rear steer commands;
4. ``treadmill_regulator``: drive voltage from pose_k, velocity_k, belt speed_k (safety-gated);
5. the rig steps t_k -> t_{k+1} with those commands held.

Node parameters are the flat dicts the nodes take (an experiment file drives both); the graph's
recorded commands must equal :meth:`ChassisLoop.run`'s.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from irs_control.chassis_params import chassis_config
from irs_control.torque_car_control import TorqueCarController
from irs_vehicle_sim.rig import RigInputs

from .lateral_loop import ClosedLoop, LoopConfig, _yaw_via_quaternion

__all__ = ['ChassisLoopConfig', 'ChassisLoop']


@dataclass
class ChassisLoopConfig:
    """Flat parameter dicts per node (missing keys: the node's defaults)."""

    rig: dict = field(default_factory=dict)
    estimator: dict = field(default_factory=dict)
    regulator: dict | None = field(default_factory=dict)
    chassis: dict = field(default_factory=dict)
    default_drive_voltage: float = 0.0


class ChassisLoop(ClosedLoop):
    """Offline torque-car loop; :meth:`run` returns what the graph would publish and record."""

    def __init__(self, cfg: ChassisLoopConfig):
        super().__init__(LoopConfig(rig=cfg.rig, estimator=cfg.estimator, controller=None,
                                    reference=None, regulator=cfg.regulator,
                                    default_drive_voltage=cfg.default_drive_voltage))
        self.chassis = TorqueCarController(chassis_config(cfg.chassis))

    def _estimate(self, out):
        """Pose ``(x, y, psi)`` and yaw rate as the estimator node publishes them (NaN if none)."""
        try:
            angles = out.arm_angles
            if self.raw_input:
                angles = self.calibration.to_angles(tuple(angles))
            est, _reason = self.estimator.update(*angles, out.time)
        except ValueError:
            est = None
        if est is None:
            return None, (math.nan,) * 3, math.nan
        r = est.yaw_rate if est.velocity_valid else math.nan
        return est, (est.x_cg, est.y_cg, _yaw_via_quaternion(est.psi)), r

    def _voltage(self, est, t, belt):
        if self.regulator is None:
            return self.cfg.default_drive_voltage
        x = est.x_cg if est is not None else math.nan
        y = est.y_cg if est is not None else math.nan
        xdot = None
        if self.reg_use_velocity:
            xdot = math.nan
            if est is not None and est.velocity_valid:
                psi = _yaw_via_quaternion(est.psi)
                xdot = est.u * math.cos(psi) - est.v * math.sin(psi)
        self.safety.update_position(x, y, t, xdot=xdot)
        r = self.regulator.update(x, belt, self.reg_dt, xdot=xdot,
                                  enabled=self.safety.drive_permitted and self.reg_enabled)
        return self.safety.gate(r.voltage) if self.reg_enabled else 0.0

    def step_commands(self, out):
        """The commands of step k from the rig outputs at t_k: (RigInputs, TorqueCarOutput)."""
        est, (x, _y, psi), r = self._estimate(out)
        stamp_ns = int(round(out.time * 1e9))
        self.chassis.update_pose(stamp_ns, x, psi, out.belt_speed_measured)
        ctl = self.chassis.step(stamp_ns, out.encoder_velocity, r)
        voltage = self._voltage(est, out.time, out.belt_speed_measured)
        inputs = RigInputs(front_steer=ctl.front_steer, rear_steer=ctl.rear_steer,
                           drive_voltage=voltage, speed_cmd=self.rig.config.u0,
                           wheel_torque=tuple(float(v) for v in ctl.torques),
                           wheel_locked=tuple(ctl.locked))
        return inputs, ctl

    def run(self, duration: float) -> dict:
        """Simulate ``duration`` s: outputs of length N+1, commands of length N (row k answers
        the outputs of row k).
        """
        n = int(round(duration / self.dt))
        out = self.rig.outputs
        rows, tyres, cmds = [], [], []
        for _ in range(n + 1):
            tyre = out.tyre
            rows.append((out.time, out.x, out.y, out.psi, out.u, out.yaw_rate, out.belt_speed,
                         out.fault, tyre.x_belt))
            tyres.append((tyre.slip, tyre.omega, out.encoder_velocity))
            if len(cmds) == n:
                break
            inputs, ctl = self.step_commands(out)
            cmds.append((*inputs.wheel_torque, *inputs.wheel_locked, inputs.front_steer,
                         inputs.rear_steer, inputs.drive_voltage, ctl.v_hat, ctl.r_ref,
                         ctl.ok, ctl.v_ref, *ctl.slip_target))
            out = self.rig.step(inputs)
        a = np.array(rows, dtype=float)
        c = np.array(cmds, dtype=float).reshape(-1, 19)
        tyre = np.array(tyres, dtype=float).reshape(-1, 3, 4)
        return {'time': a[:, 0], 'x': a[:, 1], 'y': a[:, 2], 'psi': a[:, 3], 'u': a[:, 4],
                'yaw_rate': a[:, 5], 'belt_speed': a[:, 6], 'fault': a[:, 7].astype(bool),
                'x_belt': a[:, 8], 'slip': tyre[:, 0], 'omega': tyre[:, 1],
                'encoder_velocity': tyre[:, 2], 'torque': c[:, 0:4],
                'locked': c[:, 4:8].astype(bool), 'front_steer': c[:, 8], 'rear_steer': c[:, 9],
                'drive_voltage': c[:, 10], 'v_hat': c[:, 11], 'r_ref': c[:, 12],
                'input_ok': c[:, 13].astype(bool), 'v_ref': c[:, 14], 'slip_target': c[:, 15:19]}

