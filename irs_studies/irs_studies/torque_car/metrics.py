"""Metrics of the torque car's braking and step-steer runs (pure numpy on a :class:`~.series.Run`).

Braking (:func:`braking_metrics`, from the rig's ground truth unless said otherwise): brake
start ``t_b`` [s], stopping time [s], stopping distance over the belt [m], mean deceleration
[m/s^2], true and estimated slip per wheel [-], wheel lock, peak yaw rate [rad/s], heading
[rad], the car's drift on the treadmill [m] and the belt speed [m/s]. Step steer
(:func:`step_steer_metrics`): ISE of the yaw rate against the bicycle model's steady-state
reference [rad^2/s], overshoot [%], 90 % rise time [s], steady-state error [rad/s], largest
rear steer [rad] and differential torque [N m]. They exist so that the torque car's runs are
compared by numbers computed one way; the definitions are in the two functions.
"""
from __future__ import annotations

import math

import numpy as np

from irs_models.constants import BELT_HALF_LENGTH

__all__ = ['U_STOP', 'V_MIN', 'LOCK_SPEED', 'WHEELS', 'brake_start', 'crossing_time',
           'braking_metrics', 'step_steer_metrics', 'estimated_slips', 'yaw_reference',
           'differential_torque', 'run_kind']

U_STOP = 0.02           # [m/s] the car has stopped below this speed over the belt
V_MIN = 0.1             # [m/s] ABS threshold: slips are evaluated above it
LOCK_SPEED = 0.01       # [m/s] a wheel whose rim speed |omega| R is below this is locked
V_REF_CHECK = 0.2       # [m/s] the reference speed's error is taken above this speed
WHEELS = ('FL', 'FR', 'RL', 'RR')
_NAN = float('nan')


def run_kind(name: str) -> dict:
    """``{'kind': 'braking'|'step_steer'|'unknown', 'mode', 'surface'}`` from the experiment
    name (``torque_braking_<mode>_<surface>``, ``torque_step_steer_<open|chassis>``).
    """
    parts = name.split('_')
    if name.startswith('torque_braking_') and len(parts) >= 4:
        return {'kind': 'braking', 'mode': parts[2], 'surface': '_'.join(parts[3:])}
    if name.startswith('torque_step_steer_') and len(parts) >= 4:
        return {'kind': 'step_steer', 'mode': '_'.join(parts[3:]), 'surface': 'high'}
    return {'kind': 'unknown', 'mode': '', 'surface': ''}


def wheel_radius(run) -> float:
    """R [m]: the rig's ``two_track.wheel_radius``, else the two-track model's default."""
    from irs_vehicle_sim.two_track import TwoTrackParams
    return float(run.param('two_track.wheel_radius', TwoTrackParams().wheel_radius))


def brake_start(run) -> float:
    """``t_b`` [s] (module docstring); NaN if the commands never brake."""
    cmd = run.series['cmd']
    torque_param = run.param('brake.torque')
    threshold = 0.5 * abs(float(torque_param)) if torque_param else 0.05
    braking = (cmd['locked'] > 0.5).any(axis=1) | (cmd['torque'].mean(axis=1) < -threshold)
    idx = np.flatnonzero(braking)
    return float(cmd['t'][idx[0]]) if idx.size else _NAN


def crossing_time(t, x, level: float, t_from: float) -> float:
    """First time ``>= t_from`` at which ``x`` falls below ``level`` (linear interpolation
    between samples); NaN if it never does.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    idx = np.flatnonzero((t >= t_from) & (x < level))
    if idx.size == 0:
        return _NAN
    i = int(idx[0])
    if i == 0 or t[i - 1] < t_from or x[i - 1] == x[i]:
        return float(t[i])
    return float(t[i - 1] + (x[i - 1] - level) / (x[i - 1] - x[i]) * (t[i] - t[i - 1]))


def estimated_slips(run, t) -> np.ndarray:
    """``(len(t), 4)`` slips the controller estimates (module docstring) at times ``t``; NaN
    without ``/pose``, ``/belt/speed`` or ``/wheels/encoders``.
    """
    from irs_control.abs_control import ArmSpeedEstimator, wheel_slips

    t = np.asarray(t, float)
    if not run.has('pose', 'belt', 'enc'):
        return np.full((t.size, 4), np.nan)
    pose, belt, enc = run.series['pose'], run.series['belt'], run.series['enc']
    vb = np.interp(pose['t'], belt['t'], belt['speed'])
    est = ArmSpeedEstimator()
    v_hat = np.empty(pose['t'].size)
    prev = pose['t'][0] - float(np.median(np.diff(pose['t'])))
    for k, (tk, x, psi) in enumerate(zip(pose['t'], pose['x'], pose['yaw'])):
        v_hat[k] = est.step(float(x), float(psi), float(vb[k]), float(tk - prev))
        prev = tk
    v = np.interp(t, pose['t'], v_hat)
    omega = np.column_stack([np.interp(t, enc['t'], enc['velocity'][:, i]) for i in range(4)])
    R = wheel_radius(run)
    return np.array([wheel_slips(o, float(vk), R, V_MIN) for o, vk in zip(omega, v)])


def _estimated_slip_means(run, tb: float, t_end: float) -> dict:
    tyre = run.series['tyre']
    if run.has('status') and np.isfinite(run.series['status']['slip']).any():
        st, source = run.series['status'], 'chassis/status'
        u = np.interp(st['t'], tyre['t'], tyre['u'])
        est = st['slip'][(st['t'] >= tb) & (st['t'] <= t_end) & (u > V_MIN)]
    else:
        w = (tyre['t'] >= tb) & (tyre['t'] <= t_end) & (tyre['u'] > V_MIN)
        est, source = estimated_slips(run, tyre['t'][w]), 'recomputed'
    ok = est.size and np.isfinite(est).any(axis=0).all()
    return {'slip_est_median': np.nanmedian(est, axis=0).tolist() if ok else [_NAN] * 4,
            'slip_est_source': source if ok else 'none'}


def _reference_metrics(run, tb: float, t_end: float) -> dict:
    out = {'v_ref_error_max': _NAN, 'slip_target_mean': _NAN}
    if not run.has('status'):
        return out
    st, tyre = run.series['status'], run.series['tyre']
    u = np.interp(st['t'], tyre['t'], tyre['u'])
    w = (st['t'] >= tb) & (st['t'] <= t_end) & (u > V_REF_CHECK)
    if w.any() and np.isfinite(st['v_ref'][w]).all():
        out['v_ref_error_max'] = float(np.max(np.abs(st['v_ref'][w] - u[w])))
    if w.any() and np.isfinite(st['target'][w]).all():
        out['slip_target_mean'] = float(np.mean(st['target'][w]))
    return out


def _at(t, ts, xs) -> float:
    return float(np.interp(t, ts, xs)) if math.isfinite(t) and len(ts) else _NAN


def braking_metrics(run) -> dict:
    """Braking metrics of ``run``; needs ``tyre`` and ``cmd`` series.

    All from the rig's ground truth unless said otherwise:

    * brake start ``t_b`` [s]: the first torque command with a wheel ``locked`` or with the mean of
      the four torques below ``-brake_threshold`` (half the run's ``brake.torque``, else 0.05 N m;
      speed control and differential torque average to a few mN m, a braking command to -T_brake);
    * stop ``t_s``: the first ``rig/tyre_truth`` sample after ``t_b`` with ``u < u_stop`` (0.02
      m/s, linearly interpolated); stopping time ``t_s - t_b``; stopping distance ``x_belt(t_s) -
      x_belt(t_b)`` [m] (distance over the belt surface, interpolated); mean deceleration ``u(t_b)
      / (t_s - t_b)`` [m/s^2]; ``stopped`` False (and NaN) if it never stops;
    * slip per wheel (``slip``, kappa of ``rig/tyre_truth``): mean and min over the braking samples
      with ``u > v_min`` (0.1 m/s, where the ABS works; below it slip is meaningless);
    * estimated slip per wheel, as the controller sees it: ``lambda_i = (omega_enc,i R - v_hat) /
      max(v_hat, v_min)`` with the encoder speeds and ``v_hat`` = the arm-speed estimate, the
      *median* over the braking samples with ``u > v_min`` (the encoder's 0.61 rad/s step is 0.02
      m/s of rim speed, 20 % slip at 0.1 m/s, so single samples near the stop are wild and a mean
      follows them): the slips the controller reports on ``chassis/status`` (``slip_est_source =
      'chassis/status'``), else recomputed here from ``/wheels/encoders``, ``/pose`` and
      ``/belt/speed`` with :class:`irs_control.abs_control.ArmSpeedEstimator` (``'recomputed'``);
      NaN without them;
    * the ABS's reference speed (``v_ref`` of ``chassis/status``, from the wheels): its largest
      error ``max |v_ref - u|`` [m/s] over the status samples between ``t_b`` and the stop with ``u
      > 0.2 m/s``, and the mean slip target over them (the peak seeker's; -0.10 fixed); NaN without
      them and for locked wheels (then the estimated slips too: held wheels tell nothing);
    * a wheel locked: ``|omega_i| R < lock_speed`` (0.01 m/s) while ``u > v_min`` between ``t_b``
      and the stop (after it the friction brakes hold the wheels while the car rocks on its tyres);
      the time it spent so [s];
    * peak ``|r|`` [rad/s] after ``t_b`` and the heading ``psi`` [rad] at the stop and at the end
      (``ground_truth/odom``);
    * the car's ``x`` on the treadmill [m] (``ground_truth/odom``): at ``t_b``, its minimum after
      ``t_b``, the drift back at the stop ``x(t_b) - x(t_s)`` (about ``V_b (t_s - t_b)`` minus the
      stopping distance) and by the end of the run ``x(t_b) - min x``, and the smallest distance to
      a belt end over the run, ``L/2 - max |x|`` (L/2 = ``BELT_HALF_LENGTH``);
    * the measured belt speed (``belt/speed``) at ``t_b``, its minimum between ``t_b`` and ``t_s``
      and at ``t_s`` [m/s].
    """
    if not run.has('tyre', 'cmd'):
        raise ValueError(f'{run.path}: a braking run needs /rig/tyre_truth and '
                         '/wheels/torque_command')
    tyre = run.series['tyre']
    t, u = tyre['t'], tyre['u']
    tb = brake_start(run)
    if not math.isfinite(tb):
        raise ValueError(f'{run.path}: the torque commands never brake (no locked wheel, no '
                         'mean torque below the threshold)')
    ts = crossing_time(t, u, U_STOP, tb)
    stopped = math.isfinite(ts)
    t_end = ts if stopped else float(t[-1])
    out = {'t_brake': tb, 'u_brake': _at(tb, t, u), 'stopped': stopped,
           'stopping_time': ts - tb if stopped else _NAN,
           'stopping_distance': _at(ts, t, tyre['x_belt']) - _at(tb, t, tyre['x_belt'])}
    out['mean_deceleration'] = out['u_brake'] / out['stopping_time'] if stopped else _NAN
    window = (t >= tb) & (t <= t_end) & (u > V_MIN)
    slip = tyre['slip'][window]
    out['slip_mean'] = slip.mean(axis=0).tolist() if slip.size else [_NAN] * 4
    out['slip_min'] = slip.min(axis=0).tolist() if slip.size else [_NAN] * 4
    out.update(_estimated_slip_means(run, tb, t_end))
    out.update(_reference_metrics(run, tb, t_end))
    if run_kind(run.name)['mode'] == 'locked':
        # the friction brakes hold the wheels: the controller's reference and slips are moot
        out.update(slip_est_median=[_NAN] * 4, v_ref_error_max=_NAN, slip_target_mean=_NAN)
    after = (t >= tb) & (t <= t_end) & (u > V_MIN)
    rim = np.abs(tyre['omega']) * wheel_radius(run)
    locked = (rim < LOCK_SPEED) & after[:, None]
    dt = np.diff(t, append=t[-1])
    out['wheel_locked'] = locked.any(axis=0).tolist()
    out['locked_time'] = [float(np.sum(dt[locked[:, i]])) for i in range(4)]
    out.update(_odom_metrics(run, tb, ts))
    out.update(_belt_metrics(run, tb, ts))
    return out


def _odom_metrics(run, tb: float, ts: float) -> dict:
    keys = ('peak_yaw_rate', 'heading_at_stop', 'heading_final', 'x_brake', 'x_min',
            'drift_at_stop', 'drift_back', 'belt_end_margin')
    if not run.has('odom'):
        return dict.fromkeys(keys, _NAN)
    o = run.series['odom']
    after = o['t'] >= tb
    x_min = float(np.min(o['x'][after])) if after.any() else _NAN
    x_b = _at(tb, o['t'], o['x'])
    return {'peak_yaw_rate': float(np.max(np.abs(o['r'][after]))) if after.any() else _NAN,
            'heading_at_stop': _at(ts, o['t'], o['yaw']), 'heading_final': float(o['yaw'][-1]),
            'x_brake': x_b, 'x_min': x_min, 'drift_at_stop': x_b - _at(ts, o['t'], o['x']),
            'drift_back': x_b - x_min,
            'belt_end_margin': BELT_HALF_LENGTH - float(np.max(np.abs(o['x'])))}


def _belt_metrics(run, tb: float, ts: float) -> dict:
    if not run.has('belt'):
        return dict.fromkeys(('belt_speed_brake', 'belt_speed_min', 'belt_speed_stop'), _NAN)
    b = run.series['belt']
    t_end = ts if math.isfinite(ts) else float(b['t'][-1])
    during = (b['t'] >= tb) & (b['t'] <= t_end)
    return {'belt_speed_brake': _at(tb, b['t'], b['speed']),
            'belt_speed_min': float(np.min(b['speed'][during])) if during.any() else _NAN,
            'belt_speed_stop': _at(ts, b['t'], b['speed'])}


def yaw_reference(front, speed) -> np.ndarray:
    """Steady-state bicycle yaw rate [rad/s] for front steer ``front`` [rad] at ``speed`` [m/s]
    (the chassis controller's reference, irs_iwt preset), elementwise.
    """
    from irs_control.chassis_control import ChassisController
    ctl = ChassisController()
    # linear in front steer at a given speed: one solve per distinct speed (rounded to 1 mm/s)
    gain = {}
    out = np.empty(np.size(front))
    for k, (d, v) in enumerate(zip(np.ravel(front), np.ravel(speed))):
        key = round(float(v), 3)
        if key not in gain:
            gain[key] = ctl.yaw_rate_reference(1.0, key)
        out[k] = gain[key] * float(d)
    return out


def differential_torque(torque) -> np.ndarray:
    """``dT = (T_FR + T_RR - T_FL - T_RL) / 4`` [N m] of ``(N, 4)`` torques."""
    T = np.asarray(torque, float)
    return (T[:, 1] + T[:, 3] - T[:, 0] - T[:, 2]) / 4.0


def step_steer_series(run) -> dict:
    """``t`` [s], yaw rate ``r`` and reference ``r_ref`` [rad/s] on the odometry stamps, the
    steer start ``t0`` [s] and the amplitude [rad].
    """
    if not run.has('odom', 'steer'):
        raise ValueError(f'{run.path}: a step-steer run needs /ground_truth/odom and '
                         '/steering/command')
    o, s = run.series['odom'], run.series['steer']
    amplitude = float(s['front'][np.argmax(np.abs(s['front']))])
    if amplitude == 0.0:
        raise ValueError(f'{run.path}: the front steer command is always 0: no step steer')
    t0 = float(s['t'][np.flatnonzero(np.abs(s['front']) > abs(amplitude) / 2)[0]])
    # the command held until the next one (zero-order hold), at the odometry stamps
    idx = np.clip(np.searchsorted(s['t'], o['t'], side='right') - 1, 0, None)
    front = np.where(o['t'] >= s['t'][0], s['front'][idx], 0.0)
    if run.has('tyre'):
        speed = np.interp(o['t'], run.series['tyre']['t'], run.series['tyre']['u'])
    elif run.has('belt'):
        speed = np.interp(o['t'], run.series['belt']['t'], run.series['belt']['speed'])
    else:
        speed = np.full(o['t'].size, 1.2)
    return {'t': o['t'], 'r': o['r'], 'r_ref': yaw_reference(front, speed), 't0': t0,
            'amplitude': amplitude}


def step_steer_metrics(run) -> dict:
    """Step-steer metrics of ``run``.

    Steer start ``t_0`` = the first ``steering/command`` sample with ``|front| > |amplitude| / 2``
    (amplitude = the largest ``|front|``); the yaw-rate reference ``r_ref(t)`` = the bicycle
    model's steady-state yaw rate for the commanded front steer at the car's speed ``u``
    (:meth:`irs_control.chassis_control.ChassisController. yaw_rate_reference`, the chassis
    controller's own reference); on ``ground_truth/odom``'s yaw rate ``r`` over ``[t_0, end]``:

    * ISE ``int (r - r_ref)^2 dt`` [rad^2/s] (trapezoidal);
    * the reference follows the car's speed, which changes during the run (the speed loop and the
      treadmill regulator), so the step response is taken against the reference of the same
      instant: ``r_ref0`` = the reference just after the step; overshoot ``100 max(0,
      max(sign(r_ref0) (r - r_ref))) / |r_ref0|`` [%]; 90 % rise time = the first time after
      ``t_0`` with ``sign(r_ref0) r >= 0.9 |r_ref(t)|`` minus ``t_0`` [s]; steady-state error =
      mean ``r - r_ref`` over the last 20 % of the window [rad/s], and ``r_ref_end`` the mean
      reference there;
    * the largest rear steer command [rad] and differential torque ``dT = (T_FR + T_RR - T_FL -
      T_RL) / 4`` [N m] (the per-wheel share, + = more drive right).
    """
    s = step_steer_series(run)
    w = s['t'] >= s['t0']
    t, r, ref = s['t'][w], s['r'][w], s['r_ref'][w]
    if t.size < 10:
        raise ValueError(f'{run.path}: fewer than 10 odometry samples after the steer step')
    e = r - ref
    ise = float(np.sum(0.5 * (e[1:] ** 2 + e[:-1] ** 2) * np.diff(t)))
    tail = t >= t[0] + 0.8 * (t[-1] - t[0])
    r0 = float(ref[0])
    sign = math.copysign(1.0, r0)
    reached = np.flatnonzero(sign * r >= 0.9 * np.abs(ref))
    out = {'t_steer': s['t0'], 'amplitude': s['amplitude'], 'r_ref0': r0,
           'r_ref_end': float(np.mean(ref[tail])), 'ise': ise,
           'overshoot_percent': 100.0 * max(0.0, float(np.max(sign * e))) / abs(r0)
           if r0 else _NAN,
           'rise_time_90': float(t[reached[0]] - s['t0']) if reached.size else _NAN,
           'steady_state_error': float(np.mean(e[tail]))}
    out['peak_rear_steer'] = (float(np.max(np.abs(run.series['steer']['rear'])))
                              if run.has('steer') else _NAN)
    out['peak_differential_torque'] = (
        float(np.max(np.abs(differential_torque(run.series['cmd']['torque']))))
        if run.has('cmd') else _NAN)
    return out
