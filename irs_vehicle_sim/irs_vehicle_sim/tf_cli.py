"""Print (and optionally plot) the steer-to-lateral-displacement transfer function of a preset.

Usage::

    python -m irs_vehicle_sim.tf_cli --preset irs_4ws [--speed 1.2] [--ds 0.33] [--axle front]
                                     [--actuator-hz 4.6] [--identified] [--plots DIR]

Prints gain, poles and zeros of ``Y_s(s)/delta(s)`` [m/rad] without and with the first-order
steering-actuator lag ``w_a/(s + w_a)``, ``w_a = 2 pi f_a`` (default 4.6 Hz, paper section 4).
``--identified`` also prints the paper's Eq. (6) plant
(``irs_models.identified.identified_plant``).
``--plots DIR`` writes ``bode.png`` and
``step.png`` (matplotlib, Agg backend).

Exit codes: 0 success, 2 bad arguments (unknown preset, non-positive speed, ...).
Pure Python; no rclpy.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

from irs_models.bicycle import DEFAULT_ACTUATOR_HZ, transfer_function
from irs_models.identified import identified_plant
from irs_models.presets import load_presets

__all__ = ['main', 'build_parser', 'format_roots']


def format_roots(roots) -> str:
    """Human-readable list of roots (rad/s)."""
    out = []
    for r in np.asarray(roots, dtype=complex):
        if abs(r.imag) < 1e-9 * max(1.0, abs(r)):
            out.append(f'{r.real:.4g}')
        else:
            out.append(f'{r.real:.4g}{r.imag:+.4g}j')
    return '[' + ', '.join(out) + ']'


def _describe(num, den):
    num = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), 'f')
    den = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), 'f')
    zeros = np.roots(num) if num.size > 1 else np.array([])
    poles = np.roots(den) if den.size > 1 else np.array([])
    poles = np.where(np.abs(poles) < 1e-9, 0.0, poles)
    k = num[0] / den[0]

    def order(r):
        r = np.asarray(r, complex)
        return r[np.lexsort((r.imag, r.real))][::-1]

    return k, order(zeros), order(poles)


def _print_tf(title, num, den, out):
    k, z, p = _describe(num, den)
    print(title, file=out)
    print(
        f'  high-frequency gain k = {k:.6g}   (G = k prod(s - z) / prod(s - p), m/rad)', file=out
    )
    print(f'  zeros [rad/s] = {format_roots(z)}', file=out)
    print(f'  poles [rad/s] = {format_roots(p)}', file=out)


def _identified(out):
    num, den = identified_plant()
    _print_tf(
        'Identified plant, paper Eq. (6) (irs_models.identified.identified_plant):', num, den, out
    )
    return num, den


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='irs_tf',
        description='Steer-to-lateral-displacement transfer function of a vehicle preset.',
    )
    p.add_argument('--preset', default='irs_4ws', help='preset name (default irs_4ws)')
    p.add_argument('--presets-file', default=None, help='alternative presets YAML')
    p.add_argument(
        '--speed', type=float, default=None, help="forward speed [m/s] (default: preset's)"
    )
    p.add_argument('--ds', type=float, default=None,
                   help="sensor distance ahead of c.g. [m] (default: preset's)")
    p.add_argument('--axle', choices=('front', 'rear'), default='front', help='steer input')
    p.add_argument(
        '--actuator-hz',
        type=float,
        default=DEFAULT_ACTUATOR_HZ,
        help=f'actuator first-order lag corner [Hz] (default {DEFAULT_ACTUATOR_HZ}; <= 0 '
             f'disables)',
    )
    p.add_argument(
        '--identified', action='store_true', help="also print the paper's Eq. (6) identified plant"
    )
    p.add_argument(
        '--plots', metavar='DIR', default=None, help='save bode.png and step.png in DIR'
    )
    return p


def _plots(directory, curves, step_deg=1.0):
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from scipy import signal

    os.makedirs(directory, exist_ok=True)
    w = np.logspace(-1, 3, 600)
    fig, (ax_m, ax_p) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    for label, (num, den) in curves:
        _, h = signal.freqs(num, den, worN=w)
        ax_m.semilogx(w, 20 * np.log10(np.abs(h)), label=label)
        ax_p.semilogx(w, np.degrees(np.unwrap(np.angle(h))), label=label)
    ax_m.set_ylabel('|Y_s/delta| [dB re 1 m/rad]')
    ax_p.set_ylabel('phase [deg]')
    ax_p.set_xlabel('frequency [rad/s]')
    ax_m.grid(True, which='both')
    ax_p.grid(True, which='both')
    ax_m.legend(fontsize=8)
    fig.tight_layout()
    bode = os.path.join(directory, 'bode.png')
    fig.savefig(bode, dpi=100)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    t = np.linspace(0.0, 2.0, 801)
    for label, (num, den) in curves:
        _, y = signal.step((num, den), T=t)
        ax.plot(t, y * math.radians(step_deg), label=label)
    ax.set_xlabel('time [s]')
    ax.set_ylabel(f'y_s [m] for a {step_deg:g} deg steer step (open loop)')
    ax.grid(True)
    ax.legend(fontsize=8)
    fig.tight_layout()
    step = os.path.join(directory, 'step.png')
    fig.savefig(step, dpi=100)
    plt.close(fig)
    return bode, step


def main(argv=None, out=None, err=None) -> int:
    """CLI entry point. Returns the exit code (0 ok, 2 bad arguments)."""
    out = out or sys.stdout
    err = err or sys.stderr
    args = build_parser().parse_args(argv)
    try:
        presets = load_presets(args.presets_file)
    except (OSError, ValueError) as exc:
        print(f'error: cannot load presets: {exc}', file=err)
        return 2
    if args.preset not in presets:
        print(
            f'error: unknown preset {args.preset!r}. Available presets: '
            f'{", ".join(sorted(presets))}',
            file=err,
        )
        return 2
    pre = presets[args.preset]
    speed = pre.speed if args.speed is None else args.speed
    ds = pre.ds if args.ds is None else args.ds
    wa = 2.0 * math.pi * args.actuator_hz if args.actuator_hz and args.actuator_hz > 0 else None
    try:
        num0, den0 = transfer_function(pre.params, speed, ds, args.axle, None, as_control=False)
        curves = [(f'{pre.name} vehicle only', (num0, den0))]
        if wa is not None:
            num1, den1 = transfer_function(pre.params, speed, ds, args.axle, wa, as_control=False)
    except ValueError as exc:
        print(f'error: {exc}', file=err)
        return 2

    p = pre.params
    print(f'preset {pre.name}: {pre.description}', file=out)
    print(
        f'  m = {p.mass:.6g} kg, I_z = {p.yaw_inertia:.6g} kg m^2, l_f = {p.lf:.6g} m, l_r = '
        f'{p.lr:.6g} m, '
        f'C_f = {p.c_f:.6g} N/rad, C_r = {p.c_r:.6g} N/rad, rear steer available: {p.rear_steer}',
        file=out,
    )
    print(f'  V = {speed:.6g} m/s, d_s = {ds:.6g} m, input: {args.axle} steer', file=out)
    if args.axle == 'rear' and not p.rear_steer:
        print(f'note: preset {pre.name} has no rear-steer actuator; the physical rear-steer '
              f'transfer function is shown anyway.', file=err)
    _print_tf('Y_s/delta, vehicle only:', num0, den0, out)
    if wa is not None:
        _print_tf(
            f'Y_s/delta with {args.actuator_hz:g} Hz actuator lag (pole at {-wa:.4g} rad/s):',
            num1,
            den1,
            out,
        )
        curves.append((f'+ {args.actuator_hz:g} Hz actuator', (num1, den1)))
    if pre.target:
        print(
            f'  published target ({pre.target.get("source", "")}) at V = {pre.speed:g} m/s, d_s = '
            f'{pre.ds:g} m:',
            file=out,
        )
        print(
            f'    zeros = {format_roots(pre.target_zeros)}, poles = '
            f'{format_roots(pre.target_poles)}',
            file=out,
        )
    if args.identified:
        curves.append(('identified Eq. (6)', _identified(out)))
    if args.plots:
        bode, step = _plots(args.plots, curves)
        print(f'saved {bode} and {step}', file=out)
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
