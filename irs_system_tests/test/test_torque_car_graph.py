"""The torque car through the ROS graph in lock-step: eleven experiments.

Each experiment runs through the experiment runner (vehicle_sim with ``plant: two_track``,
arm_pose_estimator, treadmill_regulator, chassis_controller and the recorder composed in one
process) once per module; the tests read the bags:

- the graph's commands and the car's motion equal the offline composition of the same cores
  (``irs_bringup/offline_twin/chassis_loop.py``) to the bit;
- on low mu ABS stops the car shorter over the belt (``x_belt`` of ``rig/tyre_truth``) than
  locked wheels, holding the slip it measures (from the wheels' reference speed) at the -0.10
  target;
- on high mu the peak-seeking ABS stops at least as short as the fixed-target ABS and locked
  wheels (all four surfaces: irs_system_tests/test/test_torque_car_abs.py, offline);
- on split mu the car stays on the belt with ABS and yaw control, and turns less than with
  locked wheels or ABS alone;
- through every braking event the treadmill regulator keeps the car on the belt (no off-belt
  fault, c.g. inside the belt's safety margins) and cuts the drive as the car falls back; after
  a brake pulse (``torque_brake_event_abs_low``) it brings the car forward again, back to the
  set point, while the car drives at its starting speed again. (A car braked
  to a stop is carried off the belt about 1.1 s after the stop, whatever the regulator does: the
  belt cannot be braked, it coasts down in about 10 s (docs/treadmill.md); the stop experiments
  end 0.8 s after the start);
- a front step steer with yaw control tracks the bicycle yaw-rate reference better (ISE) than
  without.
"""
import numpy as np
import pytest

from irs_bringup.offline_twin.from_experiment import offline_run
from irs_bringup.offline_twin.lateral_loop import _yaw_via_quaternion
from irs_bringup.experiment_cli import run_experiment
from irs_studies.torque_car.series import load_run
from irs_control.chassis_control import ChassisController

BRAKING = [f'torque_braking_{mode}_{mu}' for mu in ('high', 'low', 'split')
           for mode in ('locked', 'abs')] + ['torque_braking_chassis_split',
                                              'torque_braking_abspeak_high']
STEER = ['torque_step_steer_open', 'torque_step_steer_chassis']
EVENT = 'torque_brake_event_abs_low'     # a 0.2 s ABS brake pulse, then its start speed again
T_BRAKE = 0.05           # [s] brake.start_time of the braking experiments
T_STEER = 0.2            # [s] steer.start_time of the step-steer experiments
STOPPED = 0.02           # [m/s] the car counts as stopped over the belt below this
BELT_HALF_LENGTH, BELT_HALF_WIDTH = 1.2192, 0.6096     # [m]
END_MARGIN, EDGE_MARGIN = 0.15, 0.10                   # [m] the regulator's safety margins


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    """``{name: (RunResult, Run)}`` of the eleven experiments, each run once through the graph."""
    out = {}
    runs_dir = tmp_path_factory.mktemp('torque_runs')
    for name in BRAKING + STEER + [EVENT]:
        result = run_experiment(name, runs_dir=runs_dir, plots=False)
        out[name] = (result, load_run(result.bag_dir))
    return out


def _at(series, t):
    """Index of the sample stamped ``t`` [s] (lock-step stamps are whole steps)."""
    return int(np.flatnonzero(np.round(series['t'] * 1000) == round(t * 1000))[0])


def stop(run):
    """``(distance over the belt [m], time [s], index)`` of the stop after the brake."""
    tyre = run.series['tyre']
    i0 = _at(tyre, T_BRAKE)
    i1 = i0 + int(np.argmax(tyre['u'][i0:] < STOPPED))
    assert tyre['u'][i1] < STOPPED, 'the car must stop within the run'
    return tyre['x_belt'][i1] - tyre['x_belt'][i0], tyre['t'][i1] - tyre['t'][i0], i1


def test_every_run_completes_and_the_graph_equals_the_offline_cores(runs):
    for name, (result, run) in runs.items():
        assert result.completed, (name, result.message)
        assert all(code == 0 for code in result.exit_codes.values()), (name, result.exit_codes)
        off = offline_run(name)
        s = run.series
        n = len(off['torque'])            # the graph also answers the last instant
        cmd = {k: v[:n] for k, v in s['cmd'].items()}
        idx = np.round(cmd['t'] * 1000).astype(int)
        assert np.array_equal(idx, np.arange(n)), f'{name}: every step must be in the bag'
        assert np.array_equal(cmd['torque'], off['torque']), name
        assert np.array_equal(cmd['locked'], off['locked']), name
        steer = {k: v[:n] for k, v in s['steer'].items()}
        assert np.array_equal(steer['front'], off['front_steer']), name
        assert np.array_equal(steer['rear'], off['rear_steer']), name
        tyre, odom = s['tyre'], s['odom']
        assert len(tyre['t']) == n + 1 and len(odom['t']) == n + 1, name
        assert np.array_equal(tyre['x_belt'], off['x_belt']), name
        assert np.array_equal(tyre['slip'], off['slip']), name
        assert np.array_equal(odom['x'], off['x']) and np.array_equal(odom['y'], off['y'])
        # the bag's heading went through the odometry's quaternion: compare it the same way
        assert np.array_equal(odom['yaw'], [_yaw_via_quaternion(p) for p in off['psi']]), name


def test_abs_stops_shorter_than_locked_wheels_on_low_mu_with_slip_near_target(runs):
    d_locked, t_locked, _ = stop(runs['torque_braking_locked_low'][1])
    run = runs['torque_braking_abs_low'][1]
    d_abs, t_abs, i1 = stop(run)
    print(f'low mu: stop over the belt {d_abs:.3f} m with ABS, {d_locked:.3f} m locked '
          f'({t_abs:.3f} s, {t_locked:.3f} s)')
    assert d_abs < 0.8 * d_locked
    tyre = run.series['tyre']
    i0 = _at(tyre, T_BRAKE)
    # ABS runs while the car is above v_min (0.1 m/s, by the wheels' reference speed); below it
    # the friction brakes hold the wheels. 0.15 m/s leaves room for the reference's error.
    active = np.arange(len(tyre['t'])) < i1
    active &= (np.arange(len(tyre['t'])) >= i0) & (tyre['u'] > 0.15)
    mean_slip = float(np.mean(tyre['slip'][active]))
    st = run.series['status']
    u_st = np.interp(st['t'], tyre['t'], tyre['u'])
    held = float(np.median(st['slip'][(st['t'] >= T_BRAKE) & (u_st > 0.15) & (st['t'] <
                                                                            tyre['t'][i1])]))
    print(f'low mu: slip under ABS {held:.3f} as the controller measures it, {mean_slip:.3f} '
          f"the tyres' (target -0.10); locked wheels: "
          f'{np.mean(runs["torque_braking_locked_low"][1].series["tyre"]["slip"][i0:i1]):.3f}')
    assert abs(held + 0.10) < 0.01
    # the tyres' relaxed slip is deeper (measured -0.13): the encoders' 2.5 ms lag on a
    # decelerating wheel
    assert -0.16 < mean_slip < -0.10
    cmd = run.series['cmd']
    j = np.searchsorted(cmd['t'], tyre['t'][np.flatnonzero(active)[-1]])
    assert not cmd['locked'][:j].any(), 'ABS must not lock a wheel while the car moves'


def test_peak_seeking_abs_stops_shortest_on_high_mu_through_the_graph(runs):
    d = {m: stop(runs[f'torque_braking_{m}_high'][1])[0] for m in ('locked', 'abs', 'abspeak')}
    print('high mu: stop over the belt ' + ', '.join(f'{m} {v:.4f} m' for m, v in d.items()))
    assert d['abspeak'] <= min(d['abs'], d['locked'])
    st = runs['torque_braking_abspeak_high'][1].series['status']
    assert np.nanmin(st['target']) < -0.12, 'the peak seeker probed and moved above -0.10'


def _heading_change(run):
    odom = run.series['odom']
    i0 = _at(odom, T_BRAKE)
    return float(np.max(np.abs(odom['yaw'][i0:] - odom['yaw'][i0]))), \
        float(np.max(np.abs(odom['r'][i0:])))


def test_split_mu_yaw_control_keeps_the_car_straight_and_on_the_belt(runs):
    psi = {k: _heading_change(runs[f'torque_braking_{k}_split'][1])
           for k in ('locked', 'abs', 'chassis')}
    print('split mu: heading change, peak yaw rate ' + ', '.join(
        f'{k} {p:.3f} rad {r:.3f} rad/s' for k, (p, r) in psi.items()))
    assert psi['chassis'][0] < 0.5 * psi['locked'][0]
    assert psi['chassis'][0] < psi['abs'][0]
    assert psi['chassis'][1] < psi['abs'][1] < psi['locked'][1]
    result, run = runs['torque_braking_chassis_split']
    assert result.completed, result.message
    odom = run.series['odom']
    assert np.max(np.abs(odom['y'])) < BELT_HALF_WIDTH - EDGE_MARGIN


def test_treadmill_regulator_keeps_the_car_on_the_belt_through_every_braking_event(runs):
    for name in BRAKING:
        result, run = runs[name]
        assert result.completed, (name, result.message)   # an off-belt fault stops a run
        odom = run.series['odom']
        assert np.max(np.abs(odom['x'])) < BELT_HALF_LENGTH - END_MARGIN, name
        assert np.max(np.abs(odom['y'])) < BELT_HALF_WIDTH - EDGE_MARGIN, name
        # the car falls back while it brakes; the regulator answers by cutting the drive, and
        # the belt (which cannot be braked: docs/treadmill.md) coasts down
        _d, t_stop, _ = stop(run)
        x_fall = odom['x'][_at(odom, T_BRAKE)] - odom['x'][-1]
        belt = run.series['belt']['speed']
        print(f'{name}: stopped after {t_stop:.3f} s, fell back {x_fall:.3f} m, belt '
              f'{belt[0]:.3f} -> {belt[-1]:.3f} m/s')
        assert x_fall > 0.0
        assert belt[-1] < belt[0] - 0.05, name


def _yaw_ise(run):
    """ISE [rad^2/s] of the bicycle yaw-rate reference for the commanded front steer at the
    true speed minus the true yaw rate, from the steer step to the end.
    """
    s = run.series
    odom, steer, tyre = s['odom'], s['steer'], s['tyre']
    n = min(len(steer['t']), len(odom['t']))
    core = ChassisController()
    ref = np.array([core.yaw_rate_reference(d, u)
                    for d, u in zip(steer['front'][:n], tyre['u'][:n])])
    e = ref - odom['r'][:n]
    i0 = _at(odom, T_STEER)
    return float(np.sum(e[i0:] ** 2) * 0.001), float(ref[-1])


def test_step_steer_with_yaw_control_tracks_the_reference_better(runs):
    ise_open, ref = _yaw_ise(runs['torque_step_steer_open'][1])
    ise_chassis, _ = _yaw_ise(runs['torque_step_steer_chassis'][1])
    print(f'step steer: yaw-rate ISE {ise_chassis:.3g} with yaw control, {ise_open:.3g} without '
          f'(reference {ref:.4f} rad/s)')
    assert ref > 0.05
    assert ise_chassis < 0.5 * ise_open


def test_after_a_brake_pulse_the_regulator_brings_the_car_forward_again(runs):
    result, run = runs[EVENT]
    assert result.completed, result.message
    odom, tyre, belt = run.series['odom'], run.series['tyre'], run.series['belt']
    i0 = _at(odom, T_BRAKE)
    assert tyre['u'][i0:].min() < 0.8, 'the pulse must be a real braking event'
    assert np.max(np.abs(odom['x'])) < BELT_HALF_LENGTH - END_MARGIN
    i_min = int(np.argmin(odom['x']))
    x_min, x_end = odom['x'][i_min], odom['x'][-1]
    print(f'brake pulse: speed down to {tyre["u"][i0:].min():.3f} m/s, car back to x = '
          f'{x_min:.3f} m at {odom["t"][i_min]:.2f} s, {x_end:.3f} m at the end; belt '
          f'{belt["speed"][0]:.3f} -> {belt["speed"][-1]:.3f} m/s')
    assert odom['t'][i_min] > T_BRAKE
    x_ref = odom['x'][0]                   # the run starts at the regulator's set point
    assert odom['x'][i_min:].max() > x_ref - 0.02, 'the regulator must bring the car forward again'
    # speed.target 0: the car holds the speed it started at (the belt's), and gets back to it
    j = _at(tyre, float(odom['t'][i_min]))
    assert np.min(np.abs(tyre['u'][j:] - tyre['u'][0])) < 0.01, 'back at its starting speed'
