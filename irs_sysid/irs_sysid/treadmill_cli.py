"""``sysid treadmill <bag>``: the belt's Eq. 2 and Eq. 1 identified from a bag; paper Figure 5.

    ./irs run irs_bringup experiment run sysid_treadmill
    ./irs run irs_sysid sysid treadmill runs/sysid_treadmill-<time>/bag --png fig5.png

Reads the measured belt speed (``/belt/speed``: the encoder estimate, quantised, as the paper's
data) and the drive command (``/treadmill/drive``) by stamp, fits (:mod:`.treadmill_fit`) the
drive's pole ``a``, gain ``b`` and delay ``T_d`` from the step-ups and ``B/J``, ``F/B`` from the
coast-downs, and prints them against the values configured in the rig. The configured values
come from the bag's experiment metadata (the rig's resolved parameters, recorded by the
experiment runner); a bag without it is compared with the installed ``rig.yaml`` (the report
says which). The configured delay is the drive's ``belt.delay`` plus the encoder estimate's lag
``(window_samples/2 + delay_samples) dt``: the delay the measured speed shows.

``F/B`` is reported in m/s (belt-surface speed), the unit this identification gives from
belt-speed data; see ``docs/treadmill.md`` for the paper's "sec^-1" and the readings.

Figure 5 (``--png``): dots = measured belt speed, lines = the identified model driven by the
recorded command; left the voltage steps (1-4 V up, 0.5 V down, steady state) aligned at their
step-up, right the coast-downs aligned at the drive cut, one colour per voltage.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from irs_common.cli import InputError

from .common import run_experiment, save_figure
from .report import Estimate, format_report
from .treadmill_fit import fit_coast, fit_drive, segments, simulate_belt

#: Relative tolerances the identification is held to (see :mod:`.treadmill_fit`).
TOLERANCES = {'pole': 0.03, 'gain': 0.03, 'delay': 0.10, 'b_over_j': 0.05, 'f_over_b': 0.10}

_BELT_KEYS = ('gain', 'pole', 'b_over_j', 'f_over_b', 'v_top', 'u_max', 'delay',
              'counts_per_rev', 'roller_radius', 'gear_ratio', 'window_samples', 'delay_samples')


def installed_rig_params() -> dict:
    """The flat ``vehicle_sim`` parameters of the installed ``rig.yaml``."""
    import yaml
    from ament_index_python.packages import get_package_share_directory

    from irs_common.params import flatten
    path = Path(get_package_share_directory('irs_vehicle_sim')) / 'config' / 'rig.yaml'
    return flatten(yaml.safe_load(path.read_text())['vehicle_sim']['ros__parameters'])


def load_run(bag) -> dict:
    """``time`` [s], ``speed`` [m/s], ``voltage`` [V] on the common stamps, and ``rig`` params.

    ``rig_source`` says where the rig parameters came from ('bag' or 'installed rig.yaml').

    Raises
    ------
    ValueError
        No such bag, not a bag, or no belt-speed / drive messages in it.
    """
    from irs_bag.reader import BagReader
    from irs_bag.scan import BagError

    if not Path(bag).exists():
        raise InputError(f'{bag}: no such bag')
    speed, volts, rig = {}, {}, None
    try:
        with BagReader(bag) as reader:
            missing = [t for t in ('/belt/speed', '/treadmill/drive') if t not in reader.topics]
            if missing:
                raise InputError(f'{bag}: no {" and no ".join(missing)} messages (record them to '
                                 'identify the belt)')
            for name, meta in reader.metadata_records():
                if name == 'irs_experiment' and 'node_parameters' in meta:
                    params = json.loads(meta['node_parameters'])
                    rig = next((v for v in params.values()
                                if any(k.startswith('belt.') for k in v)), None)
            for m, msg in reader.decoded(['/belt/speed', '/treadmill/drive']):
                s = msg.header.stamp
                ns = int(s.sec) * 1_000_000_000 + int(s.nanosec)
                if m.topic == '/belt/speed':
                    speed[ns] = float(msg.speed)
                else:
                    volts[ns] = float(msg.voltage)
    except BagError as exc:
        raise InputError(f'{bag}: not a readable bag ({exc})') from None
    stamps = np.array(sorted(set(speed) & set(volts)), dtype=np.int64)
    if stamps.size < 100:
        raise InputError(f'{bag}: only {stamps.size} stamps with both a belt speed and a drive '
                         'command')
    source = 'bag'
    if rig is None:
        rig, source = installed_rig_params(), 'installed rig.yaml'
    return {'time': stamps * 1e-9, 'speed': np.array([speed[s] for s in stamps]),
            'voltage': np.array([volts[s] for s in stamps]), 'rig': rig, 'rig_source': source}


def belt_params_of(rig: dict):
    """The rig's :class:`~irs_vehicle_sim.belt.BeltParams` from its flat parameters."""
    from irs_vehicle_sim.belt import BeltParams
    default = installed_rig_params()
    values = {}
    for k in _BELT_KEYS:
        v = rig.get(f'belt.{k}', default.get(f'belt.{k}'))
        if v is not None:
            values[k] = int(v) if k in ('counts_per_rev', 'window_samples',
                                        'delay_samples') else float(v)
    return BeltParams(**values)


def measured_delay(params, dt: float) -> float:
    """Delay the measured speed shows [s]: drive delay + encoder lag (window/2 + delay) dt."""
    return params.delay + (params.window_samples / 2 + params.delay_samples) * dt


def identify(run: dict) -> dict:
    """The fits and the configured belt of one run (see the module docstring)."""
    t, v, u = run['time'], run['speed'], run['voltage']
    dt = float(run['rig'].get('dt', np.median(np.diff(t))))
    return {'drive': fit_drive(t, v, u), 'coast': fit_coast(t, v, u),
            'configured': belt_params_of(run['rig']), 'dt': dt, 'run': run}


def estimates(res: dict) -> list[Estimate]:
    """The report lines: identified, 95 % CI, configured, tolerance."""
    d, c, p = res['drive'], res['coast'], res['configured']
    tol = TOLERANCES
    return [
        Estimate('pole a (Eq. 2)', d.a, '1/s', d.a_ci, p.pole, tol['pole']),
        Estimate('gain b (Eq. 2)', d.b, 'm/s^2/V', d.b_ci, p.gain, tol['gain']),
        Estimate('delay T_d (drive + encoder)', d.delay, 's', d.delay_ci,
                 measured_delay(p, res['dt']), tol['delay']),
        Estimate('B/J (Eq. 1)', c.b_over_j, '1/s', c.b_over_j_ci, p.b_over_j, tol['b_over_j']),
        Estimate('F/B (Eq. 1)', c.f_over_b, 'm/s', c.f_over_b_ci, p.f_over_b, tol['f_over_b']),
    ]


def identified_belt(res: dict):
    """BeltParams with the identified values (delay = the fitted one, no encoder lag added)."""
    from dataclasses import replace
    d, c, p = res['drive'], res['coast'], res['configured']
    return replace(p, pole=d.a, gain=d.b, delay=d.delay, b_over_j=c.b_over_j,
                   f_over_b=c.f_over_b, u_max=max(p.u_max, float(np.max(res['run']['voltage']))))


def plot_figure5(res: dict, path) -> Path:
    """Figure 5: dots = measured belt speed, lines = identified model (module docstring)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    run = res['run']
    t, v, u = run['time'], run['speed'], run['voltage']
    model = simulate_belt(u, res['dt'], identified_belt(res), v0=float(v[0]))
    segs = segments(t, u)
    fig, (ax_s, ax_c) = plt.subplots(1, 2, figsize=(12, 5), sharey=True)
    colours = plt.rcParams['axes.prop_cycle'].by_key()['color']
    ups = [s for s in segs if s.kind == 'up' and s.u_before <= 0.0]
    for i, up in enumerate(ups):
        nxt = next((s for s in segs if s.start > up.start and s.kind == 'coast'), None)
        end = nxt.start if nxt is not None else t[-1]
        colour = colours[i % len(colours)]
        m = (t >= up.start - 0.2) & (t < end)
        tt = t[m] - up.start
        ax_s.plot(tt[::40], v[m][::40], '.', ms=4, color=colour)
        ax_s.plot(tt, model[m], '-', lw=1.0, color=colour,
                  label=f'{up.u:g} V step up, then {u[m][-1]:g} V')
        if nxt is not None:
            stop = next((s.start for s in segs if s.start > nxt.start), t[-1])
            mc = (t >= nxt.start - 0.5) & (t < stop)
            tc = t[mc] - nxt.start
            ax_c.plot(tc[::250], v[mc][::250], '.', ms=4, color=colour)
            ax_c.plot(tc, model[mc], '-', lw=1.0, color=colour,
                      label=f'from {nxt.u_before:g} V')
    d, c = res['drive'], res['coast']
    ax_s.set_title(f'voltage steps: V/U = {d.b:.3g}/(s + {d.a:.3g}), delay {1000 * d.delay:.0f} '
                   'ms')
    ax_c.set_title(f'coast-downs (drive cut to 0 V): B/J = {c.b_over_j:.3g} 1/s, '
                   f'F/B = {c.f_over_b:.3g} m/s')
    ax_s.set_xlabel('time from the step up [s]')
    ax_c.set_xlabel('time from the drive cut [s]')
    ax_s.set_ylabel('belt speed [m/s]')
    ax_s.set_ylim(-0.05, 1.3 * max(float(np.max(v)), 0.1))     # room for the legends
    for ax in (ax_s, ax_c):
        ax.grid(True, alpha=0.3)
        ax.legend(loc='upper right', fontsize=8)
    ax_s.plot([], [], 'k.', label='measured (encoder)')
    ax_s.plot([], [], 'k-', label='identified model')
    ax_s.legend(loc='upper right', fontsize=8)
    fig.suptitle('Figure 5: open-loop treadmill responses, 1-4 V steps up, 0.5 V steps down, '
                 'steady state and coast-downs (dots: data, lines: fit)')
    return save_figure(fig, path, dpi=110)


def add_arguments(parser) -> None:
    parser.add_argument('bag', help='bag of a sysid_treadmill run (with /belt/speed and '
                                    '/treadmill/drive)')
    parser.add_argument('--png', metavar='PATH', help='write Figure 5 to PATH')


def check_excitation(run: dict, bag) -> None:
    """:class:`InputError` unless the drive command has a step up from rest and a coast-down
    (a bag of another experiment: the torque car's, the regulation's).
    """
    segs = segments(run['time'], run['voltage'])
    ups = sum(s.kind == 'up' and s.u_before <= 0.0 for s in segs)
    coasts = sum(s.kind == 'coast' for s in segs)
    if not ups or not coasts:
        raise InputError(f'{bag}: {ups} drive steps up from rest and {coasts} coast-downs in '
                         '/treadmill/drive: nothing to identify the belt from (record the '
                         'sysid_treadmill experiment)')


def run(args) -> int:
    data = load_run(args.bag)
    check_excitation(data, args.bag)
    res = identify(data)
    d, c = res['drive'], res['coast']
    print(format_report(f'treadmill belt, identified from {args.bag} ({len(d.steps)} steps up, '
                        f'{len(c.coasts)} coast-downs; configured values from the '
                        f"{res['run']['rig_source']})", estimates(res)))
    print(f'residual RMS: steps {1000 * d.rms:.2f} mm/s, coast-downs {1000 * c.rms:.2f} mm/s; '
          f'DC gain b/a = {d.dc_gain:.4f} m/s/V; 15 mph needs {15 * 0.44704 / d.dc_gain:.2f} V')
    print(f'coast-down from 1.2 m/s to rest: {coast_time(c.b_over_j, c.f_over_b):.1f} s with the '
          'identified B/J and F/B (docs/treadmill.md: 3.4 s if 0.270 were F/J, 10.7 s for F/B = '
          '0.270 m/s, about 28 s for 0.270 rad/s of a 2 in roller)')
    if args.png:
        print(f'wrote {plot_figure5(res, args.png)}')
    return 0


def coast_time(b_over_j: float, f_over_b: float, v0: float = 1.2) -> float:
    """Coast-down time to rest from ``v0`` [m/s]: ``(J/B) ln(1 + v0 B/F)`` [s]."""
    return math.log1p(v0 / f_over_b) / b_over_j


def reproduce_figures(img_dir: Path, runs_dir: Path) -> dict:
    """Run ``sysid_treadmill`` through the graph, identify, write ``figure5_treadmill.png``."""
    bag = run_experiment('sysid_treadmill', Path(runs_dir))
    res = identify(load_run(bag))
    plot_figure5(res, Path(img_dir) / 'figure5_treadmill.png')
    out = {}
    for e, key in zip(estimates(res), ('pole_a', 'gain_b', 'delay', 'b_over_j', 'f_over_b')):
        out[f'treadmill_{key}'] = e.value
        out[f'treadmill_{key}_ci95'] = e.ci95
        out[f'treadmill_{key}_configured'] = e.configured
    p = res['configured']
    out['treadmill_coast_time_from_1.2_m_per_s'] = coast_time(res['coast'].b_over_j,
                                                               res['coast'].f_over_b)
    out['treadmill_top_speed_voltage'] = p.v_top / p.dc_gain
    out['treadmill_bag'] = str(bag)
    return out
