"""``sysid actuator``: the steering servo from recorded bags (paper Sec. 3.3, Fig. 6 and 7).

    ./irs run irs_sysid sysid actuator <bag> [<bag> ...] [--png PREFIX]

Each bag is a run of ``sysid_actuator_sweep`` (an ``excitation`` chirp on the steer command) or
``sysid_actuator_steps`` (an ``excitation`` schedule of steps), told apart by the excitation's
``signal.type`` in the bag's experiment metadata.  Only ``/steering/state`` is analysed (the
command as the rig received it and the achieved front steer angle, by stamp).

* sweeps: H1 frequency response per amplitude, first-order + dead-time fit with the dead time
  shared (:mod:`.actuator_fit`) -> the pole per amplitude and the dead time;
* steps: per step the dead time, the 20-80 % slew rate (rate limited: a straight line) and the
  10-90 % rise time; the smallest step's time-domain first-order fit -> the loop bandwidth.

Configured values come from the rig's parameters recorded in the bag (``actuator_front.*``).
The fitted pole of a non-linear servo has no single configured value: the reference is the same
fit on the configured actuator core (:class:`irs_vehicle_sim.actuator.SteeringActuator`) driven
by the recorded command, i.e. what the rig's model predicts at that amplitude.  The dead time is
compared with ``delay``, the slew rate of the largest steps with ``rate_limit / gear_ratio`` (the
wheel-side limit at the centre; the linkage's local gain lowers it by a few % at large angles),
the loop bandwidth with ``lag_hz``.  ``--png PREFIX`` writes ``PREFIX`` +
``figure6_actuator_bode.png`` / ``figure7_actuator_steps.png`` (a directory prefix ends in /).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from irs_common.cli import InputError

from . import actuator_fit as af
from .common import run_experiment
from .report import Estimate, format_report

#: Tolerances of the identification (irs_system_tests/test/test_sysid_actuator.py holds them).
POLE_REL_TOL = 0.05        # fitted pole vs the configured core's fit at the same amplitude
DELAY_ABS_TOL = 0.003      # [s] dead time vs the configured transport delay (paper: +-0.005 s)
RATE_REL_TOL = 0.10        # slew rate of the large steps vs rate_limit / gear_ratio
LAG_REL_TOL = 0.15         # time-domain loop bandwidth of the smallest step vs lag_hz
#: A step is rate limited when its 20-80 % part is this straight (coefficient of determination
#: of a line; an exponential lag gives about 0.97, a slew-limited ramp 0.999).
STRAIGHT = 0.995


@dataclass
class ActuatorRun:
    """One bag: sample times [s], command received and achieved angle [rad], its metadata."""

    path: str
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    signal: dict = field(default_factory=dict)
    rig: dict = field(default_factory=dict)

    @property
    def kind(self) -> str:
        return 'sweep' if self.signal.get('signal.type') == 'chirp' else 'steps'


def load_run(bag) -> ActuatorRun:
    """Read ``/steering/state`` and the experiment metadata of a bag (no rclpy)."""
    from irs_bag.scan import BagError

    try:
        return _load_run(bag)
    except BagError as exc:
        raise InputError(str(exc)) from None


def _load_run(bag) -> ActuatorRun:
    from irs_bag.reader import BagReader

    rows = {}
    params = {}
    with BagReader(bag) as reader:
        if '/steering/state' not in reader.topics:
            raise InputError(f'{bag}: no /steering/state messages (record them to identify)')
        for name, meta in reader.metadata_records():
            if name == 'irs_experiment' and 'node_parameters' in meta:
                params = json.loads(meta['node_parameters'])
        for _, msg in reader.decoded(['/steering/state']):
            s = msg.header.stamp
            rows[int(s.sec) * 1_000_000_000 + int(s.nanosec)] = (msg.front_commanded,
                                                                 msg.front_achieved)
    if len(rows) < 100:
        raise InputError(f'{bag}: only {len(rows)} /steering/state samples')
    stamps = np.array(sorted(rows), dtype=np.int64)
    uy = np.array([rows[s] for s in stamps], dtype=float)
    excitation = next((v for k, v in params.items() if 'signal.type' in v), {})
    rig = next((v for v in params.values() if any(k.startswith('actuator_front.') for k in v)),
               {})
    return ActuatorRun(str(bag), stamps * 1e-9, uy[:, 0], uy[:, 1], excitation, rig)


def configured_params(rig: dict):
    """:class:`ActuatorParams` of the front servo from the recorded rig parameters."""
    from irs_vehicle_sim.actuator import ActuatorParams

    prefix = 'actuator_front.'
    known = set(ActuatorParams.__dataclass_fields__)
    kw = {k[len(prefix):]: v for k, v in rig.items()
          if k.startswith(prefix) and k[len(prefix):] in known}
    p = ActuatorParams(**kw)
    p.validate()
    return p


def simulate_configured(run: ActuatorRun) -> np.ndarray:
    """The configured actuator core driven by the recorded command: its achieved angle [rad].

    The rig publishes ``steering/state`` stamped t_k after its step to t_k: the achieved angle
    at t_k and the last command it received, the one that acted over [t_k-1, t_k).  So sample k
    is the core's output after stepping with sample k's command (equal to the recorded angle
    to round-off when the graph ran the configured actuator).
    """
    from irs_vehicle_sim.actuator import SteeringActuator

    act = SteeringActuator(configured_params(run.rig))
    dt = float(np.median(np.diff(run.t)))
    return np.array([act.step(float(c), dt) for c in run.u])


def sweep_response(run: ActuatorRun, y=None) -> af.FrequencyResponse:
    """H1 response of one sweep (``y`` default: the recorded achieved angle).

    The record from the sweep's start to the bag's end (the rest after the sweep holds the
    response's tail); the band from the sweep's f0 to 0.8 f1 (at most 12 Hz), where the chirp
    has put its energy.
    """
    s = run.signal
    t0 = float(s.get('signal.start_time', 0.0))
    sel = run.t >= t0
    if np.count_nonzero(sel) < 1000:
        raise InputError(f'{run.path}: the sweep has fewer than 1000 samples in the bag')
    f_lo = float(s.get('signal.f0', 0.3))
    f_hi = min(0.8 * float(s.get('signal.f1', 15.0)), 12.0)
    y = run.y if y is None else y
    return af.frequency_response(run.t[sel], run.u[sel], y[sel], f_lo, f_hi,
                                 amplitude=abs(float(s.get('signal.amplitude', math.nan))))


def analyse_steps(run: ActuatorRun, y=None) -> list:
    """Every step of a steps run as :class:`actuator_fit.StepResult`, with the fitted tau."""
    y = run.y if y is None else y
    idx = af.find_steps(run.t, run.u, min_size=1e-4, min_gap=0.05)
    out = []
    for i, k in enumerate(idx):
        k_end = idx[i + 1] if i + 1 < len(idx) else len(run.t)
        out.append(af.analyse_step(run.t, run.u, y, k, k_end))
    return out


def identify(runs) -> dict:
    """Fit all sweeps jointly and analyse all steps; with the configured core's predictions."""
    sweeps = sorted((r for r in runs if r.kind == 'sweep'),
                    key=lambda r: abs(float(r.signal.get('signal.amplitude', 0.0))))
    steps = [r for r in runs if r.kind == 'steps']
    if not sweeps and not steps:
        raise InputError('no sweep or step run among the bags')
    rig = (sweeps or steps)[0].rig
    if not rig:
        raise InputError(f'{(sweeps or steps)[0].path}: no rig parameters in the bag metadata '
                         '(record it with the experiment runner)')
    p = configured_params(rig)
    res = {'params': p, 'sweeps': sweeps, 'steps': steps}
    if sweeps:
        res['responses'] = [sweep_response(r) for r in sweeps]
        res['fit'] = af.fit_first_order_delay(res['responses'])
        res['responses_cfg'] = [sweep_response(r, simulate_configured(r)) for r in sweeps]
        res['fit_cfg'] = af.fit_first_order_delay(res['responses_cfg'])
    if steps:
        run = steps[0]
        res['step_run'] = run
        res['step_results'] = analyse_steps(run)
        small = min(res['step_results'], key=lambda s: abs(s.size))
        k = int(np.searchsorted(run.t, small.t_step))
        k_end = k + int(round(0.5 / float(np.median(np.diff(run.t)))))
        k_end = min(k_end, len(run.t))
        tau, delay, tau_ci, delay_ci = af.fit_step(run.t[k:k_end], run.y[k:k_end], small.t_step,
                                                   float(run.y[k - 1]), float(run.y[k_end - 1]))
        res['small_step'] = (small, tau, delay, tau_ci, delay_ci)
    return res


def estimates(res) -> list:
    """The report rows (:class:`report.Estimate`)."""
    p = res['params']
    rows = []
    if 'fit' in res:
        fit, cfg = res['fit'], res['fit_cfg']
        for r, pole, ci, pc in zip(res['responses'], fit.poles_hz, fit.poles_ci95, cfg.poles_hz):
            rows.append(Estimate(f'pole at {math.degrees(r.amplitude):.3g} deg', float(pole),
                                 'Hz', float(ci), float(pc), rel_tol=POLE_REL_TOL))
        rows.append(Estimate('dead time (sweeps)', fit.delay, 's', fit.delay_ci95,
                             p.delay if p.enable_delay else 0.0, abs_tol=DELAY_ABS_TOL))
    if 'step_results' in res:
        sr = res['step_results']
        small, tau, delay, tau_ci, delay_ci = res['small_step']
        lag = 1.0 / (2.0 * math.pi * tau)
        rows.append(Estimate(f'loop bandwidth ({math.degrees(abs(small.size)):.2g} deg step)',
                             lag, 'Hz', lag * tau_ci / tau, p.lag_hz, rel_tol=LAG_REL_TOL))
        rows.append(Estimate('dead time (smallest step)', delay, 's', delay_ci,
                             p.delay if p.enable_delay else 0.0, abs_tol=DELAY_ABS_TOL))
        limited = [s for s in sr if s.linearity >= STRAIGHT]
        if limited:
            big = max(limited, key=lambda s: abs(s.size))
            rows.append(Estimate(f'rate limit ({math.degrees(abs(big.size)):.3g} deg step)',
                                 big.rate, 'rad/s', math.nan, p.wheel_rate_limit,
                                 rel_tol=RATE_REL_TOL))
    return rows


def _plt():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_bode(res, path: Path) -> None:
    """Figure 6: magnitude and phase per amplitude, data dots, fitted first order dashed."""
    plt = _plt()
    fig, (ax_m, ax_p) = plt.subplots(1, 2, figsize=(12, 4.8))
    fit = res['fit']
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, len(res['responses'])))
    for r, k, pole, c in zip(res['responses'], fit.gains, fit.poles_hz, colors):
        label = f'{math.degrees(r.amplitude):.3g} deg: pole {pole:.2f} Hz'
        ff = np.geomspace(r.f[0], r.f[-1], 200)
        g = af.first_order_delay(ff, k, pole, fit.delay)
        ax_m.semilogx(r.f, 20 * np.log10(np.abs(r.h)), 'o', ms=3, color=c, label=label)
        ax_m.semilogx(ff, 20 * np.log10(np.abs(g)), '--', color=c, lw=1.2)
        ax_p.semilogx(r.f, np.degrees(np.unwrap(np.angle(r.h))), 'o', ms=3, color=c)
        ax_p.semilogx(ff, np.degrees(np.unwrap(np.angle(g))), '--', color=c, lw=1.2)
    ax_m.set_ylabel('magnitude, achieved / commanded steer [dB]')
    ax_p.set_ylabel('phase [deg]')
    for ax in (ax_m, ax_p):
        ax.set_xlabel('frequency [Hz]')
        ax.grid(True, which='both', alpha=0.3)
    ax_m.legend(title='amplitude (dots: data, dashed: first-order fit)', fontsize=8,
                title_fontsize=8, loc='lower left')
    ax_p.set_title(f'shared dead time {1000 * fit.delay:.1f} ms', fontsize=9)
    fig.suptitle('Paper Figure 6: servo frequency response at several amplitudes of the '
                 'steer command (simulated rig)')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_steps(res, path: Path) -> None:
    """Figure 7: each step's command and achieved angle against time since the step."""
    plt = _plt()
    run = res['step_run']
    fig, ax = plt.subplots(figsize=(10, 5.5))
    dt = float(np.median(np.diff(run.t)))
    # the steps away from rest and swings (the returns to 0 mirror them)
    steps = [s for s in res['step_results']
             if run.u[int(np.searchsorted(run.t, s.t_step)) - 1] == 0.0 or abs(s.size) > 0.3]
    colors = plt.cm.plasma(np.linspace(0.0, 0.85, len(steps)))
    for s, c in zip(steps, colors):
        k = int(np.searchsorted(run.t, s.t_step))
        sel = slice(max(0, k - int(0.05 / dt)), min(len(run.t), k + int(0.55 / dt)))
        tt = run.t[sel] - s.t_step
        u0 = run.u[k - 1]
        lim = ' (rate limited)' if s.linearity >= STRAIGHT else ''
        ax.plot(tt, np.degrees(run.u[sel] - u0), ':', color=c, lw=1.0)
        ax.plot(tt, np.degrees(run.y[sel] - run.y[k - 1]), '-', color=c, lw=1.6,
                label=f'{math.degrees(u0):+.3g} -> {math.degrees(run.u[k]):+.3g} deg{lim}')
    ax.set_xlabel('time since the step of the command [s]')
    ax.set_ylabel('steer angle change [deg]')
    ax.grid(True, alpha=0.3)
    ax.legend(title='dotted: command, solid: achieved', fontsize=8, title_fontsize=8)
    ax.set_title('Paper Figure 7: step responses of the steering actuator (simulated rig)')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_figures(res, prefix: str) -> list:
    """Write the figures the runs allow; the paths written."""
    out = []
    if 'fit' in res:
        out.append(Path(f'{prefix}figure6_actuator_bode.png'))
        out[-1].parent.mkdir(parents=True, exist_ok=True)
        plot_bode(res, out[-1])
    if 'step_results' in res:
        out.append(Path(f'{prefix}figure7_actuator_steps.png'))
        out[-1].parent.mkdir(parents=True, exist_ok=True)
        plot_steps(res, out[-1])
    return out


def add_arguments(parser) -> None:
    parser.add_argument('bags', nargs='+', help='bags of sysid_actuator_sweep / _steps runs')
    parser.add_argument('--png', metavar='PREFIX',
                        help='write PREFIX + figure6_actuator_bode.png / figure7_actuator_steps'
                             '.png (a directory prefix ends in /)')


def run(args) -> int:
    res = identify([load_run(b) for b in args.bags])
    print(format_report('steering actuator (front servo), identified from '
                        f'{len(args.bags)} bag(s)', estimates(res)))
    if 'step_results' in res:
        print('steps: size [deg], dead time [ms], 20-80 % slope [rad/s], ramp R^2, '
              '10-90 % rise [ms]')
        for s in res['step_results']:
            print(f'  {math.degrees(s.size):+7.2f} {1000 * s.dead_time:7.1f} {s.rate:8.3f} '
                  f'{s.linearity:7.4f} {1000 * s.rise_time:7.1f}')
    if args.png:
        for path in write_figures(res, args.png):
            print(f'wrote {path}')
    return 0


#: Sweep amplitudes [deg] of the paper-figure run (the paper's are not legible; 1-15 deg spans
#: the steer range up to the 15 deg limit).
FIGURE_AMPLITUDES_DEG = (1.0, 2.0, 4.0, 8.0, 15.0)


def experiment_copy(name: str, out_dir: Path, tag: str, excitation: dict,
                    duration: float | None = None) -> Path:
    """A copy of the installed experiment ``name`` named ``<name>_<tag>``, with the excitation
    parameters ``excitation`` (and ``duration`` [s]) changed, written to ``out_dir``.
    """
    import yaml

    from irs_bringup.experiment import find_experiment

    doc = yaml.safe_load(find_experiment(name).read_text())
    doc['name'] = f'{name}_{tag}'
    doc['nodes']['excitation']['params'].update(excitation)
    if duration is not None:
        doc['duration'] = float(duration)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f'{doc["name"]}.yaml'
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def sweep_experiment(amplitude_deg: float, out_dir: Path, sweep_time: float | None = None,
                     f1: float | None = None) -> Path:
    """``sysid_actuator_sweep`` at another amplitude [deg] (and sweep), written to out_dir."""
    sig = {'signal.amplitude': math.radians(amplitude_deg)}
    duration = None
    if sweep_time is not None:
        sig['signal.sweep_time'] = float(sweep_time)
        duration = 1.0 + float(sweep_time)   # 0.5 s at rest, the sweep, 0.5 s of tail
        sig['signal.start_time'] = 0.5
    if f1 is not None:
        sig['signal.f1'] = float(f1)
    tag = f'{amplitude_deg:g}'.replace('.', 'p') + 'deg'
    return experiment_copy('sysid_actuator_sweep', out_dir, tag, sig, duration)


def reproduce_figures(img_dir: Path, runs_dir: Path) -> dict:
    """Run the sweeps (1, 2, 4, 8, 15 deg) and the steps through the graph, identify, write
    ``figure6_actuator_bode.png`` and ``figure7_actuator_steps.png``; the key numbers.
    """
    runs_dir = Path(runs_dir)
    bags = [run_experiment(sweep_experiment(a, runs_dir / 'experiments'), runs_dir)
            for a in FIGURE_AMPLITUDES_DEG]
    bags.append(run_experiment('sysid_actuator_steps', runs_dir))
    res = identify([load_run(b) for b in bags])
    write_figures(res, f'{Path(img_dir)}/')
    out = {}
    for e in estimates(res):
        key = e.name.replace(' ', '_').replace('(', '').replace(')', '').replace('.', 'p')
        out[f'{key}_{e.unit.replace("/", "_per_")}'] = e.value
        out[f'{key}_configured'] = e.configured
    out['bags'] = ' '.join(str(b) for b in bags)
    return out
