r"""``sysid vehicle <bag>``: the car's open loop from a closed-loop sweep (paper Sec. 4, Fig. 8-9).

    ./irs run irs_bringup experiment run sysid_vehicle_sweep      # 16.5 s lock-step, recorded
    ./irs run irs_bringup experiment run sysid_vehicle_step       # 8 s, a 0.02 m step
    ./irs run irs_sysid sysid vehicle runs/sysid_vehicle_sweep-<t>/bag \
        [--step-bag runs/sysid_vehicle_step-<t>/bag] [--png out/vehicle]

Both experiments run under the paper's PI (Kp = 5, Ki = 3), a loop made from no model of the
plant: the plant is identified first and designs rest on it afterwards, the paper's order
(Sec. 4-5). From the sweep bag (``lateral/reference`` r, ``steering/command`` u,
``lateral_position`` y, and ``steering/state`` for the achieved steer) two identifications
(:mod:`.vehicle_fit`):
the paper's (from the steer *command*, the actuator a 4.6 Hz lag plus the configured delay) and
one from the achieved steer (the vehicle alone, no actuator assumption): :func:`identify`.

Both are printed against the plant configured in the bag's metadata (``vehicle_sim``
parameters: Eq. 6 or a bicycle preset). ``--png PREFIX`` writes ``PREFIX_bode.png`` (Figure 8:
data dots, model fit dashed, configured plant solid) and, with ``--step-bag``,
``PREFIX_step.png`` (Figure 9: the measured, quantised step response against the identified
model closed with the bag's own controller). Exit 2 with one line for a bad bag or argument.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from irs_common.cli import InputError, RunFailed

from . import vehicle_fit as vf
from .common import save_figure
from .report import Estimate, format_report

__all__ = ['add_arguments', 'run', 'bag_parameters', 'load_run', 'identify', 'plot_bode',
           'plot_step', 'step_comparison', 'reproduce_figures']


def add_arguments(parser) -> None:
    parser.add_argument('bag', help='bag of a closed-loop sweep (e.g. sysid_vehicle_sweep)')
    parser.add_argument('--step-bag', help='bag of a closed-loop step (sysid_vehicle_step): '
                        'Figure 9')
    parser.add_argument('--png', metavar='PREFIX',
                        help='write PREFIX_bode.png (Fig. 8) and PREFIX_step.png (Fig. 9)')
    parser.add_argument('--band', nargs=2, type=float, metavar=('F0', 'F1'),
                        help='frequency band [Hz] (default: the chirp f0-f1 in the bag)')
    parser.add_argument('--coherence', type=float, default=vf.COHERENCE_MIN,
                        help=f'coherence threshold of a band (default {vf.COHERENCE_MIN})')
    parser.add_argument('--lag-hz', type=float,
                        help=f'actuator lag [Hz] of the paper fit (default {vf.PAPER_LAG_HZ})')
    parser.add_argument('--delay', type=float,
                        help="actuator dead time [s] of the paper fit (default: the bag's rig, "
                             'plus half a sample for the hold)')


# ------------------------------------------------------------------ bag reading
def bag_parameters(bag) -> dict:
    """``{node name: flat parameters}`` from the bag's experiment metadata ({} if none)."""
    from irs_bag.reader import BagReader
    from irs_bag import BagError

    try:
        with BagReader(bag) as reader:
            records = reader.metadata_records()
    except BagError as exc:
        raise InputError(str(exc)) from None
    for _name, md in records:
        if 'node_parameters' in md:
            try:
                return json.loads(md['node_parameters'])
            except ValueError:
                raise InputError(f'{bag}: unreadable node_parameters metadata') from None
    return {}


def load_run(bag) -> dict:
    """Series by stamp (:func:`irs_bag.run_series.lateral_run`) on the samples where
    reference, steer command and measurement all exist; plus ``params`` (the metadata).
    """
    from irs_bag import BagError
    from irs_bag.run_series import lateral_run

    if not Path(bag).exists():
        raise InputError(f'{bag}: no such bag')
    try:
        run = lateral_run(bag)
    except BagError as exc:
        raise InputError(str(exc)) from None
    for key in ('reference', 'steer_cmd', 'y_measured'):
        if key not in run:
            raise InputError(f'{bag}: the bag has no {key} series (record /lateral/reference, '
                             '/steering/command, /lateral_position)')
    ok = np.isfinite(run['reference']) & np.isfinite(run['steer_cmd']) & \
        np.isfinite(run['y_measured'])
    if ok.sum() < 64:
        raise InputError(f'{bag}: only {int(ok.sum())} samples with reference, steer command '
                         'and measurement')
    out = {k: v[ok] for k, v in run.items()}
    out['params'] = bag_parameters(bag)
    return out


def _rate(t) -> float:
    dt = np.diff(t)
    fs = 1.0 / float(np.median(dt))
    if not np.allclose(dt, dt[0], rtol=1e-6, atol=1e-9):
        raise InputError('the samples are not equally spaced (a lock-step run is)')
    return fs


# ------------------------------------------------------------------ identification
def identify(run: dict, band=None, coherence_min: float = vf.COHERENCE_MIN, lag_hz=None,
             delay=None) -> dict:
    """Both identifications; a dict of the pieces.

    1. **the paper's**: ``S_ry/S_ru`` from the steer *command*, the actuator "simply modeled as a
       4.6 Hz first order lag" plus the transmitter delay configured in the rig (read from the
       bag's metadata) and half a sample (the command is held over its step), the Eq. 6 structure
       fitted;
    2. **from the achieved steer** (``S_ry/S_r delta``, the servo's own angle): the vehicle alone,
       with no actuator assumption -- what is left when the actuator is not the paper's lag (the
       rig's amplitude-dependent servo is slew limited at these amplitudes).
    """
    params = run.get('params', {})
    rig = params.get('vehicle_sim', {})
    ref = params.get('reference_generator', {})
    configured = vf.configured_vehicle(rig) if rig else None
    if band is None:
        if ref.get('signal.type') != 'chirp':
            raise InputError('the bag says no chirp band (reference_generator signal.type is '
                             f"{ref.get('signal.type')!r}): give --band F0 F1")
        band = (float(ref['signal.f0']), float(ref['signal.f1']))
    a = 2 * math.pi * (lag_hz if lag_hz is not None else vf.PAPER_LAG_HZ)
    fs = _rate(run['time'])
    d = delay if delay is not None else \
        (configured.delay if configured else 0.0) + 0.5 / fs     # the hold: half a sample
    r, u, y = run['reference'], run['steer_cmd'], run['y_measured']
    fr = vf.closed_loop_frequency_response(r, u, y, fs, band, coherence_min=coherence_min)
    fit = vf.fit_open_loop(fr, a, d)
    out = {'band': band, 'fr': fr, 'fit': fit, 'configured': configured, 'fs': fs}
    if 'steer_achieved' in run and np.all(np.isfinite(run['steer_achieved'])):
        fr_a = vf.closed_loop_frequency_response(r, run['steer_achieved'], y, fs, band,
                                                 coherence_min=coherence_min)
        out['fr_achieved'] = fr_a
        out['fit_achieved'] = vf.fit_open_loop(fr_a, math.inf, 0.0)
    return out


def _configured_as(model: vf.PlantModel | None, actuator_pole, delay):
    if model is None:
        return None
    return vf.PlantModel(model.gain, model.num, model.den, actuator_pole, delay)


def reports(ident: dict) -> list:
    """``[(title, estimates)]`` for the identifications in ``ident``."""
    fit, conf = ident['fit'], ident['configured']
    m = fit.model
    out = [(f'Open loop from the steer command, actuator = {m.actuator_pole / (2 * math.pi):.2f}'
            f" Hz lag + {1000 * m.delay:.1f} ms (the paper's method; {fit.points} points, "
            f'{ident["band"][0]:g}-{ident["band"][1]:g} Hz, RMS log error '
            f'{fit.rms_log_error:.3f})',
            vf.vehicle_estimates(fit, _configured_as(conf, m.actuator_pole, m.delay),
                                 w=ident['fr'].w))]
    if 'fit_achieved' in ident:
        fa = ident['fit_achieved']
        out.append((f'Vehicle from the achieved steer (no actuator model; {fa.points} points, '
                    f'RMS log error {fa.rms_log_error:.3f})',
                    vf.vehicle_estimates(fa, _configured_as(conf, math.inf, 0.0),
                                         w=ident['fr_achieved'].w)))
    return out


# ------------------------------------------------------------------ step (Figure 9)
def controller_polynomials(params: dict):
    """``(R, S, T)`` of the bag's lateral controller (MRC design or PI), or None."""
    from irs_control.controller_factory import CONTROLLER_DEFAULTS, make_controller

    ctl = params.get('lateral_controller')
    if not ctl:
        return None
    cfg = {k: v for k, v in ctl.items() if k in CONTROLLER_DEFAULTS}
    if cfg.get('mode', 'mrc') == 'pi':
        return vf.pi_polynomials(float(cfg.get('kp', 5.0)), float(cfg.get('ki', 3.0)))
    d = make_controller(cfg).design
    return d.R, d.S, d.T


def step_comparison(step_run: dict, model: vf.PlantModel, configured=None) -> dict:
    """Measured step against the closed loop of ``model`` (and ``configured``) with the bag's
    controller: ``t, r, y, y_model, y_configured`` and RMS errors [m].
    """
    rst = controller_polynomials(step_run.get('params', {}))
    if rst is None:
        raise InputError('the step bag does not say which controller ran (no metadata)')
    t, r, y = step_run['time'], step_run['reference'], step_run['y_measured']
    out = {'t': t, 'r': r, 'y': y, 'y_model': vf.closed_loop_response(model, *rst, t, r)}
    out['rms_model'] = float(np.sqrt(np.mean((out['y_model'] - y) ** 2)))
    if configured is not None:
        out['y_configured'] = vf.closed_loop_response(configured, *rst, t, r)
        out['rms_configured'] = float(np.sqrt(np.mean((out['y_configured'] - y) ** 2)))
    return out


# ------------------------------------------------------------------ figures
def fmt_roots(roots) -> str:
    """``'-2.4, -4.8'`` or ``'-9.46+-3.31j'`` (a complex pair once)."""
    out = []
    for r in roots:
        if abs(r.imag) < 1e-9:
            out.append(f'{r.real:.3g}')
        elif r.imag > 0:
            out.append(f'{r.real:.3g}+-{r.imag:.3g}j')
    return ', '.join(out)


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_bode(ident: dict, path) -> Path:
    """Figure 8: the open loop u -> y (data dots, paper-structure fit dashed, configured)."""
    plt = _plt()
    fr, fit, conf = ident['fr'], ident['fit'], ident['configured']
    w = fr.w
    wf = np.geomspace(w.min() / 1.5, w.max() * 1.5, 400)
    fig, (ax_m, ax_p) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)

    m = fit.model
    model_phase = np.unwrap(np.angle(m.response(wf)))
    if conf is not None:
        c = _configured_as(conf, m.actuator_pole, m.delay).response(wf)
        cp = np.unwrap(np.angle(c))
        cp += 2 * np.pi * np.round((model_phase[0] - cp[0]) / (2 * np.pi))
        ax_m.semilogx(wf, 20 * np.log10(np.abs(c)), color='0.55', lw=1.5,
                      label='configured vehicle (rig) + 4.6 Hz lag + delay')
        ax_p.semilogx(wf, np.degrees(cp), color='0.55', lw=1.5)
    data_phase = np.unwrap(np.angle(fr.P))
    # put the data on the model's branch (the phase of a double integrator starts near -180)
    k = np.round((np.interp(w, wf, model_phase) - data_phase) / (2 * np.pi))
    ax_m.semilogx(w, 20 * np.log10(np.abs(fr.P)), 'o', color='C0', ms=5,
                  label='closed-loop data S_ry/S_ru')
    ax_p.semilogx(w, np.degrees(data_phase + 2 * np.pi * k), 'o', color='C0', ms=5)
    ax_m.semilogx(wf, 20 * np.log10(np.abs(m.response(wf))), '--', color='C3', lw=2,
                  label='model fit (Eq. 6 structure)')
    ax_p.semilogx(wf, np.degrees(model_phase), '--', color='C3', lw=2)
    ax_m.set_ylabel('|y / u|  [dB re 1 m/rad]')
    ax_p.set_ylabel('phase  [deg]')
    ax_p.set_xlabel('frequency  [rad/s]')
    z, p = fmt_roots(m.zeros), fmt_roots(m.poles)
    ax_m.set_title(f'Figure 8: open loop steer command -> lateral position, from closed-loop '
                   f'data\nfit: K = {m.gain:.3g} m/(s^2 rad), zeros [{z}], poles [0, 0, {p}, '
                   f'-{m.actuator_pole:.3g}], delay {1000 * m.delay:.1f} ms', fontsize=10)
    for ax in (ax_m, ax_p):
        ax.grid(True, which='both', alpha=0.3)
    ax_m.legend(loc='lower left')
    return save_figure(fig, path, dpi=100)


def plot_step(cmp: dict, path) -> Path:
    """Figure 9: the measured (quantised) closed-loop step against the models'."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4.8))
    t = cmp['t'] - cmp['t'][0]
    ax.plot(t, 1000 * cmp['r'], ':', color='0.3', label='reference')
    ax.step(t, 1000 * cmp['y'], where='post', color='C0', lw=1,
            label='measured y (arm sensor, quantised)')
    ax.plot(t, 1000 * cmp['y_model'], '--', color='C3', lw=2,
            label=f'identified model (RMS error {1000 * cmp["rms_model"]:.2f} mm)')
    if 'y_configured' in cmp:
        ax.plot(t, 1000 * cmp['y_configured'], color='0.55', lw=1.2,
                label=f'configured vehicle + 4.6 Hz lag (RMS error '
                      f'{1000 * cmp["rms_configured"]:.2f} mm)')
    ax.set_xlabel('time  [s]')
    ax.set_ylabel('lateral position y_s  [mm]')
    ax.set_title('Figure 9: vehicle step response under the lateral controller '
                 '(experimental data quantised)')
    ax.grid(True, alpha=0.3)
    ax.legend(loc='lower right')
    return save_figure(fig, path, dpi=100)


# ------------------------------------------------------------------ command
def run(args) -> int:
    if not (0 < args.coherence < 1):
        raise InputError(f'--coherence must lie in (0, 1), got {args.coherence}')
    if args.band is not None and not (0 < args.band[0] < args.band[1]):
        raise InputError(f'--band must be 0 < F0 < F1 [Hz], got {args.band}')
    for name in ('lag_hz', 'delay'):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and (v > 0 if name == 'lag_hz' else v >= 0)):
            raise InputError(f'--{name.replace("_", "-")} must be a '
                             f'{"positive" if name == "lag_hz" else "non-negative"} number, '
                             f'got {v}')
    run_ = load_run(args.bag)
    step_run = load_run(args.step_bag) if args.step_bag else None
    ident = identify(run_, args.band, args.coherence, args.lag_hz, args.delay)
    for title, est in reports(ident):
        print(format_report(title, est))
        print()
    if step_run is not None:
        m = ident['fit'].model
        cmp = step_comparison(step_run, m, _configured_as(ident['configured'], m.actuator_pole,
                                                          m.delay))
        print(format_report('Step response (Figure 9): RMS error of the closed-loop models '
                            'against the measured y', [
                                Estimate('identified model', cmp['rms_model'], 'm'),
                                Estimate('configured plant', cmp.get('rms_configured',
                                                                     math.nan), 'm')]))
    if args.png:
        print(f'wrote {plot_bode(ident, f"{args.png}_bode.png")}')
        if step_run is not None:
            print(f'wrote {plot_step(cmp, f"{args.png}_step.png")}')
    return 0


def _numbers(ident: dict, prefix: str = '') -> dict:
    out = {}
    for title, est in reports(ident):
        tag = 'command' if title.startswith('Open loop') else 'achieved'
        for e in est:
            key = (e.name.replace(' ', '_').replace(',', '').replace("''", '2').replace(':', '')
                   .replace('(', '').replace(')', '').replace('/', '_').replace('|', ''))
            out[f'{prefix}{tag}_{key}'] = e.value
            if math.isfinite(e.ci95):
                out[f'{prefix}{tag}_{key}_ci95'] = e.ci95
            if math.isfinite(e.configured):
                out[f'{prefix}{tag}_{key}_configured'] = e.configured
    return out


def reproduce_figures(img_dir: Path, runs_dir: Path) -> dict:
    """Run sysid_vehicle_sweep and sysid_vehicle_step through the graph (lock-step), identify,
    write ``figure8_vehicle_bode.png`` and ``figure9_vehicle_step.png``; the key numbers.
    """
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner

    bags = {}
    for name in ('sysid_vehicle_sweep', 'sysid_vehicle_step'):
        res = ExperimentRunner(load_experiment(name).deployed(), runs_dir=runs_dir,
                               progress=False).run()
        if not res.completed or res.bag_dir is None:
            raise RunFailed(f'{name} did not complete: {res.message}')
        bags[name] = res.bag_dir
    ident = identify(load_run(bags['sysid_vehicle_sweep']))
    m = ident['fit'].model
    cmp = step_comparison(load_run(bags['sysid_vehicle_step']), m,
                          _configured_as(ident['configured'], m.actuator_pole, m.delay))
    img_dir = Path(img_dir)
    plot_bode(ident, img_dir / 'figure8_vehicle_bode.png')
    plot_step(cmp, img_dir / 'figure9_vehicle_step.png')
    out = _numbers(ident)
    out.update({'step_rms_error_identified_m': cmp['rms_model'],
                'step_rms_error_configured_m': cmp.get('rms_configured', math.nan),
                'sweep_bag': str(bags['sysid_vehicle_sweep']),
                'step_bag': str(bags['sysid_vehicle_step'])})
    return out
