"""The servo's first-order fit against the amplitude (paper Sec. 3.3, Fig. 6), by stepped sines.

The paper identified the servo with a dynamic signal analyser (stepped sines) at several
amplitudes and "approximated [it] as first order": poles between 1 and 7 Hz, 3.8 Hz for the
isolated servo, 4.6 Hz in the vehicle fit (Eq. 6).  :func:`stepped_sine` drives the actuator
core (:class:`~.actuator.SteeringActuator`, radio frame and all) with ``A sin(2 pi f t)`` from
rest at each frequency and takes the fundamental of the achieved steer angle by least squares
over whole periods after the transient::

    H(f) = (b_s + j b_c) / A,   y(t) ~ b_s sin(2 pi f t) + b_c cos(2 pi f t) + c

:func:`fit_first_order` fits ``G(jw) = K p / (jw + p) exp(-jw T)`` to it with
``scipy.optimize.least_squares`` on the complex log ratio ``log(G / H)`` (log magnitude and phase
[rad] weigh alike); gain, pole and dead time are free per amplitude, so the fit knows nothing of
the model.  :func:`amplitude_table` and ``python -m irs_vehicle_sim.servo_fit`` give the table of
docs/paper.md (the paper's band, the 4.6 +- 0.3 Hz anchor at 5-8 deg).

Units: rad, s, Hz (amplitudes in degrees only in the table).  No rclpy.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from .actuator import PRESETS, ActuatorParams, SteeringActuator

__all__ = ['FirstOrderFit', 'stepped_sine', 'fit_first_order', 'amplitude_table',
           'table_markdown', 'FREQUENCIES_HZ', 'TABLE_AMPLITUDES_DEG', 'ANCHOR_HZ',
           'ANCHOR_TOL_HZ', 'ANCHOR_BAND_DEG', 'PAPER_RANGE_HZ', 'main']

#: Stepped-sine frequencies [Hz]: 12 log-spaced from 0.5 to 10 Hz (the paper's Fig. 6 spans
#: 0.1-10 Hz; below 0.5 Hz the servo follows with unit gain at every amplitude).
FREQUENCIES_HZ = tuple(float(f) for f in np.geomspace(0.5, 10.0, 12))
#: Amplitudes of the table [deg of steer]: 7.3 deg is Figure 10's first steer, 15 deg full command.
TABLE_AMPLITUDES_DEG = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.3, 8.0, 10.0, 12.0, 15.0)
#: The paper's 4.6 Hz (Eq. 6) and the tolerance it is held to at 5-8 deg [Hz].
ANCHOR_HZ, ANCHOR_TOL_HZ = 4.6, 0.3
#: Amplitudes where the paper's conclusions are drawn [deg]: Figure 10 steers up to 7.3 deg.
ANCHOR_BAND_DEG = (5.0, 8.0)
#: The paper's range of first-order poles over the amplitude [Hz] ("between 1 and 7 Hz").
PAPER_RANGE_HZ = (1.0, 7.0)


@dataclass(frozen=True)
class FirstOrderFit:
    """``K p / (s + p) exp(-s T)`` fitted to one stepped-sine response.

    gain [rad/rad], pole_hz = p / (2 pi) [Hz], delay T [s], rms of the complex log residual [-].
    """

    gain: float
    pole_hz: float
    delay: float
    rms: float


def stepped_sine(params: ActuatorParams, amplitude: float, freqs=FREQUENCIES_HZ, seed=0,
                 dt: float = 1e-3, settle_periods: int = 2, periods: int = 3) -> np.ndarray:
    """Complex response (fundamental of the achieved angle / command) at ``freqs`` [Hz].

    ``amplitude`` [rad] of the steer command; each frequency starts from rest, runs
    ``settle_periods`` then is measured over ``periods`` whole periods.  ``seed`` seeds the
    radio frame's phase.
    """
    out = []
    for f in freqs:
        act = SteeringActuator(params, seed=seed)
        n0 = int(round(settle_periods / (f * dt)))
        n = int(round(periods / (f * dt)))
        t = np.arange(n0 + n) * dt
        u = amplitude * np.sin(2.0 * math.pi * f * t)
        y = np.array([act.step(c, dt) for c in u])[n0:]
        tt = t[n0:] + dt                    # the achieved angle after step k is at t_{k+1}
        w = 2.0 * math.pi * f
        m = np.column_stack([np.sin(w * tt), np.cos(w * tt), np.ones_like(tt)])
        (bs, bc, _), *_ = np.linalg.lstsq(m, y, rcond=None)
        out.append(complex(bs, bc) / amplitude)
    return np.array(out)


def fit_first_order(freqs, h, delay: float | None = None) -> FirstOrderFit:
    """Fit ``K p / (jw + p) exp(-jw T)`` to the response ``h`` at ``freqs`` [Hz].

    ``delay`` [s] fixes T; ``None`` fits it.  Least squares on ``log(G / h)`` (its imaginary
    part wrapped to (-pi, pi]).
    """
    w = 2.0 * math.pi * np.asarray(freqs, dtype=float)
    h = np.asarray(h, dtype=complex)

    def model(x):
        k, p = math.exp(x[0]), math.exp(x[1])
        t = x[2] if delay is None else delay
        return k * p / (1j * w + p) * np.exp(-1j * w * t)

    def resid(x):
        r = np.log(model(x) / h)
        return np.concatenate([r.real, np.angle(np.exp(1j * r.imag))])

    x0 = [0.0, math.log(2.0 * math.pi * 4.0)] + ([0.017] if delay is None else [])
    sol = least_squares(resid, x0, method='lm', xtol=1e-12, ftol=1e-12)
    return FirstOrderFit(gain=math.exp(sol.x[0]), pole_hz=math.exp(sol.x[1]) / (2.0 * math.pi),
                         delay=float(sol.x[2]) if delay is None else float(delay),
                         rms=float(np.sqrt(np.mean(sol.fun ** 2))))


def amplitude_table(params: ActuatorParams | None = None, amplitudes_deg=TABLE_AMPLITUDES_DEG,
                    freqs=FREQUENCIES_HZ, seed=0) -> list:
    """``[(amplitude_deg, FirstOrderFit), ...]``: the first-order fit at each amplitude."""
    params = params if params is not None else ActuatorParams()
    return [(float(a), fit_first_order(freqs, stepped_sine(params, math.radians(a), freqs,
                                                            seed)))
            for a in amplitudes_deg]


def _verdict(a: float, pole: float) -> str:
    lo, hi = ANCHOR_BAND_DEG
    if lo <= a <= hi:
        ok = abs(pole - ANCHOR_HZ) <= ANCHOR_TOL_HZ
        return f'anchor {ANCHOR_HZ} +- {ANCHOR_TOL_HZ} Hz: ' + ('yes' if ok else '**no**')
    ok = PAPER_RANGE_HZ[0] <= pole <= PAPER_RANGE_HZ[1]
    return f'paper {PAPER_RANGE_HZ[0]:g}-{PAPER_RANGE_HZ[1]:g} Hz: ' + ('yes' if ok else '**no**')


def table_markdown(rows, other=None, other_name: str = '') -> str:
    """Markdown table of :func:`amplitude_table` rows (and a second column set, e.g. a preset)."""
    head = '| amplitude [deg] | pole [Hz] | dead time [ms] | gain | within |'
    sep = '|---|---|---|---|---|'
    if other is not None:
        head += f' {other_name} pole [Hz] |'
        sep += '---|'
    lines = [head, sep]
    for i, (a, fit) in enumerate(rows):
        line = (f'| {a:g} | {fit.pole_hz:.2f} | {1000 * fit.delay:.1f} | {fit.gain:.3f} | '
                f'{_verdict(a, fit.pole_hz)} |')
        if other is not None:
            line += f' {other[i][1].pole_hz:.2f} |'
        lines.append(line)
    return '\n'.join(lines)


def main(argv=None) -> int:
    """``python -m irs_vehicle_sim.servo_fit [--preset NAME] [--compare NAME] [--seed N]``."""
    ap = argparse.ArgumentParser(description='First-order fit of the steering servo against the '
                                 'amplitude (stepped sines on the actuator core).')
    ap.add_argument('--preset', choices=sorted(PRESETS), help='an earlier calibration instead '
                    'of the default parameters')
    ap.add_argument('--compare', choices=sorted(PRESETS), help='add a column for this preset')
    ap.add_argument('--seed', type=int, default=0, help='seed of the radio-frame phase')
    ap.add_argument('--amplitudes', type=float, nargs='+', default=TABLE_AMPLITUDES_DEG,
                    metavar='DEG', help='amplitudes of the steer command [deg]')
    args = ap.parse_args(argv)
    params = ActuatorParams()
    if args.preset:
        params = replace(params, **PRESETS[args.preset])
    rows = amplitude_table(params, args.amplitudes, seed=args.seed)
    other = (amplitude_table(replace(ActuatorParams(), **PRESETS[args.compare]),
                             args.amplitudes, seed=args.seed) if args.compare else None)
    print(table_markdown(rows, other, args.compare or ''))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
