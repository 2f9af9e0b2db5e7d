"""``sweep similitude``: the 1:10 car against the full-size presets by dimensionless groups.

    ./irs run irs_studies sweep similitude [--scale irs_2wd] [--speed 1.2] [--out DIR]

Prints the Pi-groups (:mod:`irs_models.similitude`) of the scale car at ``--speed`` and of every
full-size preset at its own speed, then sweeps the scale car's speed (0.1-10 m/s, 400 log-spaced
points, refined by ``scipy.optimize.minimize_scalar``) for the speed whose groups best match each
preset, and writes into ``DIR`` (default ``runs/similitude``):

* ``sweep_similitude_speed.png`` -- mismatch (RMS log ratio of Pi1, Pi3, Pi4, Pi5) against the
  scale car's speed, one curve per preset, best speed and sqrt(length) (Froude) speed marked;
* ``sweep_similitude_step.png`` -- unit steer-step responses on scaled axes (``tau = t V/L``,
  yaw rate ``r L/V``, sideslip ``v_y/V``): each preset at its speed, the scale car at its
  best-matching speed for that preset and at ``--speed``;
* ``similitude_eq6_eq7_10.png`` -- the paper's Eq. 6 (the identified 1:10 car, with the scale
  preset's wheelbase, at ``--speed``) against Eqs. 7-10 (the full-size presets' published roots
  at their speed) on the dimensionless time scale: poles and zeros as ``s L/V`` and the
  magnitude ``|Y_s / (L delta)|`` against ``omega L/V`` (Eq. 6's gain ``b0 / 29`` = 12.53; the
  full-size gains from their presets). It also prints the speeds at which the scale car has each
  full-size car's time scale (equal L/V, the paper's comparison) and its Froude speed.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from irs_common.cli import InputError

HELP = '1:10 car vs full-size presets: Pi-groups, best-matching speed, scaled responses'


def add_arguments(p) -> None:
    p.add_argument('--scale', default='irs_2wd', help='scale-car preset (default irs_2wd)')
    p.add_argument('--speed', type=float, default=1.2,
                   help="scale-car speed to show [m/s] (default 1.2, the paper's)")
    p.add_argument('--out', type=Path, default=Path('runs') / 'similitude',
                   help='directory of the PNGs (default runs/similitude)')


def similitude_table(scale_name: str = 'irs_2wd', speed: float = 1.2) -> dict:
    """The scale car's groups and, per full-size preset, its groups and best-matching speed.

    ``{'scale': (preset, PiGroups), 'full': {name: (preset, PiGroups, SpeedMatch)}}``.
    """
    from irs_models.presets import get_preset, load_presets
    from irs_models.similitude import best_speed, pi_groups
    try:
        scale = get_preset(scale_name)
    except KeyError as exc:
        raise InputError(f'--scale: {exc.args[0]}') from None
    if not speed > 0:
        raise InputError(f'--speed must be a positive speed in m/s, got {speed}')
    full = {}
    for name, p in load_presets().items():
        if p.kind == 'full_size':
            full[name] = (p, pi_groups(p.params, p.speed, p.ds),
                          best_speed(scale.params, p.params, p.speed))
    return {'scale': (scale, pi_groups(scale.params, speed, scale.ds)), 'full': full}


def table_text(tab: dict, speed: float) -> str:
    scale, g = tab['scale']
    head = ('car', 'V [m/s]', 'L [m]', 'Pi1 lf/L', 'Pi3 CfL/mV2', 'Pi4 CrL/mV2', 'Pi5 Iz/mL2',
            'Pi_us', 'best V_1:10 [m/s]', 'mismatch', 'sqrt(L) V [m/s]')
    rows = [(scale.name, f'{speed:g}', f'{scale.params.wheelbase:.3f}', f'{g.pi1:.3f}',
             f'{g.pi3:.3f}', f'{g.pi4:.3f}', f'{g.pi5:.3f}', f'{g.understeer:+.3f}', '', '', '')]
    for name, (p, g, m) in tab['full'].items():
        rows.append((name, f'{p.speed:g}', f'{p.params.wheelbase:.3f}', f'{g.pi1:.3f}',
                     f'{g.pi3:.3f}', f'{g.pi4:.3f}', f'{g.pi5:.3f}', f'{g.understeer:+.3f}',
                     f'{m.speed:.3f}', f'{m.mismatch:.3f}', f'{m.froude_speed:.2f}'))
    lines = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    lines += ['| ' + ' | '.join(r) + ' |' for r in rows]
    return '\n'.join(lines)


def write_plots(tab: dict, speed: float, out: Path) -> list[Path]:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from irs_models.similitude import dimensionless_step, equal_time_speed
    out.mkdir(parents=True, exist_ok=True)
    scale, _ = tab['scale']
    colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
    fig, ax = plt.subplots(figsize=(7.5, 4.5), constrained_layout=True)
    for c, (name, (p, _g, m)) in zip(colors, tab['full'].items()):
        ax.semilogx(m.speeds, m.mismatches, color=c, label=f'{name} at {p.speed:g} m/s')
        ax.plot(m.speed, m.mismatch, 'o', color=c)
        ax.axvline(m.froude_speed, color=c, ls=':', lw=1)
        ax.axvline(equal_time_speed(p.speed, scale.params.wheelbase, p.params.wheelbase),
                   color=c, ls='-.', lw=1)
    ax.axvline(speed, color='k', ls='--', lw=1, label=f'{scale.name} at {speed:g} m/s (paper)')
    ax.set_xlabel(f'{scale.name} speed V [m/s]')
    ax.set_ylabel('mismatch: RMS log(Pi_1:10 / Pi_full) over Pi1, Pi3, Pi4, Pi5 [-]')
    ax.set_title(f'Similitude: {scale.name} speed sweep against the full-size presets\n'
                 '(dots: best-matching speed; dotted: Froude, V_full sqrt(L_1:10 / L_full);\n'
                 'dash-dot: equal L/V, V_full L_1:10 / L_full)', fontsize=10)
    ax.set_ylim(bottom=0)
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=8)
    p1 = out / 'sweep_similitude_speed.png'
    fig.savefig(p1, dpi=110)
    plt.close(fig)

    n = len(tab['full'])
    fig, axes = plt.subplots(2, n, figsize=(3.4 * n, 5.6), sharex=True, squeeze=False,
                             constrained_layout=True)
    for i, (name, (p, _g, m)) in enumerate(tab['full'].items()):
        for (label, car, v, style) in ((f'{name} {p.speed:g} m/s', p.params, p.speed, '-k'),
                                       (f'{scale.name} {m.speed:.2f} m/s (best)', scale.params,
                                        m.speed, '-C1'),
                                       (f'{scale.name} {speed:g} m/s', scale.params, speed,
                                        '--C0')):
            tau, r, beta = dimensionless_step(car, v)
            axes[0, i].plot(tau, r, style, label=label)
            axes[1, i].plot(tau, beta, style, label=label)
        axes[0, i].set_title(name, fontsize=9)
        axes[1, i].set_xlabel('tau = t V / L [-]')
        axes[0, i].legend(fontsize=7)
        for ax in axes[:, i]:
            ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel('yaw rate r L / V per rad of steer [-]')
    axes[1, 0].set_ylabel('sideslip v_y / V per rad of steer [-]')
    fig.suptitle(f'Unit front-steer step on scaled axes: full-size presets vs {scale.name}',
                 fontsize=10)
    p2 = out / 'sweep_similitude_step.png'
    fig.savefig(p2, dpi=110)
    plt.close(fig)
    return [p1, p2]


def paper_roots(scale_name: str = 'irs_2wd', speed: float = 1.2) -> dict:
    """Eq. 6 and Eqs. 7-10 as ``{name: {'poles', 'zeros', 'gain', 'length', 'speed', 'ds'}}``.

    Eq. 6: the paper's vehicle poles and zeros (irs_models.constants), gain ``b0 / 29``
    [m/(rad s^2)], the scale preset's wheelbase (the paper gives none) and ``speed``; Eqs. 7-10:
    each full-size preset's published (target) roots with its own bicycle model's gain, and
    under ``'sensor'`` the zeros and gain of its bicycle model seen at Eq. 6's sensor point
    (``d_s / L`` = 0.33 / the scale car's wheelbase; the poles do not depend on it).
    """
    from irs_models.bicycle import zpk
    from irs_models.constants import (PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN,
                                      PAPER_VEHICLE_POLES, PAPER_ZEROS, SENSOR_DISTANCE)
    from irs_models.presets import get_preset, load_presets
    scale = get_preset(scale_name)
    out = {'Eq. 6 (IRS 1:10)': {
        'poles': np.array(PAPER_VEHICLE_POLES, complex), 'zeros': np.array(PAPER_ZEROS, complex),
        'gain': PAPER_PLANT_GAIN / PAPER_ACTUATOR_POLE, 'length': scale.params.wheelbase,
        'speed': speed, 'ds': SENSOR_DISTANCE}}
    ratio = SENSOR_DISTANCE / scale.params.wheelbase
    for name, p in load_presets().items():
        if p.kind == 'full_size':
            eq = p.target['source'].split(',')[0].replace('(', '').replace(')', '')
            L = p.params.wheelbase
            z_s, _p_s, k_s = zpk(p.params, p.speed, ratio * L)
            out[f'{eq} ({name})'] = {'poles': p.target_poles, 'zeros': p.target_zeros,
                                     'gain': zpk(p.params, p.speed, p.ds)[2],
                                     'length': L, 'speed': p.speed, 'ds': p.ds,
                                     'sensor': {'zeros': z_s, 'gain': k_s, 'ds': ratio * L}}
    return out


def roots_text(roots: dict, scale_name: str = 'irs_2wd') -> str:
    """Markdown table of the root sets in ``s L/V`` and the scale car's similar speeds."""
    from irs_models.presets import get_preset
    from irs_models.similitude import dimensionless_roots, equal_time_speed, froude_speed
    L_s = get_preset(scale_name).params.wheelbase

    def fmt(r):
        return ', '.join(f'{z.real:.2f}' + (f'{z.imag:+.2f}j' if abs(z.imag) > 1e-9 else '')
                         for z in r if abs(z) > 1e-9)
    head = ('equation', 'V [m/s]', 'L [m]', 'L/V [s]', 'd_s/L', 'poles s L/V', 'zeros s L/V',
            'zeros s L/V at d_s/L of Eq. 6', 'omega_n L/V',
            f'equal-L/V speed of the {L_s:.2f} m car [m/s]', 'Froude speed [m/s]')
    lines = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    for name, e in roots.items():
        p = dimensionless_roots(e['poles'], e['length'], e['speed'])
        z = dimensionless_roots(e['zeros'], e['length'], e['speed'])
        wn = np.sqrt(np.prod(np.abs(p[np.abs(p) > 1e-9])))
        full = e['length'] > 2 * L_s
        lines.append('| ' + ' | '.join([
            name, f'{e["speed"]:g}', f'{e["length"]:.3f}', f'{e["length"] / e["speed"]:.3f}',
            f'{e["ds"] / e["length"]:.2f}', fmt(p), fmt(z),
            fmt(dimensionless_roots(e['sensor']['zeros'], e['length'], e['speed']))
            if 'sensor' in e else fmt(z), f'{wn:.2f}',
            f'{equal_time_speed(e["speed"], L_s, e["length"]):.2f}' if full else '',
            f'{froude_speed(e["speed"], L_s, e["length"]):.2f}' if full else '']) + ' |')
    return '\n'.join(lines)


def write_root_plot(roots: dict, out: Path) -> Path:
    """``similitude_eq6_eq7_10.png`` (module docstring)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from irs_models.similitude import dimensionless_roots
    out.mkdir(parents=True, exist_ok=True)
    fig, (ax_pz, ax_m) = plt.subplots(1, 2, figsize=(13, 5.2), constrained_layout=True)
    w = np.logspace(-1.5, 1.5, 400)                  # omega L / V
    for c, (name, e) in zip(plt.rcParams['axes.prop_cycle'].by_key()['color'], roots.items()):
        p = dimensionless_roots(e['poles'], e['length'], e['speed'])
        z = dimensionless_roots(e['zeros'], e['length'], e['speed'])
        lw = 2.5 if name.startswith('Eq. 6') else 1.4
        p = p[np.abs(p) > 1e-9]
        ax_pz.plot(p.real, p.imag, 'x', color=c, ms=9, mew=lw,
                   label=f'{name}: poles x, zeros o (d_s/L {e["ds"] / e["length"]:.2f})')
        ax_pz.plot(z.real, z.imag, 'o', color=c, ms=8, mfc='none', mew=lw)
        s = 1j * w * e['speed'] / e['length']          # s = j omega at omega L/V = w

        def mag(zeros, gain):
            return np.abs(gain * np.prod([s - q for q in zeros], axis=0) / np.prod(
                [s - q for q in e['poles']], axis=0) / e['length'])
        ax_m.loglog(w, mag(e['zeros'], e['gain']), color=c, lw=lw,
                    label=f'{name}, d_s/L = {e["ds"] / e["length"]:.2f}')
        if 'sensor' in e:
            zs = dimensionless_roots(e['sensor']['zeros'], e['length'], e['speed'])
            ax_pz.plot(zs.real, zs.imag, 'd', color=c, ms=7, mfc='none', mew=1.0)
            ax_m.loglog(w, mag(e['sensor']['zeros'], e['sensor']['gain']), '--', color=c,
                        lw=1.0)
    ax_pz.plot([], [], 'd', color='grey', mfc='none', label="zeros of Eqs. 7-10 at Eq. 6's "
               'sensor point (d_s/L 1.10; their bicycle presets)')
    ax_m.plot([], [], '--', color='grey', label='Eqs. 7-10 at d_s/L 1.10')
    ax_pz.axhline(0.0, color='k', lw=0.5)
    ax_pz.axvline(0.0, color='k', lw=0.5)
    ax_pz.set(xlabel='Re(s L/V) [-]', ylabel='Im(s L/V) [-]',
              title='poles (x) and zeros (o) as s L/V (the double integrator left out)')
    ax_pz.legend(fontsize=7, loc='lower left')
    ax_m.set(xlabel='omega L/V [-]', ylabel='|Y_s / (L delta)| [1/rad]',
             title='dimensionless magnitude of Y_s / delta')
    ax_m.grid(True, which='both', alpha=0.3)
    ax_m.legend(fontsize=7)
    for ax in (ax_pz, ax_m):
        ax.grid(True, alpha=0.3)
    fig.suptitle('Eq. 6 (IRS 1:10 car, 1.2 m/s) against Eqs. 7-10 (full-size cars, 12 m/s) in '
                 'dimensionless form', fontsize=11)
    path = out / 'similitude_eq6_eq7_10.png'
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run(args) -> int:
    tab = similitude_table(args.scale, args.speed)
    print(table_text(tab, args.speed))
    roots = paper_roots(args.scale, args.speed)
    print()
    print(roots_text(roots, args.scale))
    for p in write_plots(tab, args.speed, args.out) + [write_root_plot(roots, args.out)]:
        print(f'[similitude] wrote {p}')
    return 0
