"""``sweep similitude``: the 1:10 car against the full-size presets by dimensionless groups.

    ./irs run irs_bringup sweep similitude [--scale irs_2wd] [--speed 1.2] [--out DIR]

Prints the Pi-groups (:mod:`irs_models.similitude`) of the scale car at ``--speed`` and of every
full-size preset at its own speed, then sweeps the scale car's speed (0.1-10 m/s, 400 log-spaced
points, refined by ``scipy.optimize.minimize_scalar``) for the speed whose groups best match each
preset, and writes into ``DIR`` (default ``runs/similitude``):

* ``sweep_similitude_speed.png`` -- mismatch (RMS log ratio of Pi1, Pi3, Pi4, Pi5) against the
  scale car's speed, one curve per preset, best speed and sqrt(length) (Froude) speed marked;
* ``sweep_similitude_step.png`` -- unit steer-step responses on scaled axes (``tau = t V/L``,
  yaw rate ``r L/V``, sideslip ``v_y/V``): each preset at its speed, the scale car at its
  best-matching speed for that preset and at ``--speed``.
"""
from __future__ import annotations

from pathlib import Path

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
    from irs_models.similitude import dimensionless_step
    out.mkdir(parents=True, exist_ok=True)
    scale, _ = tab['scale']
    colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
    fig, ax = plt.subplots(figsize=(7.5, 4.5), constrained_layout=True)
    for c, (name, (p, _g, m)) in zip(colors, tab['full'].items()):
        ax.semilogx(m.speeds, m.mismatches, color=c, label=f'{name} at {p.speed:g} m/s')
        ax.plot(m.speed, m.mismatch, 'o', color=c)
        ax.axvline(m.froude_speed, color=c, ls=':', lw=1)
    ax.axvline(speed, color='k', ls='--', lw=1, label=f'{scale.name} at {speed:g} m/s (paper)')
    ax.set_xlabel(f'{scale.name} speed V [m/s]')
    ax.set_ylabel('mismatch: RMS log(Pi_1:10 / Pi_full) over Pi1, Pi3, Pi4, Pi5 [-]')
    ax.set_title(f'Similitude: {scale.name} speed sweep against the full-size presets\n'
                 '(dots: best-matching speed; dotted: V_full sqrt(L_1:10 / L_full))', fontsize=10)
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


def run(args) -> int:
    tab = similitude_table(args.scale, args.speed)
    print(table_text(tab, args.speed))
    for p in write_plots(tab, args.speed, args.out):
        print(f'[similitude] wrote {p}')
    return 0
