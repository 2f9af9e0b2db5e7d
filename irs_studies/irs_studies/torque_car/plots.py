"""Figures of the torque car's runs (matplotlib, Agg): braking, split-mu yaw, step steer.

Every braking panel is against the time since the brake start ``t - t_b`` [s]; every run of a
figure is one line style (locked dashed, fixed-target ABS solid, peak-seeking ABS dash-dot-dot,
ABS + chassis dotted, open dash-dotted), every wheel one colour (FL, FR, RL, RR).

* ``plot_braking``: (a) the car's speed over the belt ``u`` (truth), the ABS's reference speed
  from the wheels (``chassis/status``) and the rim speeds ``omega R`` from the encoders; (b) the
  tyres' longitudinal slip (truth) with the fixed target and the peak seeker's targets; (c) the
  distance over the belt ``x_belt - x_belt(t_b)`` (the stopping distance at the marker); (d) the
  car's ``x`` on the treadmill and the measured belt speed.
* ``plot_split_yaw``: yaw rate and heading (truth) of the split-mu runs.
* ``plot_step_steer``: yaw rate against its reference, rear steer (command and achieved) and
  the differential torque ``dT``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from irs_sysid.common import save_figure
from .metrics import WHEELS, differential_torque, step_steer_series, wheel_radius

__all__ = ['plot_braking', 'plot_split_yaw', 'plot_step_steer', 'STYLE', 'LABEL']

STYLE = {'locked': '--', 'abs': '-', 'abspeak': (0, (5, 1, 1, 1)), 'chassis': ':',
         'open': '-.'}
LABEL = {'locked': 'locked wheels', 'abs': 'ABS (fixed target)', 'abspeak': 'ABS (peak-seeking)',
         'chassis': 'ABS + chassis control', 'open': 'no yaw control'}
SURFACE = {'high': 'high mu (0.8)', 'low': 'low mu (0.3)',
           'split': 'split mu (0.8 left / 0.3 right)',
           'step': 'mu 0.8 dropping to 0.3 mid-stop (t = 0.1 s)'}


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _colours(plt):
    return plt.rcParams['axes.prop_cycle'].by_key()['color']


def _window(runs: dict) -> float:
    """Plot to 0.3 s past the latest stop (or the end of the longest run)."""
    ends = []
    for run, m in runs.values():
        t = run.series['tyre']['t']
        ends.append(m['stopping_time'] if m['stopped'] else t[-1] - m['t_brake'])
    return float(max(ends)) + 0.3


def plot_braking(surface: str, runs: dict, path, slip_target: float = -0.10) -> Path:
    """Braking figure of one surface; ``runs``: mode -> (Run, braking metrics)."""
    plt = _plt()
    colours = _colours(plt)
    fig, axes = plt.subplots(2, 2, figsize=(14, 9), sharex=True)
    (ax_w, ax_s), (ax_d, ax_x) = axes
    ax_b = ax_x.twinx()
    t_max, d_max = _window(runs), 0.01
    for mode, (run, m) in runs.items():
        ls, tb, name = STYLE.get(mode, '-'), m['t_brake'], LABEL.get(mode, mode)
        tyre = run.series['tyre']
        tt = tyre['t'] - tb
        ax_w.plot(tt, tyre['u'], linestyle=ls, color='k', lw=1.8, label=f'car speed u, {name}')
        if run.has('enc'):
            enc = run.series['enc']
            for i, w in enumerate(WHEELS):
                ax_w.plot(enc['t'] - tb, enc['velocity'][:, i] * wheel_radius(run), linestyle=ls,
                          color=colours[i], lw=0.7, alpha=0.7)
        status = run.series.get('status') if run.has('status') else None
        if mode != 'locked' and status is not None and np.isfinite(status['v_ref']).any():
            ax_w.plot(status['t'] - tb, status['v_ref'], linestyle=ls, color=colours[6], lw=1.4,
                      label=f'ABS reference speed (wheels), {name}')
        for i, w in enumerate(WHEELS):     # left wheels wide beneath, right ones narrow above:
            ax_s.plot(tt, tyre['slip'][:, i], linestyle=ls, color=colours[i],  # equal in a
                      lw=2.4 if i % 2 == 0 else 0.9, zorder=2 + i % 2)          # straight stop
        if mode == 'abspeak' and status is not None:
            for i, w in enumerate(WHEELS):
                ax_s.step(status['t'] - tb, status['target'][:, i], where='post',
                          color=colours[i], lw=3.0, alpha=0.35)
        dist = tyre['x_belt'] - np.interp(tb, tyre['t'], tyre['x_belt'])
        label = (f'{name}: {m["stopping_distance"]:.4f} m in {m["stopping_time"]:.3f} s'
                 if m['stopped'] else f'{name}: no stop')
        ax_d.plot(tt, dist, linestyle=ls, color='k', label=label)
        d_max = max(d_max, float(np.max(dist[tt <= t_max])))
        if m['stopped']:
            ax_d.plot([m['stopping_time']], [m['stopping_distance']], 'o', color='k', ms=5)
        if run.has('odom'):
            o = run.series['odom']
            ax_x.plot(o['t'] - tb, o['x'], linestyle=ls, color=colours[4], label=f'car x, {name}')
        if run.has('belt'):
            b = run.series['belt']
            ax_b.plot(b['t'] - tb, b['speed'], linestyle=ls, color=colours[5], lw=1.0,
                      label=f'belt speed, {name}')
    for i, w in enumerate(WHEELS):
        ax_w.plot([], [], '-', color=colours[i], lw=0.7, label=f'{w} rim speed (encoder)')
        ax_s.plot([], [], '-', color=colours[i], lw=2.4 if i % 2 == 0 else 0.9, label=w)
    ax_s.axhline(slip_target, color='grey', lw=1.0, ls=(0, (1, 2)), label='fixed ABS target')
    if 'abspeak' in runs:
        ax_s.plot([], [], '-', color='grey', lw=3.0, alpha=0.35, label='peak-seeking targets')
    for mode in runs:
        ax_s.plot([], [], linestyle=STYLE.get(mode, '-'), color='k', label=LABEL.get(mode, mode))
    ax_w.set(title='(a) car speed over the belt (truth), the ABS reference and the rim speeds',
             ylabel='speed [m/s]')
    ax_s.set(title='(b) longitudinal tyre slip (truth; locked wheels -0.9 to -1, off the scale)',
             ylabel='slip kappa [-]', ylim=(-0.45, 0.05))
    ax_d.set(title='(c) distance over the belt since the brake start (dot: stop, u < 0.02 m/s)',
             ylabel='x_belt - x_belt(t_b) [m]', xlabel='time since the brake start [s]')
    ax_x.set(title='(d) car position on the treadmill and belt speed',
             ylabel='car x on the treadmill [m]', xlabel='time since the brake start [s]')
    ax_b.set_ylabel('measured belt speed [m/s]')
    ax_d.set_ylim(-0.15 * d_max, 1.1 * d_max)
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
        ax.set_xlim(-0.05, t_max)
    ax_w.legend(fontsize=7, loc='upper right')
    ax_s.legend(fontsize=7, loc='lower right', ncol=2)
    ax_d.legend(fontsize=8, loc='lower right')
    h1, l1 = ax_x.get_legend_handles_labels()
    h2, l2 = ax_b.get_legend_handles_labels()
    ax_x.legend(h1 + h2, l1 + l2, fontsize=7, loc='lower left')
    u_b = np.mean([m['u_brake'] for _, m in runs.values()])
    fig.suptitle(f'Torque car braking from {u_b:.2f} m/s on {SURFACE.get(surface, surface)}: '
                 + ' vs '.join(LABEL.get(k, k) for k in runs))
    return save_figure(fig, path, dpi=100)


def plot_split_yaw(runs: dict, path) -> Path:
    """Yaw rate and heading (truth) of the split-mu runs; ``runs``: mode -> (Run, metrics)."""
    plt = _plt()
    fig, (ax_r, ax_p) = plt.subplots(1, 2, figsize=(13, 4.8), sharex=True)
    colours = _colours(plt)
    for i, (mode, (run, m)) in enumerate(runs.items()):
        if not run.has('odom'):
            continue
        o, tb, name = run.series['odom'], m['t_brake'], LABEL.get(mode, mode)
        ax_r.plot(o['t'] - tb, o['r'], linestyle=STYLE.get(mode, '-'), color=colours[i],
                  label=f'{name}: peak |r| {m["peak_yaw_rate"]:.3f} rad/s')
        ax_p.plot(o['t'] - tb, o['yaw'], linestyle=STYLE.get(mode, '-'), color=colours[i],
                  label=f'{name}: {m["heading_at_stop"]:.3f} rad at the stop')
    ax_r.set(title='yaw rate (truth)', ylabel='yaw rate r [rad/s]')
    ax_p.set(title='heading (truth)', ylabel='heading psi [rad]')
    for ax in (ax_r, ax_p):
        ax.set_xlabel('time since the brake start [s]')
        ax.set_xlim(-0.1, _window(runs))
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    u_b = np.mean([m['u_brake'] for _, m in runs.values()])
    fig.suptitle(f'Split-mu braking (0.8 left / 0.3 right) from {u_b:.2f} m/s: yaw of the car')
    return save_figure(fig, path, dpi=100)


def plot_step_steer(runs: dict, path) -> Path:
    """Step steer; ``runs``: mode (``open``, ``chassis``) -> (Run, step-steer metrics)."""
    plt = _plt()
    colours = _colours(plt)
    fig, (ax_r, ax_d, ax_t) = plt.subplots(3, 1, figsize=(11, 10), sharex=True)
    t_end = 0.0
    for i, (mode, (run, m)) in enumerate(runs.items()):
        s = step_steer_series(run)
        name = 'chassis controller' if mode == 'chassis' else LABEL.get(mode, mode)
        t0, ls = s['t0'], STYLE.get(mode, '-')
        t_end = max(t_end, float(s['t'][-1] - t0))
        ax_r.plot(s['t'] - t0, s['r'], linestyle=ls, color=colours[i],
                  label=f'{name}: 90 % in {m["rise_time_90"]:.3f} s, overshoot '
                        f'{m["overshoot_percent"]:.1f} %, ISE {m["ise"]:.2e} rad^2/s')
        if i == 0:
            ax_r.plot(s['t'] - t0, s['r_ref'], '-', color='k', lw=0.8,
                      label='reference (bicycle steady state)')
        st = run.series['steer']
        ax_d.plot(st['t'] - t0, st['rear'], linestyle=ls, color=colours[i],
                  label=f'rear command, {name}')
        if run.has('act'):
            a = run.series['act']
            ax_d.plot(a['t'] - t0, a['rear'], linestyle=ls, color=colours[i], lw=0.8, alpha=0.6,
                      label=f'rear achieved, {name}')
        if i == 0:
            ax_d.plot(st['t'] - t0, st['front'], '-', color='k', lw=0.8,
                      label='front command (driver)')
        if run.has('cmd'):
            c = run.series['cmd']
            ax_t.plot(c['t'] - t0, differential_torque(c['torque']), linestyle=ls,
                      color=colours[i], label=name)
    ax_r.set(title='yaw rate (truth) against the reference', ylabel='yaw rate r [rad/s]')
    ax_d.set(title='steer angles', ylabel='steer [rad]')
    ax_t.set(title='differential torque dT = (T_FR + T_RR - T_FL - T_RL) / 4',
             ylabel='dT [N m]', xlabel='time since the steer step [s]')
    for ax in (ax_r, ax_d, ax_t):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_xlim(-0.1, t_end)
    u0 = np.mean([float(np.interp(m['t_steer'], r.series['tyre']['t'], r.series['tyre']['u']))
                  for r, m in runs.values() if r.has('tyre')] or [np.nan])
    fig.suptitle(f'Torque car: driver front step steer at {u0:.2f} m/s, with and without the '
                 'chassis controller')
    return save_figure(fig, path, dpi=100)
