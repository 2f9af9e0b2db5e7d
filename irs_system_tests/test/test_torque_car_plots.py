"""The torque car's bag analysis (irs_studies.torque_car) on synthetic runs with known answers.

Until the experiments exist these runs are written here: a braking run at a constant
deceleration ``a`` from ``u0`` (stopping distance ``(u0^2 - u_stop^2) / 2a``, time
``(u0 - u_stop) / a``), set slips, one wheel held at 0 rad/s for 0.1 s, a half-sine yaw rate,
a belt that slows at a set rate; step steers with a first-order and a second-order yaw rate
(90 % rise ``tau ln 10``, overshoot ``exp(-pi zeta / sqrt(1 - zeta^2))``). The expected values
are derived from those inputs. The same series go through a real MCAP bag (BagWriter, CDR) and
the CLI; bad bags give one line.
"""
import json
import math
from pathlib import Path
import subprocess

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from irs_studies.torque_car import metrics as tm
from irs_studies.torque_car.cli import main as cli_main
from irs_studies.torque_car.series import TOPICS, Run, load_run
from irs_models.constants import BELT_HALF_LENGTH

DT = 0.001          # [s] the rig's step
R = 0.033           # [m] wheel radius (two-track default)
LOG0 = 10**9        # [ns] log time of the first message


# ----------------------------------------------------------------- synthetic series
def braking_series(u0=1.2, a=3.0, tb=0.5, after=0.6, slips=(-0.05, -0.1, -0.15, -0.2),
                   lock_wheel=3, belt_decel=0.5, r_peak=0.2, yaw_period=0.4, mode='abs',
                   brake_torque=0.2):
    """Series (the :data:`TOPICS` layout) of a braking run at constant deceleration ``a``."""
    t = np.arange(0.0, tb + after + DT / 2, DT)
    tau = np.maximum(t - tb, 0.0)
    u = np.maximum(u0 - a * tau, 0.0)
    tau_stop = u0 / a
    x_belt = u0 * np.minimum(t, tb) + np.where(tau < tau_stop, u0 * tau - a * tau**2 / 2,
                                               u0**2 / (2 * a))
    braking = (t >= tb)
    slip = np.where((braking & (u > 0))[:, None], np.array(slips)[None, :], 0.0)
    omega = u[:, None] * (1.0 + slip) / R
    if lock_wheel is not None:
        omega[(tau >= 0.1) & (tau < 0.2), lock_wheel] = 0.0
    vb = 1.2 - belt_decel * tau
    x = x_belt - (1.2 * t - belt_decel * tau**2 / 2)     # dx/dt = u - V_b
    ph = np.minimum(tau, yaw_period)
    r = np.where(tau < yaw_period, r_peak * np.sin(np.pi * ph / yaw_period), 0.0)
    yaw = r_peak * yaw_period / np.pi * (1.0 - np.cos(np.pi * ph / yaw_period))
    torque = np.zeros((t.size, 4))
    locked = np.zeros((t.size, 4))
    if mode == 'locked':
        locked[braking] = 1.0
    else:
        torque[braking] = -brake_torque
    z = np.zeros(t.size)
    return {
        'tyre': {'t': t, 'slip': slip, 'omega': omega, 'mu': np.full((t.size, 4), 0.3),
                 'fx': np.zeros((t.size, 4)), 'x_belt': x_belt, 'u': u},
        'enc': {'t': t, 'velocity': omega.copy()},
        'cmd': {'t': t, 'torque': torque, 'locked': locked},
        'odom': {'t': t, 'x': x, 'y': z, 'yaw': yaw, 'r': r},
        'pose': {'t': t, 'x': x, 'y': z, 'yaw': yaw},
        'velocity': {'t': t, 'r': r},
        'belt': {'t': t, 'speed': vb},
        'steer': {'t': t, 'front': z, 'rear': z},
        'act': {'t': t, 'front': z, 'rear': z},
    }


def with_status(series, offset=0.01, every=10):
    """``series`` plus a ``chassis/status`` every ``every`` steps reporting the true slips +
    ``offset`` (and v_hat = u, v_ref = u + offset, targets -0.10 - offset, braking after the
    brake start).
    """
    tyre, cmd = series['tyre'], series['cmd']
    k = slice(None, None, every)
    braking = ((cmd['torque'] < 0).any(axis=1) | (cmd['locked'] > 0).any(axis=1))[k]
    series['status'] = {'t': tyre['t'][k], 'v_hat': tyre['u'][k],
                        'v_ref': tyre['u'][k] + offset, 'braking': braking.astype(float),
                        'slip': tyre['slip'][k] + offset,
                        'target': np.full((tyre['t'][k].size, 4), -0.10 - offset)}
    return series


def step_steer_series(amplitude=0.03, t0=0.5, duration=3.0, tau=0.05, zeta=None, wn=20.0,
                      d_torque=0.05, rear=0.01, u_slope=0.0):
    """Series of a step steer from 1.2 m/s (slowing at ``u_slope`` [m/s^2]): yaw rate = the
    bicycle reference at the speed of the instant times a first-order (``tau``) or a
    second-order (``zeta``, ``wn``) step response.
    """
    from irs_control.chassis_control import ChassisController
    t = np.arange(0.0, duration + DT / 2, DT)
    s = np.maximum(t - t0, 0.0)
    u = 1.2 - u_slope * t
    ctl = ChassisController()
    r_ss = np.array([ctl.yaw_rate_reference(amplitude, v) for v in u])
    if zeta is None:
        g = 1.0 - np.exp(-s / tau)
    else:
        wd = wn * math.sqrt(1 - zeta**2)
        g = 1.0 - np.exp(-zeta * wn * s) * (np.cos(wd * s) + zeta * wn / wd * np.sin(wd * s))
    r = r_ss * g
    z = np.zeros(t.size)
    on = (t >= t0).astype(float)
    torque = np.column_stack([-d_torque * on, d_torque * on, -d_torque * on, d_torque * on])
    return {
        'tyre': {'t': t, 'slip': np.zeros((t.size, 4)), 'omega': np.full((t.size, 4), 1.2 / R),
                 'mu': np.full((t.size, 4), 0.8), 'fx': np.zeros((t.size, 4)),
                 'x_belt': 1.2 * t - u_slope * t**2 / 2, 'u': u},
        'cmd': {'t': t, 'torque': torque, 'locked': np.zeros((t.size, 4))},
        'odom': {'t': t, 'x': z, 'y': z, 'yaw': np.cumsum(r) * DT, 'r': r},
        'belt': {'t': t, 'speed': u},
        'steer': {'t': t, 'front': amplitude * on, 'rear': rear * on},
        'act': {'t': t, 'front': amplitude * on, 'rear': rear * on},
    }, (r_ss[0] if u_slope == 0.0 else r_ss)


def as_run(name, series, params=None):
    return Run(name, Path(name), params or {}, series)


# ----------------------------------------------------------------- bags
def _message(key, row):
    """The message of topic ``key`` for one sample ``row`` (field -> value)."""
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from nav_msgs.msg import Odometry

    from irs_common.orientation import quaternion_from_yaw
    from irs_msgs.msg import (BeltSpeed, SteeringActuatorState, SteeringCommand, TyreState,
                              WheelEncoders, WheelTorqueCommand)

    def quat(o, yaw):
        o.x, o.y, o.z, o.w = quaternion_from_yaw(yaw)

    if key == 'tyre':
        m = TyreState(slip=row['slip'], omega=row['omega'], mu=row['mu'], fx=row['fx'],
                      x_belt=row['x_belt'], u=row['u'])
    elif key == 'enc':
        m = WheelEncoders(velocity=row['velocity'], counts_per_rev=2048, window=5)
    elif key == 'cmd':
        m = WheelTorqueCommand(torque=row['torque'], torque_limit=0.3,
                               locked=[bool(b) for b in row['locked']])
    elif key == 'odom':
        m = Odometry()
        m.pose.pose.position.x, m.pose.pose.position.y = row['x'], row['y']
        quat(m.pose.pose.orientation, row['yaw'])
        m.twist.twist.angular.z = row['r']
    elif key == 'pose':
        m = PoseStamped()
        m.pose.position.x, m.pose.position.y = row['x'], row['y']
        quat(m.pose.orientation, row['yaw'])
    elif key == 'velocity':
        m = TwistStamped()
        m.twist.angular.z = row['r']
    elif key == 'belt':
        m = BeltSpeed(speed=row['speed'])
    elif key == 'steer':
        m = SteeringCommand(front_angle=row['front'], rear_angle=row['rear'])
    elif key == 'status':
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
        values = {'brake_mode': 'abs', 'braking': 'true' if row['braking'] else 'false',
                  'v_hat': f'{row["v_hat"]:.17g}', 'v_ref': f'{row["v_ref"]:.17g}'}
        values.update({f'slip_{w}': f'{v:.17g}' for w, v in zip(tm.WHEELS, row['slip'])})
        values.update({f'slip_target_{w}': f'{v:.17g}'
                       for w, v in zip(tm.WHEELS, row['target'])})
        m = DiagnosticArray(status=[DiagnosticStatus(
            name='chassis_controller', values=[KeyValue(key=a, value=b)
                                               for a, b in values.items()])])
    else:
        m = SteeringActuatorState(front_achieved=row['front'], rear_achieved=row['rear'])
    return m


def write_bag(path, name, series, params=None, chunk_size=1024 * 1024):
    """A rosbag2 MCAP bag of ``series`` with the experiment runner's metadata record."""
    from rclpy.serialization import serialize_message

    from irs_bag.writer import BagWriter

    with BagWriter(path, chunk_size=chunk_size) as w:
        w.add_metadata('irs_experiment', {
            'experiment_yaml': f'name: {name}\nclock: lockstep\n',
            'node_parameters': json.dumps(params or {})})
        for key, data in series.items():
            topic = TOPICS[key][0]
            fields = [f for f in data if f != 't']
            for k, tk in enumerate(data['t']):
                msg = _message(key, {f: (data[f][k].tolist() if np.ndim(data[f][k])
                                         else float(data[f][k])) for f in fields})
                sec, ns = divmod(int(round(tk * 1e9)), 10**9)
                msg.header.stamp.sec, msg.header.stamp.nanosec = sec, ns
                mod = type(msg).__module__.split('.')[0]
                w.write(topic, f'{mod}/msg/{type(msg).__name__}', serialize_message(msg),
                        LOG0 + int(round(tk * 1e9)))
    return path


# ----------------------------------------------------------------- braking metrics
def expected_braking(u0=1.2, a=3.0, tb=0.5, after=0.6, belt_decel=0.5, r_peak=0.2,
                     yaw_period=0.4):
    """The answers of :func:`braking_series`, from its inputs."""
    ts = (u0 - tm.U_STOP) / a

    def x_rel(tau):         # car x relative to x(t_b): distance over the belt - belt travel
        return ((u0 * tau - a * tau**2 / 2 if tau < u0 / a else u0**2 / (2 * a))
                - (1.2 * tau - belt_decel * tau**2 / 2))

    taus = np.arange(0.0, after + DT / 2, DT)
    x_at_b = (u0 - 1.2) * tb
    return {'stopping_time': ts, 'stopping_distance': (u0**2 - tm.U_STOP**2) / (2 * a),
            'mean_deceleration': u0 / ts, 'u_brake': u0, 't_brake': tb,
            'peak_yaw_rate': r_peak,
            'heading_at_stop': r_peak * yaw_period / np.pi
            * (1 - np.cos(np.pi * min(ts, yaw_period) / yaw_period)),
            'drift_back': -min(x_rel(tau) for tau in taus), 'drift_at_stop': -x_rel(ts),
            'belt_speed_brake': 1.2, 'belt_speed_min': 1.2 - belt_decel * ts,
            'x_brake': x_at_b}


def test_braking_metrics_of_a_constant_deceleration():
    slips = (-0.05, -0.1, -0.15, -0.2)
    m = tm.braking_metrics(as_run('torque_braking_abs_low', braking_series(slips=slips),
                                  {'chassis_controller': {'brake.torque': 0.2}}))
    exp = expected_braking()
    for k, v in exp.items():
        assert m[k] == pytest.approx(v, rel=1e-3, abs=1e-6), k
    assert m['stopped'] is True
    assert m['stopping_distance'] == pytest.approx(1.2**2 / (2 * 3.0), rel=2e-3)   # ~v^2/2a
    assert m['slip_mean'] == pytest.approx(list(slips), abs=1e-12)
    assert m['slip_min'] == pytest.approx(list(slips), abs=1e-12)
    # the controller's view lags (the arm speed over 10 samples): close to the truth, and
    # more negative while decelerating (v_hat is the speed of about 5 ms earlier)
    # (RR's encoder reads 0 rad/s for 0.1 s: -1 there, though its set kappa stays -0.2, which
    # pulls its median below the same run's without the lock)
    est = np.array(m['slip_est_median'])
    assert np.all(np.abs(est[:3] - np.array(slips[:3])) < 0.05), est
    assert np.all(est < np.array(slips)), est
    free = tm.braking_metrics(as_run('torque_braking_abs_low', braking_series(
        slips=slips, lock_wheel=None)))['slip_est_median']
    assert est[3] < free[3] < slips[3], (est, free)
    assert free[:3] == pytest.approx(est[:3], abs=1e-12)
    # wheel RR held at 0 rad/s for 0.1 s while u > 0.1 m/s
    assert m['wheel_locked'] == [False, False, False, True]
    assert m['locked_time'][3] == pytest.approx(0.1, abs=2 * DT)
    assert m['locked_time'][:3] == [0.0, 0.0, 0.0]
    assert m['slip_est_source'] == 'recomputed'
    assert m['x_min'] == pytest.approx(-exp['drift_back'], abs=1e-9)
    assert m['belt_end_margin'] == pytest.approx(BELT_HALF_LENGTH - exp['drift_back'], abs=1e-9)


def test_estimated_slips_from_the_controller_status():
    slips = (-0.05, -0.1, -0.15, -0.2)
    m = tm.braking_metrics(as_run('torque_braking_abs_low', with_status(
        braking_series(slips=slips), offset=0.01)))
    assert m['slip_est_source'] == 'chassis/status'
    assert m['slip_est_median'] == pytest.approx([s + 0.01 for s in slips], abs=1e-12)
    # the reference speed reads u + 0.01, the targets -0.11
    assert m['v_ref_error_max'] == pytest.approx(0.01, abs=1e-12)
    assert m['slip_target_mean'] == pytest.approx(-0.11, abs=1e-12)
    bare = tm.braking_metrics(as_run('torque_braking_locked_low', braking_series()))
    assert math.isnan(bare['v_ref_error_max']) and math.isnan(bare['slip_target_mean'])


def test_brake_start_from_the_locked_flags_and_a_run_that_never_stops():
    s = braking_series(mode='locked', a=1.0, after=0.6)    # 1.2 m/s at 1 m/s^2: no stop
    m = tm.braking_metrics(as_run('torque_braking_locked_low', s))
    assert m['t_brake'] == pytest.approx(0.5, abs=1e-9)
    assert m['stopped'] is False
    assert math.isnan(m['stopping_distance']) and math.isnan(m['stopping_time'])
    s['cmd']['locked'][:] = 0.0
    with pytest.raises(ValueError, match='never brake'):
        tm.braking_metrics(as_run('torque_braking_locked_low', s))


@settings(max_examples=40, deadline=None, database=None)
@given(u0=st.floats(0.5, 2.0), a=st.floats(1.5, 9.0), tb=st.floats(0.05, 0.5))
def test_stopping_distance_is_v2_over_2a(u0, a, tb):
    """Any start speed, deceleration and brake instant: the stop as derived from the inputs."""
    tb = round(tb / DT) * DT                   # the brake starts at a rig step
    s = braking_series(u0=u0, a=a, tb=tb, after=u0 / a + 0.1, lock_wheel=None)
    m = tm.braking_metrics(as_run('torque_braking_abs_high', s))
    assert m['t_brake'] == pytest.approx(tb, abs=1e-9)
    assert m['stopping_distance'] == pytest.approx((u0**2 - tm.U_STOP**2) / (2 * a), rel=1e-3)
    assert m['stopping_time'] == pytest.approx((u0 - tm.U_STOP) / a, rel=1e-3, abs=DT)
    assert not any(m['wheel_locked'])


def test_crossing_time_interpolates():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    x = np.array([1.0, 0.8, 0.4, 0.0])
    assert tm.crossing_time(t, x, 0.6, 0.0) == pytest.approx(1.5)
    assert math.isnan(tm.crossing_time(t, x, -1.0, 0.0))
    assert tm.crossing_time(t, x, 0.9, 2.5) == 3.0       # first sample below after t_from


# ----------------------------------------------------------------- step steer metrics
def test_step_steer_first_order():
    tau = 0.05
    s, r_ss = step_steer_series(tau=tau)
    m = tm.step_steer_metrics(as_run('torque_step_steer_open', s))
    assert m['t_steer'] == pytest.approx(0.5, abs=1e-9)
    assert m['amplitude'] == pytest.approx(0.03)
    assert m['r_ref0'] == pytest.approx(r_ss, rel=1e-3)
    assert m['r_ref_end'] == pytest.approx(r_ss, rel=1e-3)
    assert m['rise_time_90'] == pytest.approx(tau * math.log(10), abs=1.5 * DT)
    assert m['overshoot_percent'] == pytest.approx(0.0, abs=1e-9)
    assert m['ise'] == pytest.approx(r_ss**2 * tau / 2, rel=1e-2)
    assert abs(m['steady_state_error']) < 1e-3 * abs(r_ss)
    assert m['peak_differential_torque'] == pytest.approx(0.05)
    assert m['peak_rear_steer'] == pytest.approx(0.01)


def test_step_steer_against_a_reference_that_follows_the_speed():
    """The car slows (0.2 m/s^2) and the reference with it: a response that stays below the
    reference of each instant has no overshoot, and reaches 90 % of it after tau ln 10.
    """
    s, r_ref = step_steer_series(tau=0.05, u_slope=0.2, duration=2.0)
    m = tm.step_steer_metrics(as_run('torque_step_steer_open', s))
    assert m['overshoot_percent'] == pytest.approx(0.0, abs=0.1)
    assert m['rise_time_90'] == pytest.approx(0.05 * math.log(10), abs=2 * DT)
    assert m['r_ref0'] == pytest.approx(r_ref[500], rel=2e-3)
    assert m['r_ref_end'] == pytest.approx(np.mean(r_ref[-301:]), rel=2e-3)
    assert m['r_ref_end'] < 0.8 * m['r_ref0']


@pytest.mark.parametrize('zeta', [0.3, 0.5, 0.7])
def test_step_steer_overshoot_of_a_second_order_response(zeta):
    s, r_ss = step_steer_series(zeta=zeta, wn=20.0)
    m = tm.step_steer_metrics(as_run('torque_step_steer_chassis', s))
    expected = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    assert m['overshoot_percent'] == pytest.approx(expected, abs=0.1)


def test_yaw_reference_is_linear_in_steer_and_negative_steer_works():
    ref = tm.yaw_reference([0.01, 0.02, -0.03], [1.2, 1.2, 1.2])
    assert ref[1] == pytest.approx(2 * ref[0]) and ref[2] == pytest.approx(-3 * ref[0])
    s, r_ss = step_steer_series(amplitude=-0.03)
    m = tm.step_steer_metrics(as_run('torque_step_steer_open', s))
    assert m['r_ref0'] == pytest.approx(r_ss) and r_ss < 0
    assert m['rise_time_90'] == pytest.approx(0.05 * math.log(10), abs=1.5 * DT)


def test_run_kind_from_the_names():
    assert tm.run_kind('torque_braking_chassis_split') == {
        'kind': 'braking', 'mode': 'chassis', 'surface': 'split'}
    assert tm.run_kind('torque_step_steer_open')['mode'] == 'open'
    assert tm.run_kind('figure10_pi')['kind'] == 'unknown'


# ----------------------------------------------------------------- bags, CLI, figures
def test_bag_round_trip_gives_the_series(tmp_path):
    s = with_status(braking_series(after=0.3))
    write_bag(tmp_path / 'bag', 'torque_braking_abs_low', s, {'sim': {'two_track.wheel_radius':
                                                                      R}})
    run = load_run(tmp_path / 'bag')
    assert run.name == 'torque_braking_abs_low'
    assert run.param('two_track.wheel_radius') == R
    for key, data in s.items():
        for f, v in data.items():
            got = run.series[key][f]
            tol = 1e-9 if key in ('odom', 'pose') and f == 'yaw' else 0.0
            np.testing.assert_allclose(got, v, atol=tol, err_msg=f'{key}.{f}')


def test_cli_writes_metrics_and_figures(tmp_path, capsys):
    import matplotlib.image as mpimg

    bags = []
    for mode, a in (('locked', 2.4), ('abs', 3.0)):
        for surface in ('low', 'split'):
            name = f'torque_braking_{mode}_{surface}'
            bags.append(write_bag(tmp_path / name / 'bag', name, braking_series(a=a, mode=mode)))
    name = 'torque_braking_chassis_split'
    bags.append(write_bag(tmp_path / name, name, braking_series(a=2.0, r_peak=0.05)))
    for mode, tau in (('open', 0.2), ('chassis', 0.02)):
        name = f'torque_step_steer_{mode}'
        bags.append(write_bag(tmp_path / f'{name}-20261127T040000', 'x', step_steer_series(
            tau=tau)[0]))
    # the last two are run directories whose metadata name is not an experiment: skipped
    rc = cli_main([str(b) for b in bags] + ['--out', str(tmp_path / 'img'),
                                             '--metrics', str(tmp_path / 'm.json')])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert out.err.count("experiment 'x' is not a torque-car experiment") == 2
    res = json.loads((tmp_path / 'm.json').read_text())
    assert set(res['braking']) == {'torque_braking_locked_low', 'torque_braking_abs_low',
                                   'torque_braking_locked_split', 'torque_braking_abs_split',
                                   'torque_braking_chassis_split'}
    assert res['braking']['torque_braking_locked_low']['stopping_distance'] == pytest.approx(
        (1.2**2 - tm.U_STOP**2) / (2 * 2.4), rel=1e-3)
    assert res['braking']['torque_braking_chassis_split']['peak_yaw_rate'] == pytest.approx(0.05)
    assert '| torque_braking_abs_low | 1.200 | 0.240 | 0.393 |' in out.out
    names = sorted(p.name for p in (tmp_path / 'img').iterdir())
    assert names == ['torque_braking_low.png', 'torque_braking_split.png',
                     'torque_split_yaw.png']
    for p in (tmp_path / 'img').iterdir():
        h, w = mpimg.imread(p).shape[:2]
        assert h > 300 and w > 600, (p, h, w)


def test_cli_step_steer_figure(tmp_path, capsys):
    bags = []
    for mode, tau in (('open', 0.2), ('chassis', 0.02)):
        name = f'torque_step_steer_{mode}'
        bags.append(write_bag(tmp_path / name, name, step_steer_series(tau=tau)[0]))
    rc = cli_main([str(b) for b in bags] + ['--out', str(tmp_path / 'img'),
                                             '--metrics', str(tmp_path / 'm.json')])
    assert rc == 0, capsys.readouterr().err
    res = json.loads((tmp_path / 'm.json').read_text())
    assert res['step_steer']['torque_step_steer_open']['rise_time_90'] == pytest.approx(
        0.2 * math.log(10), abs=1.5 * DT)
    assert (tmp_path / 'img' / 'torque_step_steer.png').stat().st_size > 10_000


def _one_line_error(capsys, argv):
    rc = cli_main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1 and err.startswith('torque_car: error: '), err
    assert 'Traceback' not in err
    return err


def test_bad_bags_give_one_line(tmp_path, capsys):
    (tmp_path / 'junk.mcap').write_bytes(b'this is not an MCAP file' * 10)
    assert 'not a readable bag' in _one_line_error(capsys, [str(tmp_path / 'junk.mcap')])
    assert 'no such run directory or bag' in _one_line_error(capsys, [str(tmp_path / 'none')])
    other = braking_series(after=0.1)
    write_bag(tmp_path / 'fig10', 'figure10_pi', {'odom': other['odom']})
    assert 'not a torque-car run' in _one_line_error(capsys, [str(tmp_path / 'fig10')])
    s = braking_series(after=0.1)
    s['cmd']['torque'][:] = 0.0
    write_bag(tmp_path / 'nobrake', 'torque_braking_abs_high', s)
    assert 'never brake' in _one_line_error(capsys, [str(tmp_path / 'nobrake')])
    assert 'no runs given' in _one_line_error(capsys, [])


def test_run_with_an_unknown_experiment_names_it(tmp_path, capsys):
    """--run: an experiment that cannot run is one line naming it, then no runs: exit 2."""
    rc = cli_main(['--run', '--experiments', 'no_such_torque_experiment', '--runs-dir',
                   str(tmp_path), '--metrics', str(tmp_path / 'm.json')])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 2 and 'no_such_torque_experiment' in err[0], err
    assert err[1] == 'torque_car: error: no runs given (paths or --run)'
    assert not (tmp_path / 'm.json').exists()


def test_an_unfinished_bag_is_read_with_one_warning(tmp_path, capsys):
    """A bag cut short (a killed recorder): its complete chunks are analysed, one warning."""
    bag = write_bag(tmp_path / 'bag', 'torque_braking_abs_low', braking_series(),
                    chunk_size=64 * 1024)
    mcap = next(bag.glob('*.mcap'))
    data = mcap.read_bytes()
    mcap.write_bytes(data[:int(0.8 * len(data))])
    rc = cli_main([str(bag), '--metrics', str(tmp_path / 'm.json'), '--out', str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 0, err
    assert len(err) == 1 and err[0].startswith('torque_car: warning: '), err
    m = json.loads((tmp_path / 'm.json').read_text())['braking']['torque_braking_abs_low']
    assert m['stopping_distance'] == pytest.approx(expected_braking()['stopping_distance'],
                                                   rel=1e-3)


def test_installed_executable_gives_one_line(tmp_path):
    from irs_bringup.executables import resolve_executable

    exe = resolve_executable('irs_studies', 'torque_car')
    res = subprocess.run([exe, str(tmp_path / 'missing')], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [
        f'torque_car: error: {tmp_path / "missing"}: no such run directory or bag']


def test_process_per_node_without_run_is_one_line(tmp_path, capsys):
    """--process-per-node places the nodes of --run: without --run it is one line, exit 2."""
    err = _one_line_error(capsys, ['--process-per-node', str(tmp_path / 'some_run')])
    assert err == 'torque_car: error: --process-per-node places the nodes of --run: add --run'
