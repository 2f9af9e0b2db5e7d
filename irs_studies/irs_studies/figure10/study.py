"""Check the paper's Figure 10 claims with several oscillation measures (no rclpy).

``python -m irs_studies.figure10.study --out REPORT.md [--duration 8] [--jobs 1]``

Claims (paper Sec. 5):

* A -- the MRC designed *with* the actuator follows the reference model almost perfectly;
* B -- the MRC that neglects the actuator is less damped / more oscillatory;
* C -- ... even more oscillatory than the PI (Kp = 5, Ki = 3);
* D -- the PI cannot achieve the fast transient (slower rise).

Evidence: (1) linear closed-loop poles of the three designs on the design model with the
actuator (pole 29 rad/s), without and with the 17 ms delay (3rd-order Pade); (2) offline
closed-loop runs (:func:`irs_studies.figure10.report.simulate_offline`) at the default 0.02 m step
with the actuator non-idealities switched on cumulatively and one at a time, arm noise
on/off; (3) a step-size sweep 0.01-0.2 m, all non-idealities on and "linear" (lag only).
Metrics: :func:`irs_studies.figure10.report.run_metrics`.

Seed statistics at 0.02 m and 0.1 m with both anti-windup choices: :mod:`.seeds`. How
"without saturation" is set up: :func:`rig_params`.
"""
from __future__ import annotations

import argparse
import math
import time as _time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from irs_control.controller_factory import make_controller
from irs_control.paper_design import identified_plant

from .report import (DEFAULT_CONTROLLERS, DEFAULT_STEP, RUN_NAMES, STEER_LIMIT,
                       model_metrics, run_metrics, simulate_offline)
from .seeds import reproduce_figures

__all__ = ['rig_params', 'CONDITIONS', 'STEPS', 'closed_loop_poles', 'dominant',
           'run_condition', 'main', 'reproduce_figures']

#: Controller steer limit when the saturation is "off" [rad] (< rig steer_reject 0.5236).
NO_SAT_LIMIT = 0.5
STEPS = (0.01, 0.02, 0.05, 0.1, 0.2)


def rig_params(lag=True, delay=False, backlash=False, saturation=False, rate_limit=False,
               noise=False, lag_hz=None, friction=False, linkage=False) -> dict:
    """Flat rig overrides with the given front-actuator elements and arm noise/ADC.

    The servo's gear ratio alone does not change the wheel's response (horn and reference scale
    alike), so with friction, linkage and rate limit off the servo loop is the plain lag.

    Saturation: the controllers clip their command at ``steer_limit`` (15 deg, with anti-windup) in
    the paper's design, which makes the rig's saturation element redundant. In the conditions
    "without saturation" the controller limit is raised to 0.5 rad (28.6 deg, just below the rig's
    30 deg command-reject threshold) and the rig saturation is off; "with saturation" is the
    paper's 15 deg limit in both.
    """
    p = {'actuator_front.enable_lag': lag, 'actuator_front.enable_delay': delay,
         'actuator_front.enable_backlash': backlash,
         'actuator_front.enable_saturation': saturation,
         'actuator_front.enable_rate_limit': rate_limit,
         'actuator_front.enable_friction': friction,
         'actuator_front.enable_linkage_geometry': linkage,
         'arm.enable_noise': noise, 'arm.enable_quantization': noise}
    if lag_hz is not None:
        p['actuator_front.lag_hz'] = float(lag_hz)
    return p


#: name -> (description, rig flags). Cumulative chain, then one-at-a-time on top of the lag.
CONDITIONS = {
    'lag29': ('lag only, rig pole = design pole 29 rad/s (4.616 Hz)',
              dict(lag_hz=29.0 / (2 * math.pi))),
    'lag': ('lag only (the servo loop, 7 Hz = 44.0 rad/s)', dict()),
    '+delay': ('lag + 17 ms delay', dict(delay=True)),
    '+backlash': ('lag + delay + 0.175 deg backlash', dict(delay=True, backlash=True)),
    '+saturation': ('lag + delay + backlash + 15 deg saturation',
                    dict(delay=True, backlash=True, saturation=True)),
    '+rate': ('... + servo slew limit 1.16 rad/s at the wheel, friction dead zone, linkage '
              '(all actuator, no arm noise)',
              dict(delay=True, backlash=True, saturation=True, rate_limit=True, friction=True,
                   linkage=True)),
    'all': ('... + arm noise and 12-bit ADC (= default Figure 10 scenario)',
            dict(delay=True, backlash=True, saturation=True, rate_limit=True, noise=True,
                 friction=True, linkage=True)),
    'lag+backlash': ('lag + backlash only', dict(backlash=True)),
    'lag+saturation': ('lag + 15 deg saturation only', dict(saturation=True)),
    'lag+rate': ('lag + rate limit only', dict(rate_limit=True)),
    'lag+noise': ('lag + arm noise/ADC only', dict(noise=True)),
}


def _controllers(saturation: bool) -> dict:
    if saturation:
        return {n: dict(c) for n, c in DEFAULT_CONTROLLERS.items()}
    return {n: {**c, 'steer_limit': NO_SAT_LIMIT} for n, c in DEFAULT_CONTROLLERS.items()}


def run_condition(args):
    """``(cond, step) -> {name: metrics}`` (picklable for the process pool)."""
    cond, step, duration = args
    flags = CONDITIONS[cond][1]
    runs = simulate_offline(step=step, duration=duration, rig=rig_params(**flags),
                            controllers=_controllers(flags.get('saturation', False)))
    limit = STEER_LIMIT if flags.get('saturation', False) else NO_SAT_LIMIT
    out = {n: run_metrics(r, steer_limit=limit) for n, r in runs.items()}
    out['model'] = model_metrics(runs[RUN_NAMES[0]])
    return cond, step, out


# --------------------------------------------------------------------------- linear analysis
def closed_loop_poles(name: str, delay: float = 0.0, pade_order: int = 3) -> np.ndarray:
    """Closed-loop poles of design ``name`` on the design plant with the actuator (29 rad/s).

    MRC: roots of ``A R + B S`` (with delay: ``A R Dd + B S Nd``); PI: roots of
    ``A s + B (kp s + ki)`` (with delay likewise), ``Nd/Dd`` = Pade approximation.
    """
    import control

    B, A = identified_plant(True)
    cfg = DEFAULT_CONTROLLERS[name]
    if cfg['mode'] == 'pi':
        R, S = np.array([1.0, 0.0]), np.array([cfg['kp'], cfg['ki']])
    else:
        d = make_controller(cfg).design
        R, S = d.R, d.S
    Nd, Dd = (np.array([1.0]), np.array([1.0])) if delay == 0 else \
        tuple(np.asarray(x, float) for x in control.pade(delay, pade_order))
    char = np.polyadd(np.polymul(np.polymul(A, R), Dd), np.polymul(np.polymul(B, S), Nd))
    return np.roots(char)


def dominant(poles, wmax: float = 60.0) -> dict:
    """Least-damped complex pair and slowest pole among poles with ``|s| < wmax`` rad/s
    (excludes the Pade poles and the fast observer/actuator modes).
    """
    p = np.asarray(poles)
    p = p[np.abs(p) < wmax]
    cx = p[(p.imag > 1e-5 * np.abs(p))]
    out = {'zeta': float('nan'), 'wn': float('nan'), 'pair': None,
           'slowest': complex(p[np.argmin(np.abs(p.real))]) if p.size else None,
           'max_re': float(np.max(p.real)) if p.size else float('nan')}
    if cx.size:
        z = -cx.real / np.abs(cx)
        i = int(np.argmin(z))
        out.update(zeta=float(z[i]), wn=float(abs(cx[i])), pair=complex(cx[i]))
    return out


def _pstr(p):
    return ', '.join(
        f'{z.real:.2f}{z.imag:+.2f}j' if abs(z.imag) > 1e-5 * abs(z) else f'{z.real:.2f}'
        for z in sorted(p, key=lambda z: (-z.real, z.imag))
        if z.imag >= -1e-5 * abs(z)
    )


# --------------------------------------------------------------------------- report
COLS = (('rise_time', 'rise [s]', '{:.3f}'), ('overshoot_percent', 'OS [%]', '{:.1f}'),
        ('settling_time', 'settle [s]', '{:.2f}'), ('oscillation_count', 'cross', '{:d}'),
        ('crossings_2pct', 'cross±2%', '{:d}'),
        ('residual_oscillation', 'resid p-p/step', '{:.3f}'),
        ('ise_norm', 'ISE/step² [s]', '{:.2e}'), ('max_dev_rel', 'max|y-ym|/step', '{:.4f}'),
        ('peak_steer_cmd_deg', 'peak cmd [deg]', '{:.1f}'),
        ('time_at_limit', 'at limit [s]', '{:.2f}'))
SHORT = {'mrc_with_actuator': 'MRC+act', 'mrc_without_actuator': 'MRC-act', 'pi': 'PI',
         'model': 'model'}


def _val(m, k, f):
    v = m[k]
    if k == 'residual_oscillation':
        v = v / abs(m['step'])
    if isinstance(v, float) and not math.isfinite(v):
        return 'nan'
    return f.format(int(v)) if '{:d}' in f else f.format(v)


def _table(rows):
    """rows: list of (label, metrics dict)."""
    lines = ['| case | design | ' + ' | '.join(h for _, h, _ in COLS) + ' |',
             '|---|---|' + '---|' * len(COLS)]
    for label, res in rows:
        for n in (*RUN_NAMES, 'model'):
            m = res[n]
            lines.append(
                f'| {label} | {SHORT[n]} | ' + ' | '.join(_val(m, k, f) for k, _, f in COLS) + ' |'
            )
    return '\n'.join(lines)


def _more_osc(a, b):
    """Measures by which metrics a is more oscillatory than b: list of (name, a, b, bool)."""
    return [('overshoot %', a['overshoot_percent'], b['overshoot_percent'],
             a['overshoot_percent'] > b['overshoot_percent']),
            ('crossings ±2 %', a['crossings_2pct'], b['crossings_2pct'],
             a['crossings_2pct'] > b['crossings_2pct']),
            ('raw crossings', a['oscillation_count'], b['oscillation_count'],
             a['oscillation_count'] > b['oscillation_count']),
            ('residual p-p/step', a['residual_oscillation'] / abs(a['step']),
             b['residual_oscillation'] / abs(b['step']),
             a['residual_oscillation'] > b['residual_oscillation'])]


def _fmtv(v):
    return f'{v:.3g}' if isinstance(v, float) else str(v)


def build_report(results, poles, elapsed, duration) -> str:
    R = results
    L = [
        '# Figure 10 claims study',
        '',
        f'Generated by `python -m irs_studies.figure10.study` ({len(R)} condition/step '
        f'cases x 3 '
        f'designs, {duration:g} s records, step at 0.5 s, {elapsed:.0f} s wall time). Metrics as '
        'in `irs_studies.figure10.report` (step window = whole record after the step; residual '
        'p-p from 3 s after the step, shown divided by the step; ISE normalised by step²). '
        '"model" rows are the reference model itself. MRC+act / MRC-act = MRC designed '
        'with / without the actuator lag.',
        '',
    ]
    # poles
    L += ['## 1. Linear closed-loop poles (design plant with actuator pole 29 rad/s)', '',
          'Dominant = least-damped complex pair and slowest pole with |s| < 60 rad/s '
          '(the delay column uses a 3rd-order Pade of 17 ms). For MRC+act the closed loop is '
          'Am·Ao·B+ exactly; the slowest poles -2.4, -4.8 are the cancelled plant zeros (not '
          'excited by the reference, only by disturbances/noise/initial conditions).', '',
          '| design | poles (upper half plane, no delay) | ζ, ωn of least-damped pair | '
          'same with 17 ms delay | slowest pole |', '|---|---|---|---|---|']
    for n in RUN_NAMES:
        d0, d1 = poles[n]['d0'], poles[n]['d1']
        L.append(
            f'| {SHORT[n]} | {_pstr(poles[n]["p0"])} | ζ = {d0["zeta"]:.3f}, ωn = {d0["wn"]:.2f} '
            f'| ζ = {d1["zeta"]:.3f}, ωn = {d1["wn"]:.2f} | {d0["slowest"].real:.2f} |'
        )
    L += ['']
    # conditions table
    base = [(c, R[(c, DEFAULT_STEP)]) for c in CONDITIONS]
    L += [f'## 2. Non-idealities at the default {DEFAULT_STEP} m step', '',
          '| case | description |', '|---|---|']
    L += [f'| {c} | {CONDITIONS[c][0]} |' for c in CONDITIONS]
    L += ['', _table([(c, r) for c, r in base]), '']
    # step sweep
    L += ['## 3. Step-size sweep', '',
          '"lag" = lag only with the controller limit at 0.5 rad (linear up to ~0.069 m for '
          'MRC+act); "all" = default scenario (15 deg limit, all non-idealities, noise).', '',
          _table([(f'{c} {s:g} m', R[(c, s)]) for c in ('lag', 'all') for s in STEPS]), '']
    # claims
    L += ['## 4. Claims', '']
    L += _claims(R, poles)
    return '\n'.join(L) + '\n'


def _claims(R, poles):
    L = []
    s0 = DEFAULT_STEP
    w = lambda c, s=s0: R[(c, s)]['mrc_with_actuator']   # noqa: E731
    wo = lambda c, s=s0: R[(c, s)]['mrc_without_actuator']   # noqa: E731
    pi = lambda c, s=s0: R[(c, s)]['pi']   # noqa: E731
    # A
    a29, alag, aall = w('lag29'), w('lag'), w('all')
    repro_a = a29['max_dev_rel'] < 5e-3
    L += [
        '### Claim A: MRC with actuator follows the reference model almost perfectly',
        '',
        f'- Linear, rig lag = design pole (29 rad/s), no delay/backlash/saturation/noise: '
        f'max|y - y_model|/step = {a29["max_dev_rel"]:.2e}, ISE/step² = {a29["ise_norm"]:.2e} s '
        f'(the residual is the 1 kHz ZOH discretisation of the continuous RST law: the measured '
        f'y is treated as held, ≈ dt/2 delay). '
        f'**{"Reproduced" if repro_a else "NOT reproduced"}** '
        'to the discretisation error.',
        f'- Rig servo loop 7 Hz (44.0 rad/s, linear; the design assumes 29 rad/s): max dev/step = '
        f'{alag["max_dev_rel"]:.2e}, ISE/step² = {alag["ise_norm"]:.2e} s.',
        '- Cumulative non-idealities at 0.02 m (max dev/step, ISE/step² [s], overshoot % vs '
        f'model {R[("lag", s0)]["model"]["overshoot_percent"]:.1f} %): '
        + '; '.join(
            f'{c}: {w(c)["max_dev_rel"]:.3f}, {w(c)["ise_norm"]:.2e}, '
            f'{w(c)["overshoot_percent"]:.1f} %'
            for c in ('lag', '+delay', '+backlash', '+saturation', '+rate', 'all')
        )
        + '.',
        '- One at a time on top of the lag: '
        + '; '.join(
            f'{c}: {w(c)["max_dev_rel"]:.3f}, {w(c)["ise_norm"]:.2e}'
            for c in ('+delay', 'lag+backlash', 'lag+saturation', 'lag+rate', 'lag+noise')
        )
        + '.',
        '- Step sweep, all non-idealities (max dev/step, ISE/step², time at limit): '
        + '; '.join(
            f'{s:g} m: {w("all", s)["max_dev_rel"]:.3f}, {w("all", s)["ise_norm"]:.2e}, '
            f'{w("all", s)["time_at_limit"]:.2f} s'
            for s in STEPS
        )
        + '.',
        f'- Verdict: reproduced in the linear range (exactly, up to ZOH error); with all '
        f'non-idealities at 0.02 m the design still follows the model far better than the '
        f'other two (ISE/step² {aall["ise_norm"]:.2e} vs {wo("all")["ise_norm"]:.2e} '
        f"(MRC-act) and {pi('all')['ise_norm']:.2e} (PI)), but 'nearly perfect' only "
        f"loosely: overshoot {aall['overshoot_percent']:.1f} % vs the model's "
        f'{R[("all", s0)]["model"]["overshoot_percent"]:.1f} %, max deviation '
        f'{100 * aall["max_dev_rel"]:.1f} % of the step. Once the command saturates '
        '(steps ≳ 0.036 m) model following is impossible by construction.',
        '',
    ]
    # B
    L += ['### Claim B: MRC neglecting the actuator is less damped / more oscillatory', '']
    pb = poles
    L.append(
        f'- Linear poles: least-damped pair ζ = {pb["mrc_without_actuator"]["d0"]["zeta"]:.3f} '
        f'(ωn {pb["mrc_without_actuator"]["d0"]["wn"]:.2f}) vs ζ = '
        f'{pb["mrc_with_actuator"]["d0"]["zeta"]:.3f} for MRC+act; with 17 ms delay '
        f'{pb["mrc_without_actuator"]["d1"]["zeta"]:.3f} vs '
        f'{pb["mrc_with_actuator"]["d1"]["zeta"]:.3f}.'
    )
    nb, tot = 0, 0
    rows = []
    for c in CONDITIONS:
        ms = _more_osc(wo(c), w(c))
        k = sum(x[3] for x in ms)
        nb += k
        tot += len(ms)
        rows.append(f'{c}: ' + ', '.join(f'{x[0]} {_fmtv(x[1])} vs {_fmtv(x[2])}' for x in ms))
    L.append(f'- Simulated at 0.02 m, MRC-act vs MRC+act ({nb}/{tot} measure-condition pairs '
             'say MRC-act is more oscillatory):')
    L += [f'  - {r}' for r in rows]
    L.append('- Step sweep (overshoot % MRC-act vs MRC+act): ' + '; '.join(
        f"{c} {s:g} m: {wo(c, s)['overshoot_percent']:.1f} vs {w(c, s)['overshoot_percent']:.1f}"
        for c in ('lag', 'all') for s in STEPS) + '.')
    lin = [s for s in STEPS if R[('all', s)]['mrc_with_actuator']['time_at_limit'] == 0.0]
    sat = [s for s in STEPS if s not in lin]
    k_lin = sum(x[3] for c in ('lag', 'all') for s in lin for x in _more_osc(wo(c, s), w(c, s)))
    n_lin = 4 * 2 * len(lin)
    k_sat = sum(x[3] for s in sat for x in _more_osc(wo('all', s), w('all', s)))
    L.append(f"- Verdict: **reproduced** wherever the command stays below the limit (steps "
             f"{', '.join(f'{s:g}' for s in lin)} m; {k_lin}/{n_lin} measure-case pairs, "
             f"overshoot about 2x, lower pole damping). With all non-idealities and saturated "
             f"steps ({', '.join(f'{s:g}' for s in sat)} m) both MRCs are saturation-limited, "
             f"overshoot < 2 % for both; only {k_sat}/{4 * len(sat)} measures (mainly raw "
             f"crossings from the backlash/noise jitter) still favour the claim.")
    L += ['', '### Claim C: MRC neglecting the actuator is more oscillatory than even the PI', '',
          f"- Linear poles: MRC-act ζ = {pb['mrc_without_actuator']['d0']['zeta']:.3f} at ωn "
          f"{pb['mrc_without_actuator']['d0']['wn']:.2f} rad/s vs PI ζ = "
          f"{pb['pi']['d0']['zeta']:.3f} at ωn {pb['pi']['d0']['wn']:.2f} rad/s (with delay: "
          f"{pb['mrc_without_actuator']['d1']['zeta']:.3f} vs {pb['pi']['d1']['zeta']:.3f})."]
    rows, counts = [], {}
    for c in CONDITIONS:
        ms = _more_osc(wo(c), pi(c))
        for x in ms:
            counts.setdefault(x[0], []).append(x[3])
        rows.append(f'{c}: ' + ', '.join(f'{x[0]} {_fmtv(x[1])} vs {_fmtv(x[2])}' for x in ms))
    L.append('- Simulated at 0.02 m, MRC-act vs PI; conditions in which MRC-act is more '
             'oscillatory, per measure: ' + ', '.join(
                 f'{k} {sum(v)}/{len(v)}' for k, v in counts.items()) + ':')
    L += [f'  - {r}' for r in rows]
    L.append('- Step sweep (overshoot % and crossings ±2 %, MRC-act vs PI): ' + '; '.join(
        f"{c} {s:g} m: {wo(c, s)['overshoot_percent']:.1f}/{wo(c, s)['crossings_2pct']} vs "
        f"{pi(c, s)['overshoot_percent']:.1f}/{pi(c, s)['crossings_2pct']}"
        for c in ('lag', 'all') for s in STEPS) + '.')
    amp = sum(counts['overshoot %']) + sum(counts['residual p-p/step'])
    L.append(
        f'- Verdict: **not reproduced** in amplitude or damping: the PI has the larger '
        f'overshoot ({pi("all")["overshoot_percent"]:.0f} % vs '
        f'{wo("all")["overshoot_percent"]:.0f} % '
        f'at 0.02 m, all non-idealities), the larger residual oscillation and the less damped '
        f'dominant pair (ζ {pb["pi"]["d0"]["zeta"]:.2f} vs '
        f'{pb["mrc_without_actuator"]["d0"]["zeta"]:.2f}) '
        f'in every case ({amp} of {2 * len(CONDITIONS)} overshoot/residual comparisons favour '
        f'the claim). **Partly reproduced** in the number of oscillations: the MRC-act '
        f'oscillates faster (ωn {pb["mrc_without_actuator"]["d0"]["wn"]:.1f} vs '
        f'{pb["pi"]["d0"]["wn"]:.1f} rad/s) and, with backlash and/or arm noise, keeps '
        f'crossing the set-point (raw crossings '
        f'{sum(counts["raw crossings"])}/{len(counts["raw crossings"])} '
        f'cases; ±2 % band crossings {wo("all")["crossings_2pct"]} vs '
        f'{pi("all")["crossings_2pct"]} '
        f'at 0.02 m and {wo("all", 0.01)["crossings_2pct"]} vs '
        f'{pi("all", 0.01)["crossings_2pct"]} '
        f"at 0.01 m with everything on), so a plot of a small-step experiment can look 'more "
        f"oscillatory' for the MRC-act although the PI swings further. Caveat: the PI result "
        f'depends on the reconstructed plant gain b0 (docs/control_design.md).'
    )
    L += [
        '',
        '### Claim D: PI cannot achieve the fast transient',
        '',
        '- 10-90 % rise time [s] PI vs MRC+act vs model: '
        + '; '.join(
            f'{c} {s:g} m: {pi(c, s)["rise_time"]:.3f} vs {w(c, s)["rise_time"]:.3f} vs '
            f'{R[(c, s)]["model"]["rise_time"]:.3f}'
            for c in ('lag', 'all')
            for s in STEPS
        )
        + '.',
        '- 2 % settling [s] PI vs MRC+act at 0.02 m: '
        + '; '.join(
            f'{c}: {pi(c)["settling_time"]:.2f} vs {w(c)["settling_time"]:.2f}'
            for c in ('lag', 'all')
        )
        + ' (nan = not settled within the record).',
        f'- Verdict: **reproduced** while the MRC is unsaturated (steps ≤ 0.02 m: PI rise '
        f'{pi("all")["rise_time"]:.3f} s vs MRC+act {w("all")["rise_time"]:.3f} s and model '
        f'{R[("all", s0)]["model"]["rise_time"]:.3f} s, i.e. '
        f'{pi("all")["rise_time"] / w("all")["rise_time"] - 1:+.0%} and '
        f'{pi("all")["rise_time"] / R[("all", s0)]["model"]["rise_time"] - 1:+.0%}; and the PI '
        f'needs '
        f'{pi("lag")["settling_time"]:.1f} s to settle to 2 % vs {w("lag")["settling_time"]:.2f} '
        f's) -- '
        f"the PI's fast initial rise is bought with ~50 % overshoot, so its transient is not "
        f'the desired one. **Reversed** for saturated steps (≥ 0.05 m with the 15 deg limit): '
        f'the MRC designs command full lock and then rise slower than the PI '
        f'(0.05 m: {w("all", 0.05)["rise_time"]:.3f} vs PI {pi("all", 0.05)["rise_time"]:.3f} s), '
        f'but they settle in ~1.1 s vs ~5.7 s.',
        '',
    ]
    return L


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog='python -m irs_studies.figure10.study')
    p.add_argument('--out', default='figure10_study.md', help='Markdown report path')
    p.add_argument('--duration', type=float, default=8.0, help='record length [s]')
    p.add_argument('--jobs', type=int, default=1, help='worker processes')
    a = p.parse_args(argv)
    t0 = _time.time()
    cases = [(c, DEFAULT_STEP) for c in CONDITIONS]
    cases += [(c, s) for c in ('lag', 'all') for s in STEPS if (c, s) not in cases]
    args = [(c, s, a.duration) for c, s in cases]
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            res = list(ex.map(run_condition, args))
    else:
        res = [run_condition(x) for x in args]
    results = {(c, s): m for c, s, m in res}
    poles = {}
    for n in RUN_NAMES:
        p0, p1 = closed_loop_poles(n), closed_loop_poles(n, 0.017)
        poles[n] = {'p0': p0, 'p1': p1, 'd0': dominant(p0), 'd1': dominant(p1)}
    text = build_report(results, poles, _time.time() - t0, a.duration)
    with open(a.out, 'w') as f:
        f.write(text)
    print(f'wrote {a.out} ({_time.time() - t0:.0f} s)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
