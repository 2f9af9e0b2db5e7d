"""The torque car through the hardware node and the emulated board's wheel channels
(``hil_torque_car``, lock-step: a 0.03 rad front step steer with yaw-rate control by
differential torque), against the same run on ``vehicle_sim`` (``torque_step_steer_chassis``:
its offline twin, which the graph reproduces to the bit, ``test_torque_car_graph``).

1. The graph is the hardware chain's offline twin
   (:class:`irs_bringup.offline_twin.hardware_loop.HardwareChassisLoop`: the node's core on the
   emulated devices) to the bit: the wheel torque and steer commands, the drive voltage and the
   wheel encoders' velocities the node publishes, every step. So the twin's ground truth (yaw
   rate, speed) is the emulated car's, and the step-steer metrics
   (``irs_studies.torque_car.metrics.step_steer_metrics``) are taken from it.
2. ISE and overshoot of the yaw rate against its reference agree with ``vehicle_sim``'s within a
   tolerance derived from what the hardware chain adds, modelled on ``vehicle_sim``'s own
   offline loop (:class:`WheelLinkModel`, none of the emulator's code):

   - latency: the link's 2 samples (``--lockstep-delay 2``) on the steer and the wheel torques;
   - the encoders: the host's windows start empty at the first sample (``vehicle_sim`` primes
     its own), over the same counts (the board reads the rig's encoders, so their quantisation
     is the same on both): the wheels' velocities over 5 samples, the belt's speed over 10
     with the calibrated counts per metre and without ``vehicle_sim``'s extra sample of delay;
   - command resolution: the motor command's per-mille of the drivers' 0.4 N m
     (``q_T = 0.4 mN m``, on a grid through 0), the servo pulse's 0.5 us, the drive's set-point
     step (1.27 mV);
   - the pots: the 16-bit ADC's step ``q_a = 92.7 urad`` and the calibration file's residual
     (as ``test_hil_figure10``).

   Grid offsets of the servo, drive and pots drawn at random (fixed seed) for ``K`` = 6 runs:
   mean ``mu`` and deviation ``s``; tolerance ``|mu - m_sim| + 4 s``, and the hardware run
   within ``4 s`` of ``mu``.
"""
import collections
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from irs_bag.run_series import series_by_stamp
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_cli import run_experiment
from irs_bringup.offline_twin.chassis_loop import ChassisLoop
from irs_bringup.offline_twin.from_experiment import chassis_loop_config, offline_run
from irs_hardware.calibration import load_calibration
from irs_hardware.emulator.board_core import BoardTruth
from irs_hardware.paths import resolve
from irs_studies.torque_car.metrics import step_steer_metrics
from irs_studies.torque_car.series import Run, load_run
from test_hil_figure10 import Q_ANGLE, Q_VOLT, calibration_residual

K = 6
DELAY = 2                       # [samples] hil_torque_car's --lockstep-delay
METRICS = ('ise', 'overshoot_percent')
TRUTH = BoardTruth()
#: The motor command's step [N m] (per-mille of the drivers' full scale).
Q_TORQUE = TRUTH.motor_constant * TRUTH.driver_full_scale / 1000
TORQUE_LIMIT = 0.3              # [N m] the node's wheel_torque_limit
BELT_WINDOW = 10                # [samples] the node's belt_window
COUNTS_PER_METRE = load_calibration(resolve(
    'pkg://irs_hardware/config/calibration_emulated_torque_car.yaml')).belt.counts_per_metre


def quantise(value, step, offset):
    return step * (round(value / step - offset) + offset)


class LinkActuators:
    """The rig behind the hardware chain's outputs: each step's steer command through the servo
    pulse's grid and the calibration residual, the torques clipped and on the motor command's
    grid, the voltage on the set-point's, and steer and torques applied ``DELAY`` steps late
    (the rig's other attributes are the wrapped rig's). The loop records the commands the
    controller sent, as the graph's bag does.
    """

    def __init__(self, rig, offsets, residual):
        self._rig = rig
        self.offsets = offsets
        _error, self.steer_offset, self.steer_gain, self.q_steer = residual
        self.fifo = collections.deque([(0.0, (0.0,) * 4)] * DELAY)

    def __getattr__(self, name):
        return getattr(self._rig, name)

    def step(self, inputs):
        steer = quantise(inputs.front_steer, self.q_steer, self.offsets[3])
        torque = tuple(quantise(min(TORQUE_LIMIT, max(-TORQUE_LIMIT, t)), Q_TORQUE, 0.0)
                       for t in inputs.wheel_torque)
        self.fifo.append((self.steer_offset + self.steer_gain * steer, torque))
        steer, torque = self.fifo.popleft()
        volts = quantise(inputs.drive_voltage, Q_VOLT, self.offsets[4])
        return self._rig.step(replace(inputs, front_steer=steer, wheel_torque=torque,
                                      drive_voltage=volts))


class WheelLinkModel(ChassisLoop):
    """``vehicle_sim``'s offline torque-car loop with the hardware chain's latency, encoder
    windows, command resolution, ADC and calibration residual (module docstring); ``offsets``:
    the grids' offsets (3 pots, steer, set-point) in [0, 1) steps.
    """

    def __init__(self, cfg, offsets, residual):
        cfg = replace(cfg, rig={**cfg.rig, 'arm.enable_quantization': False})
        super().__init__(cfg)
        self.rig = LinkActuators(self.rig, offsets, residual)
        self.offsets = offsets
        self.pot_error = residual[0]
        self.window = collections.deque(maxlen=self.rig.config.encoders['window'] + 1)
        self.belt_window = collections.deque(maxlen=BELT_WINDOW + 1)
        self.counts_per_rev = self.rig.config.encoders['counts_per_rev']

    def _host_velocity(self, out):
        """The host's ``2 pi (n_k - n_{k-w}) / (N w dt)``, w the samples there are (<= W)."""
        self.window.append((round(out.time / self.dt), out.encoder_counts))
        (k0, n0), (k1, n1) = self.window[0], self.window[-1]
        scale = 2.0 * math.pi / (self.counts_per_rev * (k1 - k0) * self.dt) if k1 > k0 else 0.0
        return tuple(scale * (b - a) for a, b in zip(n0, n1))

    def _host_belt_speed(self, out):
        """The host's ``(c_k - c_{k-w}) / (counts_per_metre w dt)`` of the belt's counter."""
        self.belt_window.append((round(out.time / self.dt), self.rig.belt.encoder.count))
        (k0, c0), (k1, c1) = self.belt_window[0], self.belt_window[-1]
        return (c1 - c0) / COUNTS_PER_METRE / ((k1 - k0) * self.dt) if k1 > k0 else 0.0

    def step_commands(self, out):
        angles = tuple(quantise(a + e, Q_ANGLE, o) for a, e, o in
                       zip(out.arm_angles, self.pot_error, self.offsets))
        measured = replace(out, arm_angles=angles, encoder_velocity=self._host_velocity(out),
                           belt_speed_measured=self._host_belt_speed(out))
        return super().step_commands(measured)


def metrics(run: dict, name: str) -> dict:
    """Step-steer metrics of an offline run's arrays (the bag's series of the same names)."""
    t = run['time']
    n = len(run['front_steer'])
    series = {'odom': {'t': t, 'r': run['yaw_rate']}, 'tyre': {'t': t, 'u': run['u']},
              'steer': {'t': t[:n], 'front': run['front_steer'], 'rear': run['rear_steer']},
              'cmd': {'t': t[:n], 'torque': run['torque']}}
    m = step_steer_metrics(Run(name, Path(name), {}, series))
    return {k: m[k] for k in METRICS}


def model_metrics(duration) -> dict:
    """``{metric: (mu, s)}`` over ``K`` grid offsets of :class:`WheelLinkModel`."""
    cfg = chassis_loop_config(load_experiment('torque_step_steer_chassis'))
    residual = calibration_residual()
    rng = np.random.default_rng(26)
    runs = [metrics(WheelLinkModel(cfg, rng.uniform(0.0, 1.0, 5), residual).run(duration),
                    'model') for _ in range(K)]
    return {k: (float(np.mean([r[k] for r in runs])),
                float(np.std([r[k] for r in runs], ddof=1))) for k in METRICS}


def test_hil_torque_car_matches_vehicle_sim_within_the_derived_tolerance(tmp_path):
    result = run_experiment('hil_torque_car', runs_dir=tmp_path, plots=False,
                            deployment='composed')
    assert result.completed, result.message
    assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes
    twin = offline_run('hil_torque_car')
    assert not twin['fault'].any()
    run = load_run(result.bag_dir)
    n = len(twin['torque'])
    drive = series_by_stamp(result.bag_dir)['drive_voltage']
    graph = {'torque': run.series['cmd']['torque'][:n],
             'front_steer': run.series['steer']['front'][:n],
             'drive_voltage': np.array([drive.get(k * 1_000_000, np.nan) for k in range(n)]),
             'encoder_velocity': run.series['enc']['velocity'][:n + 1]}
    assert np.array_equal(np.round(run.series['cmd']['t'][:n] * 1000), np.arange(n))
    for name, got in graph.items():
        want = twin[name][:len(got)]
        assert got.shape == np.shape(want), (name, got.shape, np.shape(want))
        diff = np.abs(got - want)
        print(f'{name}: {len(got)} steps, largest difference graph - twin {np.max(diff):.3g}')
        assert np.array_equal(got, want), (name, np.max(diff))     # NaN: a lost step
    assert np.min(twin['encoder_velocity'][10:]) > 30.0            # the wheels turn (~36 rad/s)
    assert np.max(np.abs(twin['torque'][:, 1] - twin['torque'][:, 0])) > 0.01   # differential

    sim = metrics(offline_run('torque_step_steer_chassis'), 'vehicle_sim')
    hil = metrics(twin, 'hil')
    model = model_metrics(load_experiment('hil_torque_car').duration)
    for k in METRICS:
        mu, s = model[k]
        tol = abs(mu - sim[k]) + 4.0 * s
        print(f'{k}: vehicle_sim {sim[k]:.6g}, hardware {hil[k]:.6g}, model {mu:.6g} +- '
              f'{s:.2g}, tolerance {tol:.3g}')
        assert abs(hil[k] - sim[k]) <= tol, (k, hil[k], sim[k], tol)
        assert abs(hil[k] - mu) <= 4.0 * s, (k, hil[k], mu, s)
