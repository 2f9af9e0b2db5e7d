"""The experiment graph as one offline, ROS-free simulation of the same cores.

Data flow per step k (exactly the ROS graph's, see docs/architecture.md):

1. rig outputs at t_k (``vehicle_sim``): arm angles, belt encoder speed;
2. ``arm_pose_estimator``: pose, velocity and sensor point from the angles (NaN when rejected);
3. ``reference_generator``: r(t_k);  ``driver``: speed command v(t_k);
4. ``lateral_controller``: steer_k from (r_k, y_s,k) by the controller's ``step_checked`` (its
   bad-input rule: zero steer and a reset for a NaN/out-of-range measurement, the last valid
   reference held for an invalid one);
5. ``treadmill_regulator``: drive voltage_k from pose_k, velocity_k, belt speed_k, safety-gated;
6. the rig steps t_k -> t_{k+1} with those commands held.

Node parameters are given as the same flat dicts the nodes take, so an experiment file drives
both this simulation and the graph; the graph's recorded outputs must equal these, to the bit.
So each core gets the time as its node computes it from step k's stamp ``k dt_ns`` [ns]: the
reference generator, the driver and the treadmill's safety monitor ``(k dt_ns) 1e-9``, the
pose estimator ``sec + nanosec 1e-9`` of the stamp (:func:`irs_common.stamps.to_sec`). The rig's
own ``k dt`` differs from these in the last bit at about a quarter of the steps, which a sine
reference turns into different steer commands.
"""
from dataclasses import dataclass, field
import math
from typing import Any

from mypy_extensions import mypyc_attr
import numpy as np

from irs_common.orientation import quaternion_from_yaw, yaw_from_quaternion
from irs_control.controller_factory import make_controller
from irs_control.lateral_params import controller_config
from irs_control.reference_params import reference_signal
from irs_sensing.estimator_params import estimator_config
from irs_sensing.pose_estimator import PoseEstimator
from irs_treadmill.regulator import BeltSpeedRegulator
from irs_treadmill.regulator_params import regulator_config
from irs_treadmill.safety import SafetyMonitor
from irs_vehicle_sim.rig import RigInputs, RigSimulation
from irs_vehicle_sim.rig_params import rig_config

from ..driver.speed_profile import speed_profile


@dataclass
class LoopConfig:
    """Flat parameter dicts per node (missing keys: the node's defaults); None = node absent."""

    rig: dict = field(default_factory=dict)
    estimator: dict = field(default_factory=dict)
    controller: dict | None = field(default_factory=dict)
    reference: dict | None = field(default_factory=dict)
    regulator: dict | None = field(default_factory=dict)
    driver: dict | None = None
    default_drive_voltage: float = 0.0   # vehicle_sim parameter: drive before any command


def _yaw_via_quaternion(psi: float) -> float:
    """psi -> quaternion (as published) -> yaw (as the regulator reads it)."""
    return yaw_from_quaternion(*quaternion_from_yaw(psi))


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (irs_common.native_cores), subclassed
class ClosedLoop:
    """Offline closed loop; :meth:`run` returns the signals the graph would publish."""

    def __init__(self, cfg: LoopConfig):
        self.cfg = cfg
        self.rig: Any = RigSimulation(rig_config(cfg.rig))   # or a stand-in (hardware_loop)
        self.dt = self.rig.config.dt
        self.dt_ns = int(round(self.dt * 1e9))      # vehicle_sim's step in its stamps [ns]
        self.k = 0                                  # the step being answered
        est = estimator_config(cfg.estimator)
        self.calibration = est.calibration
        self.raw_input = est.input == 'raw'
        self.estimator = PoseEstimator(est.params)
        self.controller = None
        if cfg.controller is not None:
            self.controller = make_controller(controller_config(cfg.controller)).controller
        self.signal = reference_signal(cfg.reference) if cfg.reference is not None \
            else (lambda t: 0.0)
        self.regulator = self.safety = None
        if cfg.regulator is not None:
            reg = regulator_config(cfg.regulator)
            self.regulator = BeltSpeedRegulator(reg.regulator)
            self.safety = SafetyMonitor(reg.safety)
            self.reg_dt = 1.0 / reg.rate_hz
            self.reg_enabled = reg.enabled
            self.reg_use_velocity = reg.use_velocity_input
        self.profile = speed_profile(cfg.driver) if cfg.driver is not None else None
        # One RigInputs, refilled each step: the rig copies what it applies into its outputs.
        self._inputs = RigInputs()

    def _control(self, out):
        stamp_ns = self.k * self.dt_ns
        t = stamp_ns * 1e-9                                  # the ticker's and the regulator's
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        angles = out.arm_angles
        try:
            if self.raw_input:
                angles = self.calibration.to_angles(tuple(angles))
            est, _reason = self.estimator.update(*angles, sec + nanosec * 1e-9)   # to_sec
        except ValueError:
            est = None
        y_s = est.y_s if est is not None else math.nan
        ref = float(self.signal(t))
        steer = 0.0
        if self.controller is not None:
            steer = self.controller.step_checked(ref, y_s).u_sat
        voltage = self.cfg.default_drive_voltage
        if self.regulator is not None:
            x = est.x_cg if est is not None else math.nan
            y = est.y_cg if est is not None else math.nan
            xdot = math.nan
            if not self.reg_use_velocity:
                xdot = None
            elif est is not None and est.velocity_valid:
                psi = _yaw_via_quaternion(est.psi)
                xdot = est.u * math.cos(psi) - est.v * math.sin(psi)
            self.safety.update_position(x, y, t, xdot=xdot)
            belt = out.belt_speed_measured
            r = self.regulator.update(x, belt, self.reg_dt, xdot=xdot,
                                      enabled=self.safety.drive_permitted and self.reg_enabled)
            voltage = self.safety.gate(r.voltage) if self.reg_enabled else 0.0
        speed = self.profile(t) if self.profile is not None else None
        inputs = self._inputs
        inputs.front_steer = steer
        inputs.drive_voltage = voltage
        inputs.speed_cmd = self.rig.config.u0 if speed is None else speed
        return inputs, ref, y_s

    def run(self, duration: float) -> dict:
        """Simulate ``duration`` s; arrays of length N+1 (outputs) and N (commands)."""
        n = int(round(duration / self.dt))
        rows: list = []
        cmds: list = []
        control, step = self._control, self.rig.step
        add_row, add_cmd = rows.append, cmds.append
        out = self.rig.outputs
        for k in range(n):
            self.k = k                                 # the step _control answers
            inputs, ref, y_meas = control(out)
            add_row((out.time, out.y_s, y_meas, ref, out.actuator_front.achieved, out.x,
                     out.belt_speed, out.fault, out.y))
            add_cmd((inputs.front_steer, inputs.drive_voltage))
            out = step(inputs)
        # The last instant: outputs only (no command is computed for it), the reference as the
        # reference generator publishes it.
        self.k = n
        t_last = n * self.dt_ns * 1e-9
        rows.append((out.time, out.y_s, math.nan, float(self.signal(t_last)),
                     out.actuator_front.achieved, out.x, out.belt_speed, out.fault, out.y))
        a = np.array(rows, dtype=float)
        c = np.array(cmds, dtype=float).reshape(-1, 2)
        return {'time': a[:, 0], 'y_s': a[:, 1], 'y_measured': a[:, 2], 'reference': a[:, 3],
                'steer_achieved': a[:, 4], 'x': a[:, 5], 'belt_speed': a[:, 6],
                'fault': a[:, 7].astype(bool), 'y': a[:, 8], 'steer_cmd': c[:, 0],
                'drive_voltage': c[:, 1]}
