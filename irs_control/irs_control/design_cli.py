"""Command line: print the paper's RST designs and optionally save Bode/step plots.

Usage::

    python -m irs_control.design_cli [--actuator-pole 29] [--gain 363.394]
                                     [--observer minimal|paper] [--plots DIR]
                                     [--reconstruction] [--check-plant identified]
                                     [--check-delay 0.017]

Prints R, S, T, Ao, B+, B- and the closed-loop poles for the design with the actuator and
the design that neglects it (both on the identified plant of Eq. 6), and the start-up design
check of each (:mod:`.design_check`: the 1 kHz controller closed with ``--check-plant`` and the
transport delay ``--check-delay``; poles, margins, delay margin; the node refuses what it calls
UNSTABLE). ``--plots DIR``
writes ``bode_<case>.png`` and ``step_<case>.png`` (closed loop vs reference model; the
step plots include the *true* plant -- with actuator -- driven by the design that neglects
it, the paper's Fig. 10 middle-panel situation, simulated with the discrete controller at
1 kHz with the +-15 deg steer limit).
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from .controller_factory import CONTROLLER_DEFAULTS
from .design_check import check_design, check_plant_polynomials
from .discrete_rst import DiscreteRstController
from .paper_design import (PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN, identified_plant,
                           paper_mrc_design, reconstruction_hypotheses)

__all__ = ['main', 'format_poly', 'format_design', 'design_check_line']


def format_poly(p, var: str = 's') -> str:
    """Human-readable polynomial, e.g. ``1 s^2 + 24 s + 144``."""
    p = np.atleast_1d(np.asarray(p, dtype=float))
    n = p.size - 1
    terms = []
    for i, c in enumerate(p):
        k = n - i
        mon = '' if k == 0 else (f' {var}' if k == 1 else f' {var}^{k}')
        terms.append(f'{c:.6g}{mon}')
    return ' + '.join(terms).replace('+ -', '- ')


def format_design(name: str, d) -> str:
    """Multi-line text block describing an :class:`~irs_control.rst_design.RstDesign`."""
    poles = ', '.join(
        f'{p.real:.4g}{p.imag:+.4g}j'
        for p in sorted(d.closed_loop_poles, key=lambda z: (z.real, z.imag))
    )
    lines = [f'== {name} ==',
             f'A   = {format_poly(d.A)}', f'B   = {format_poly(d.B)}',
             f'R   = {format_poly(d.R)}', f'S   = {format_poly(d.S)}',
             f'T   = {format_poly(d.T)}', f'Ao  = {format_poly(d.Ao)}',
             f'B+  = {format_poly(d.B_plus)}', f'B-  = {format_poly(d.B_minus)}',
             f'closed-loop poles: {poles}',
             f'max |Gcl - Gm|/|Gm| (0.01..1000 rad/s): {d.closed_loop_freq_error():.2e}']
    return '\n'.join(lines)


def design_check_line(d, check_plant: str, actuator_pole: float, gain: float,
                      delay: float, dt: float = CONTROLLER_DEFAULTS['dt']) -> str:
    """The start-up design check of design ``d`` run at ``dt`` [s] on ``check_plant`` with the
    transport delay ``delay`` [s], as the node logs it (``REFUSED`` when it would not start).
    """
    B, A = check_plant_polynomials(check_plant, actuator_pole,
                                   gain if check_plant == 'identified' else 0.0,
                                   CONTROLLER_DEFAULTS['speed'], CONTROLLER_DEFAULTS['ds'])
    ss = DiscreteRstController(d, dt=dt).linear_state_space()
    chk = check_design(B, A, d.R, d.S, ss, dt, check_plant, delay)
    return f"design check{'' if chk.stable else ' (REFUSED)'}: {chk.summary()}"


def _plots(outdir, designs, actuator_pole, gain):
    import matplotlib

    matplotlib.use('Agg')
    import control
    import matplotlib.pyplot as plt

    from .discrete_rst import DiscreteRstController
    from .loop_sim import simulate_loop

    os.makedirs(outdir, exist_ok=True)
    files = []
    w = np.logspace(-1, 2.5, 400)
    B_true, A_true = identified_plant(True, actuator_pole, gain)
    for key, d in designs.items():
        num, den = d.closed_loop()
        g_cl = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
        g_m = np.polyval(d.Bm, 1j * w) / np.polyval(d.Am, 1j * w)
        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
        ax[0].semilogx(w, 20 * np.log10(np.abs(g_cl)), label='closed loop (design plant)')
        ax[0].semilogx(w, 20 * np.log10(np.abs(g_m)), '--', label='reference model')
        ax[1].semilogx(w, np.degrees(np.unwrap(np.angle(g_cl))))
        ax[1].semilogx(w, np.degrees(np.unwrap(np.angle(g_m))), '--')
        ax[0].set_ylabel('|G| [dB]')
        ax[1].set_ylabel('phase [deg]')
        ax[1].set_xlabel('w [rad/s]')
        ax[0].legend()
        ax[0].set_title(f'Bode: {key}')
        f = os.path.join(outdir, f'bode_{key}.png')
        fig.savefig(f, dpi=90)
        plt.close(fig)
        files.append(f)

        t_end, amp = 4.0, 0.1
        ctrl = DiscreteRstController(d, dt=1e-3)
        res = simulate_loop(ctrl, B_true, A_true, lambda t: amp, t_end)
        _, ym = control.step_response(control.tf(d.Bm, d.Am), res.t)
        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
        ax[0].plot(res.t, res.y, label='discrete RST on plant with actuator')
        ax[0].plot(res.t, amp * ym, '--', label='reference model')
        ax[0].set_ylabel('y_s [m]')
        ax[0].legend()
        ax[0].set_title(f'0.1 m step: {key}')
        ax[1].plot(res.t, res.u)
        ax[1].set_ylabel('steer [rad]')
        ax[1].set_xlabel('t [s]')
        f = os.path.join(outdir, f'step_{key}.png')
        fig.savefig(f, dpi=90)
        plt.close(fig)
        files.append(f)
    return files


def main(argv=None) -> int:
    """Entry point; returns the process exit code."""
    ap = argparse.ArgumentParser(description='IRS lateral MRC/RST design (paper Sec. 5).')
    ap.add_argument('--actuator-pole', type=float, default=PAPER_ACTUATOR_POLE,
                    help='actuator pole magnitude [rad/s] (default 29, Eq. 6)')
    ap.add_argument('--gain', type=float, default=PAPER_PLANT_GAIN,
                    help='plant high-frequency gain b0 (default reconstructed 363.394)')
    ap.add_argument('--observer', choices=('minimal', 'paper'), default='minimal',
                    help='observer of the design without actuator: s+12 or (s+12)^2')
    ap.add_argument('--plots', metavar='DIR', help='save Bode and step PNGs in DIR')
    ap.add_argument('--reconstruction', action='store_true',
                    help='print the Eq. 22 reconstruction hypotheses table')
    ap.add_argument('--check-plant', default=CONTROLLER_DEFAULTS['check_plant'],
                    help="plant of the design check: 'identified' (Eq. 6) or a preset name")
    ap.add_argument('--check-delay', type=float, default=CONTROLLER_DEFAULTS['check_delay'],
                    help='transport delay of the design check [s] (default 0.017)')
    args = ap.parse_args(argv)
    designs = {
        'with_actuator': paper_mrc_design(True, args.actuator_pole, args.gain),
        'without_actuator': paper_mrc_design(False, args.actuator_pole, args.gain, args.observer),
    }
    for key, d in designs.items():
        print(format_design(key, d))
        print(design_check_line(d, args.check_plant, args.actuator_pole, args.gain,
                                args.check_delay))
        print()
    if args.reconstruction:
        print('== Eq. 22 reconstruction (max relative R coefficient error) ==')
        for label, _, err, m in reconstruction_hypotheses():
            print(f'{m:8.3f}  {label}' + ('' if err is None else f'  {np.round(err, 3)}'))
    if args.plots:
        for f in _plots(args.plots, designs, args.actuator_pole, args.gain):
            print(f'wrote {f}')
    return 0


if __name__ == '__main__':  # pragma: no cover
    raise SystemExit(main())
