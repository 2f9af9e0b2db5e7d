"""Figure 10 of the paper: MRC with / without the actuator and PI vs the reference model.

No rclpy. Three pieces:

* :func:`reference_model_response` -- the reference model ``Gm = Bm/Am``
  (:func:`irs_control.paper_design.reference_model`, Eq. 21) driven by the *sampled*
  reference (ZOH-exact discretisation at the sample period, zero initial state). This is
  what every run is compared against (the dashed line of Figure 10).
* :func:`run_metrics` -- step metrics of one run (see "Metric windows" below).
* :func:`write_report` -- ``figure10.png`` (the paper's three stacked panels),
  ``figure10_steer.png``, ``figure10_metrics.md`` and ``figure10_metrics.csv``.

``main(['--offline', '--out', DIR])`` simulates the three designs with
:class:`irs_bringup.offline_twin.lateral_loop.ClosedLoop` on the default Figure 10 configuration
and writes the report. A run is a dict of 1-D numpy arrays ``time, y_s, reference, steer_cmd,
steer_achieved`` (``steer_cmd`` may have length N or N+1 for N+1 time samples; non-finite reference
samples, e.g. the last sample of a ClosedLoop record, are held from the previous sample).

Default scenario (V = 1.2 m/s, ds = 0.33 m, the identified plant, a 0.02 m step at 0.5 s):
:func:`simulate_offline`; metric windows and definitions: :func:`run_metrics`.
"""
from __future__ import annotations

import argparse
import csv
import functools
import math
import os
from pathlib import Path

import numpy as np

from irs_control import metrics as M
from irs_control.paper_design import reference_model
from irs_models.constants import STEER_LIMIT  # [rad] 15 deg: the "time at limit" metric

__all__ = ['RUN_NAMES', 'RUN_LABELS', 'DEFAULT_STEP', 'DEFAULT_STEP_TIME', 'DEFAULT_DURATION',
           'DEFAULT_RIG', 'DEFAULT_CONTROLLERS', 'METRIC_COLUMNS', 'RESIDUAL_DELAY',
           'STEER_LIMIT', 'reference_model_response', 'step_window', 'run_metrics',
           'write_report', 'model_metrics', 'band_crossings', 'metrics_markdown',
           'simulate_offline', 'main']

#: Run names in panel order (top, middle, bottom).
RUN_NAMES = ('mrc_with_actuator', 'mrc_without_actuator', 'pi')
RUN_LABELS = {'mrc_with_actuator': 'MRC (RST) with actuator',
              'mrc_without_actuator': 'MRC (RST) without actuator',
              'pi': 'PI (Kp = 5, Ki = 3)'}
#: Default reference step [m], its time [s] and the record length [s].
DEFAULT_STEP = 0.02
DEFAULT_STEP_TIME = 0.5
DEFAULT_DURATION = 8.0
#: Residual oscillation is measured from t_step + RESIDUAL_DELAY [s].
RESIDUAL_DELAY = 3.0
#: Rig overrides of the default scenario (empty: irs_vehicle_sim/config/rig.yaml defaults,
#: i.e. identified plant at 1.2 m/s, ds 0.33 m, all actuator non-idealities and arm noise on).
DEFAULT_RIG: dict = {}
#: Controller parameters of the three designs (controller_factory keys).
DEFAULT_CONTROLLERS = {
    'mrc_with_actuator': {'mode': 'mrc', 'include_actuator': True},
    'mrc_without_actuator': {'mode': 'mrc', 'include_actuator': False},
    'pi': {'mode': 'pi', 'kp': 5.0, 'ki': 3.0},
}

#: (key, header, format) of the metrics table.
METRIC_COLUMNS = (
    ('step', 'step [m]', '{:.3g}'),
    ('rise_time', 'rise 10-90 [s]', '{:.3f}'),
    ('overshoot_percent', 'overshoot [%]', '{:.1f}'),
    ('settling_time', 'settle 2 % [s]', '{:.2f}'),
    ('oscillation_count', 'set-point crossings', '{:d}'),
    ('crossings_2pct', 'crossings +-2 % band', '{:d}'),
    ('residual_oscillation', 'residual p-p [m]', '{:.2e}'),
    ('ise_vs_model', 'ISE vs model [m^2 s]', '{:.3e}'),
    ('ise_norm', 'ISE/step^2 [s]', '{:.3e}'),
    ('max_dev_rel', 'max|y-ym|/step', '{:.4f}'),
    ('peak_steer_cmd_deg', 'peak steer cmd [deg]', '{:.2f}'),
    ('peak_steer_achieved_deg', 'peak steer achieved [deg]', '{:.2f}'),
    ('time_at_limit', 'time at limit [s]', '{:.3f}'),
)


# --------------------------------------------------------------------------- model response
def _hold_nonfinite(r):
    r = np.array(r, dtype=float)
    ok = np.isfinite(r)
    if not ok.any():
        raise ValueError('reference has no finite sample')
    first = int(np.argmax(ok))
    r[:first] = r[first]
    for i in range(first + 1, r.size):
        if not ok[i]:
            r[i] = r[i - 1]
    return r


def reference_model_response(time, reference) -> np.ndarray:
    """Output of ``Gm = Bm/Am`` for the sampled ``reference`` held between samples.

    ZOH-exact discretisation per sample interval (one matrix exponential when the sampling
    is uniform), zero initial state; ``y_model[k]`` is the model output at ``time[k]`` (Gm is
    strictly proper, so it depends on ``reference[:k]`` only). Non-finite reference samples
    are replaced by the previous finite value (leading ones by the first finite value).
    A process keeps the responses of its last 8 (time, reference) pairs: the points of a sweep
    share their reference, and each would otherwise step the model again (20-30 ms for 5 s);
    every call returns its own array.
    """
    t = np.asarray(time, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError('time must be a 1-D array with at least 2 samples')
    r = _hold_nonfinite(reference)
    if r.shape != t.shape:
        raise ValueError(f'reference length {r.size} != time length {t.size}')
    dts = np.diff(t)
    if np.any(dts <= 0):
        raise ValueError('time must be strictly increasing')
    Bm, Am = reference_model()
    return _model_response(t.tobytes(), r.tobytes(), tuple(np.asarray(Bm, float)),
                           tuple(np.asarray(Am, float))).copy()


@functools.lru_cache(maxsize=8)
def _model_response(t_bytes: bytes, r_bytes: bytes, Bm: tuple, Am: tuple) -> np.ndarray:
    """:func:`reference_model_response` of checked float64 ``time`` and ``reference`` bytes."""
    from scipy.signal import cont2discrete, tf2ss

    t, r = np.frombuffer(t_bytes), np.frombuffer(r_bytes)
    dts = np.diff(t)
    A, B, C, D = tf2ss(np.asarray(Bm), np.asarray(Am))
    x = np.zeros((A.shape[0], 1))
    y = np.empty_like(t)
    uniform = np.allclose(dts, dts[0], rtol=1e-6, atol=0.0)
    cache = {}
    for k in range(t.size):
        y[k] = float((C @ x)[0, 0] + D[0, 0] * r[k])
        if k == t.size - 1:
            break
        key = dts[0] if uniform else round(float(dts[k]), 12)
        if key not in cache:
            cache[key] = cont2discrete((A, B, C, D), key, method='zoh')[:2]
        Ad, Bd = cache[key]
        x = Ad @ x + Bd * r[k]
    y.flags.writeable = False
    return y


# --------------------------------------------------------------------------- metrics
def _align(x, n):
    """Commands of length N (held over [t_k, t_k+1)) or N+1 -> length n (last one held)."""
    x = np.asarray(x, dtype=float)
    if x.size == n:
        return x
    if x.size == n - 1:
        return np.append(x, x[-1] if x.size else np.nan)
    raise ValueError(f'steer array length {x.size} is neither {n} nor {n - 1}')


#: [s] the least time a reference must hold its first new value to be a step (a sine, ramp or
#: chirp changes every sample: the step metrics would describe one sample).
MIN_STEP_HOLD = 0.1


def step_window(time, reference):
    """``(y0, setpoint, t_step, t_end, i0, i1)`` of the first reference step (:func:`run_metrics`).

    ``i0:i1`` is the index slice of the step window. ``ValueError`` when the reference never
    changes, or changes again within :data:`MIN_STEP_HOLD` of its first change (no step).
    """
    t = np.asarray(time, dtype=float)
    r = _hold_nonfinite(reference)
    y0 = r[0]
    changed = np.nonzero(np.abs(r - y0) > 1e-12 * max(1.0, abs(y0)))[0]
    if changed.size == 0:
        raise ValueError('the reference never changes: no step to evaluate')
    i0 = int(changed[0])
    sp = r[i0]
    later = np.nonzero(np.abs(r[i0:] - sp) > 1e-12 * max(1.0, abs(sp)))[0]
    i1 = i0 + int(later[0]) if later.size else t.size
    if i1 < t.size and t[i1] - t[i0] < MIN_STEP_HOLD:
        raise ValueError(f'the reference is no step: it changes again {t[i1] - t[i0]:.3g} s '
                         f'after its first change at {t[i0]:.3g} s (the step metrics need a '
                         f'value held at least {MIN_STEP_HOLD:g} s)')
    return float(y0), float(sp), float(t[i0]), float(t[i1 - 1]), i0, i1


def band_crossings(y, setpoint, band) -> int:
    """Set-point crossings after the first, with hysteresis: a crossing counts only when
    ``y`` goes from above ``setpoint + band`` to below ``setpoint - band`` or back (noise
    and backlash jitter inside the band are ignored). ``band`` >= 0 [m].
    """
    y = np.asarray(y, dtype=float)
    s = np.where(y > setpoint + band, 1, np.where(y < setpoint - band, -1, 0))
    s = s[s != 0]
    return max(int(np.count_nonzero(s[1:] != s[:-1])) - 1, 0) if s.size else 0


def run_metrics(run: dict, steer_limit: float = STEER_LIMIT) -> dict:
    """Figure-10 metrics of one run on its first reference step.

    The step is the first change of the reference: ``t_step`` = first sample whose reference
    differs from the first finite reference value ``y0``; ``setpoint`` = the reference right after
    the change. The *step window* runs from ``t_step`` to the next reference change (or the end of
    the record). Within it (``irs_control.metrics``): rise time 10-90 %, overshoot [%], 2 %
    settling time (from ``t_step``; nan if not settled by the window end), oscillation count
    (set-point crossings after the first; ``crossings_2pct``: the same with a +-2 % of step
    hysteresis band, so noise/backlash jitter does not count), residual oscillation = peak-to-peak
    of ``y_s`` over ``[t_step + RESIDUAL_DELAY, window end]`` (3 s after the step: the model has
    settled to 0.02 % by then), ISE vs model = ``int (y_s - y_model)^2 dt`` over the step window
    [m^2 s], also normalised by ``delta^2`` [s] and as ``max |y_s - y_model| / |delta|``, peak
    |steer command| and peak |achieved steer| [deg] over the step window, and the time the command
    sits at the steer limit [s].
    """
    t = np.asarray(run['time'], dtype=float)
    y = np.asarray(run['y_s'], dtype=float)
    n = t.size
    if y.shape != t.shape:
        raise ValueError('y_s and time must have the same length')
    y_model = reference_model_response(t, run['reference'])
    y0, sp, t_step, t_end, i0, i1 = step_window(t, run['reference'])
    delta = sp - y0
    tw, yw, ymw = t[i0:i1], y[i0:i1], y_model[i0:i1]
    cmd = _align(run['steer_cmd'], n)[i0:i1]
    ach = (
        _align(run['steer_achieved'], n)[i0:i1]
        if 'steer_achieved' in run
        else np.full(tw.size, np.nan)
    )
    ise = M.ise_vs_model(tw, yw, ymw)
    at_limit = np.abs(cmd) >= steer_limit * (1.0 - 1e-6)
    dt = np.diff(tw, append=tw[-1] + (tw[-1] - tw[-2] if tw.size > 1 else 0.0))
    res_from = t_step + RESIDUAL_DELAY
    return {
        'step': delta,
        'y0': y0,
        't_step': t_step,
        't_end': t_end,
        'rise_time': M.rise_time(tw, yw, sp, y0),
        'overshoot_percent': M.overshoot_percent(yw, sp, y0),
        'settling_time': M.settling_time(tw, yw, sp, y0, t_step=t_step),
        'oscillation_count': M.oscillation_count(yw, sp),
        'crossings_2pct': band_crossings(
            np.sign(delta) * (yw - y0), abs(delta), 0.02 * abs(delta)
        ),
        'residual_oscillation': (
            M.residual_oscillation(tw, yw, res_from) if tw[-1] >= res_from else float('nan')
        ),
        'ise_vs_model': ise,
        'ise_norm': ise / delta**2,
        'max_dev_rel': float(np.max(np.abs(yw - ymw)) / abs(delta)),
        'peak_steer_cmd_deg': math.degrees(M.peak_abs(cmd)),
        'peak_steer_achieved_deg': math.degrees(float(np.nanmax(np.abs(ach))))
        if np.isfinite(ach).any()
        else float('nan'),
        'time_at_limit': float(np.sum(dt[at_limit])),
    }


# --------------------------------------------------------------------------- report
def _fmt(fmt, v):
    if isinstance(v, float) and not math.isfinite(v):
        return 'nan'
    if '{:d}' in fmt:
        return fmt.format(int(v))
    return fmt.format(v)


def metrics_markdown(table: dict, title: str = '') -> str:
    """Markdown table of ``{run name: run_metrics(...)}``."""
    head = '| run | ' + ' | '.join(h for _, h, _ in METRIC_COLUMNS) + ' |'
    sep = '|---|' + '---|' * len(METRIC_COLUMNS)
    rows = [f'| {name} | ' + ' | '.join(_fmt(f, m[k]) for k, _, f in METRIC_COLUMNS) + ' |'
            for name, m in table.items()]
    out = ([f'# {title}', ''] if title else []) + [head, sep] + rows
    return '\n'.join(out) + '\n'


def model_metrics(run: dict) -> dict:
    """:func:`run_metrics` of the reference model itself on ``run``'s reference (steer nan)."""
    t = np.asarray(run['time'], dtype=float)
    nan = np.full(t.size, np.nan)
    return run_metrics({'time': t, 'y_s': reference_model_response(t, run['reference']),
                        'reference': run['reference'], 'steer_cmd': nan, 'steer_achieved': nan})


def write_report(runs: dict, out_dir, title: str = 'Figure 10') -> dict:
    """Plots and metrics table of the runs ``{name: run dict}`` into ``out_dir``.

    Names ``'mrc_with_actuator'``, ``'mrc_without_actuator'``, ``'pi'`` are drawn in the
    paper's panel order (other names follow). Writes ``figure10.png``,
    ``figure10_steer.png``, ``figure10_metrics.md``, ``figure10_metrics.csv`` (the tables
    add a ``reference_model`` row: the model's own metrics on the first run's reference);
    returns ``{name: run_metrics(run)}`` for the runs only.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    if not runs:
        raise ValueError('write_report needs at least one run')
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = [n for n in RUN_NAMES if n in runs] + [n for n in runs if n not in RUN_NAMES]
    table = {n: run_metrics(runs[n]) for n in names}

    fig, axes = plt.subplots(len(names), 1, sharex=True, figsize=(7.5, 2.4 * len(names) + 0.6),
                             squeeze=False)
    for ax, n in zip(axes[:, 0], names):
        run = runs[n]
        t = np.asarray(run['time'], float)
        ym = reference_model_response(t, run['reference'])
        ax.plot(t, np.asarray(run['y_s'], float), 'k-', lw=1.3, label=RUN_LABELS.get(n, n))
        ax.plot(t, ym, 'k--', lw=1.0, label='reference model')
        ax.plot(t, _hold_nonfinite(run['reference']), color='0.6', lw=0.8, label='reference')
        m = table[n]
        ax.set_title(f"{RUN_LABELS.get(n, n)}: overshoot {m['overshoot_percent']:.1f} %, "
                     f"ISE vs model {m['ise_vs_model']:.2e} m$^2$s", fontsize=9)
        ax.set_ylabel('$y_s$ [m]')
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc='lower right')
    axes[-1, 0].set_xlabel('time [s]')
    fig.suptitle(f'{title}: lateral displacement vs time', fontsize=10)
    fig.tight_layout()
    fig.savefig(out / 'figure10.png', dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(len(names), 1, sharex=True, figsize=(7.5, 2.2 * len(names) + 0.6),
                             squeeze=False)
    for ax, n in zip(axes[:, 0], names):
        run = runs[n]
        t = np.asarray(run['time'], float)
        ax.step(t, np.degrees(_align(run['steer_cmd'], t.size)), where='post', color='C0',
                lw=1.0, label='steer command')
        if 'steer_achieved' in run:
            ax.plot(t, np.degrees(np.asarray(run['steer_achieved'], float)), color='C1', lw=1.0,
                    label='achieved steer')
        for s in (-1, 1):
            ax.axhline(s * math.degrees(STEER_LIMIT), color='r', ls=':', lw=0.8)
        ax.set_title(RUN_LABELS.get(n, n), fontsize=9)
        ax.set_ylabel('steer [deg]')
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc='upper right')
    axes[-1, 0].set_xlabel('time [s]')
    fig.suptitle(f'{title}: front steer', fontsize=10)
    fig.tight_layout()
    fig.savefig(out / 'figure10_steer.png', dpi=110)
    plt.close(fig)

    full = {**table, 'reference_model': model_metrics(runs[names[0]])}
    (out / 'figure10_metrics.md').write_text(metrics_markdown(full, title))
    keys = ['run'] + [k for k, _, _ in METRIC_COLUMNS] + ['y0', 't_step', 't_end']
    with open(out / 'figure10_metrics.csv', 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(keys)
        for n, m in full.items():
            w.writerow([n] + [repr(m[k]) if isinstance(m[k], float) else m[k] for k in keys[1:]])
    return table


# --------------------------------------------------------------------------- offline runs
def simulate_offline(step: float = DEFAULT_STEP, duration: float = DEFAULT_DURATION,
                     rig: dict | None = None, controllers: dict | None = None,
                     step_time: float = DEFAULT_STEP_TIME, regulator: dict | None = None,
                     names=RUN_NAMES) -> dict:
    """``{name: ClosedLoop run}`` of the designs on a reference step (default scenario).

    Default scenario (``DEFAULT_*``, docs/figure10.md): V = 1.2 m/s, ds = 0.33 m, identified plant
    (Eq. 6), rig.yaml defaults: the servo (7 Hz loop, slew limit 1.16 rad/s at the wheel, friction
    dead zone, linkage; docs/vehicle_sim.md), 17 ms delay, 0.175 deg backlash, 15 deg saturation,
    arm pot noise and 12-bit ADC quantisation on; treadmill regulator on. Reference: a 0.02 m step
    at 0.5 s, 8 s record. Why 0.02 m and not a 0.1 m step (the paper's axis is labelled at 0.1 m
    but the step size is not printed): the MRC-with-actuator design commands about 7.2 rad of steer
    per metre of step in the linear range, so steps above ~0.036 m hit the 15 deg limit; at 0.05 m
    and above all three designs saturate for most of the transient, the responses become
    saturation-limited (rise times converge, the MRC designs' differences blur) and model following
    is impossible by construction. 0.02 m is the largest step of round size where both MRC designs
    stay linear (peak steer ~8 deg), i.e. where the paper's comparison of the designs is
    meaningful; the study (:mod:`.figure10_study`) covers 0.01-0.2 m.
    """
    from irs_bringup.offline_twin.lateral_loop import ClosedLoop, LoopConfig

    rig = DEFAULT_RIG if rig is None else rig
    ctls = {**DEFAULT_CONTROLLERS, **(controllers or {})}
    ref = {'signal.type': 'step', 'signal.amplitude': float(step),
           'signal.start_time': float(step_time)}
    runs = {}
    for n in names:
        loop = ClosedLoop(LoopConfig(rig=dict(rig), controller=dict(ctls[n]), reference=ref,
                                     regulator={} if regulator is None else dict(regulator)))
        runs[n] = loop.run(duration)
    return runs


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog='python -m irs_studies.figure10.report',
                                description='Figure 10 report (MRC with/without actuator, PI).')
    p.add_argument('--offline', action='store_true',
                   help='simulate the three designs with the offline ClosedLoop')
    p.add_argument('--out', default='figure10_out', help='output directory')
    p.add_argument('--step', type=float, default=DEFAULT_STEP, help='reference step [m]')
    p.add_argument('--duration', type=float, default=DEFAULT_DURATION, help='record length [s]')
    p.add_argument('--title', default='Figure 10 (offline)')
    a = p.parse_args(argv)
    if not a.offline:
        p.error('only --offline is implemented here (the ROS-graph mode feeds write_report)')
    runs = simulate_offline(step=a.step, duration=a.duration)
    table = write_report(runs, a.out, a.title)
    print(metrics_markdown(table), end='')
    print(f'wrote {os.path.abspath(a.out)}/figure10.png, figure10_steer.png, '
          f'figure10_metrics.md, figure10_metrics.csv')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
