r"""Which design plant explains the printed R and S of Sec. 5 (Eqs. 22-23)? An inverse problem.

Printed (OCR): ``R = s^4 + 44.9 s^3 + 707.2 s^2 + 3530.8 s + 6364.5`` (22), ``S = "6000" s^4 +
293 s^3 + 4484 s^2 + 23140 s + 23779`` (23), ``T = "6000" s^4 + 216 s^3 + 2604 s^2 + 13109 s +
23779`` (24), ``Ao = (s + 12)^2`` (25), ``Bm = 2308 (s^2 + 10 s + 26)`` (21; 2308 is
60000 / 26 = 2307.69 rounded: the model has unit DC gain).  The leading "6000" are garbled (T's is
6.35) and treated as unknown.  The degrees fix a type-2 plant ``b0 Z(s) / A(s)`` with ``Z`` monic
quadratic, ``A = s^2 A1`` monic quintic, every zero cancelled, so ``R' = quotient(Am Ao / A)``,
``S = remainder / b0``, ``R = R' Z``, ``T = Ao Bm / b0`` (``np.polydiv``; the same as
:func:`.rst_design.design_rst`, tested).  Findings (``python -m irs_control.paper_inverse``):

1. **b0 is pinned by T and S0**: ``T = Ao Bm / b0`` and, for any ``A = s^2 A1``,
   ``b0 S0 = (Am Ao)_0``.  Each printed integer is its true value rounded, so b0 lies in the
   intersection of the intervals each gives (:func:`gain_interval`): 363.346 +- 0.008.
2. **S1 = 23140 is impossible**: ``b0 S1 = (Am Ao)_1`` for any type-2 plant gives 17121 (-26 %).
3. Of the six other numbers (R3..R0, S3, S2) no type-2 design reproduces all: with R exact
   (``Z`` one of R's root pairs, a one-parameter family, :func:`r_exact_plant`) S3 and S2 stay
   12.9 % off (or 5.7 % with S4 < 0); the smallest worst error (:func:`fit_minimax`) is 5.1 % with
   S4 > 0 (3.5 % with S4 = -24.7, which would print with a minus sign).  Two families remain,
   :data:`INVERSE_PLANT` (S side, 5.1 %) and :data:`R_EXACT_PLANT` (R exact, the paper's 3.8 Hz
   actuator pole); only the weak reading of S's "6000" as a number in [6, 7) prefers the first.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from .paper_design import paper_observer, reference_model

__all__ = ['PRINTED_R', 'PRINTED_S', 'PRINTED_T', 'exact_model_numerator', 'gain_interval',
           'PINNED_GAIN', 'DesignPlant', 'mrc_polynomials', 'coefficient_errors', 'type2_s1',
           'fit_minimax', 'r_exact_plant', 'family_table', 'INVERSE_PLANT', 'R_EXACT_PLANT',
           'COMPLEX_ZERO_PLANT', 'vehicle_part', 'figure10_on_plant', 'main']

#: Eq. 22 as printed (monic).
PRINTED_R = np.array([1.0, 44.9, 707.2, 3530.8, 6364.5])
#: Eq. 23 as printed; the OCR-garbled leading "6000" is unknown (NaN).
PRINTED_S = np.array([np.nan, 293.0, 4484.0, 23140.0, 23779.0])
#: Eq. 24 as printed; the OCR-garbled leading "6000" is unknown (NaN).
PRINTED_T = np.array([np.nan, 216.0, 2604.0, 13109.0, 23779.0])
#: Residuals of the fits: R3, R2, R1, R0, S3, S2 (S4 garbled, S1 impossible, S0 and T fix b0).
RESIDUALS = ('R3', 'R2', 'R1', 'R0', 'S3', 'S2')


def exact_model_numerator() -> np.ndarray:
    """Eq. 21's numerator with unit DC gain, ``(60000 / 26)(s^2 + 10 s + 26)`` (2308 printed)."""
    _, am = reference_model()
    return am[-1] / 26.0 * np.array([1.0, 10.0, 26.0])


def gain_interval(half_unit: float = 0.5) -> tuple:
    """``(lo, hi)`` of b0 [m rad^-1 s^-3] consistent with the printed T3..T0 and S0.

    ``T_i = (Ao Bm)_i / b0`` and ``S0 = (Am Ao)_0 / b0`` (type 2); each printed integer ``p`` is
    the true value rounded, within ``p +- half_unit``, so ``b0`` lies in ``[c / (p + 1/2),
    c / (p - 1/2)]`` for each; the intersection of the five intervals.
    """
    _, am = reference_model()
    known = [(c, p) for c, p in zip(np.polymul(paper_observer(), exact_model_numerator())[1:],
                                    PRINTED_T[1:])]
    known.append((np.polymul(am, paper_observer())[-1], PRINTED_S[-1]))
    lo = max(c / (p + half_unit) for c, p in known)
    hi = min(c / (p - half_unit) for c, p in known)
    if lo > hi:
        raise ValueError('the printed T and S0 admit no common b0')
    return float(lo), float(hi)


#: b0 pinned by T and S0: the middle of :func:`gain_interval`, 363.346 [m rad^-1 s^-3].
PINNED_GAIN = 0.5 * sum(gain_interval())


@dataclass(frozen=True)
class DesignPlant:
    """Design plant ``b0 (s^2 + z1 s + z0) / A(s)`` (steer [rad] -> y_s [m]).

    Attributes
    ----------
    gain : float
        High-frequency gain b0 [m rad^-1 s^-3].
    zero_poly : tuple of float
        ``(z1, z0)`` of the monic zero quadratic [1/s, 1/s^2] (complex zeros if z1^2 < 4 z0).
    den : tuple of float
        Monic denominator A, highest power first (degree 5).
    """

    gain: float
    zero_poly: tuple
    den: tuple

    @property
    def B(self) -> np.ndarray:
        """Numerator ``b0 Z(s)``."""
        return self.gain * np.array([1.0, *self.zero_poly])

    @property
    def A(self) -> np.ndarray:
        """Monic denominator."""
        return np.asarray(self.den, dtype=float)

    @property
    def zeros(self) -> np.ndarray:
        """Plant zeros [rad/s]."""
        return np.roots([1.0, *self.zero_poly])

    @property
    def poles(self) -> np.ndarray:
        """Plant poles [rad/s]."""
        return np.roots(self.A)


def mrc_polynomials(plant: DesignPlant, bm=None):
    """R, S, T of the paper's MRC (every zero cancelled, Am of Eq. 21, Ao of Eq. 25).

    ``R' = quotient(Am Ao / A)``, ``S = remainder / b0`` (padded to degree 4), ``R = R' Z``,
    ``T = Ao Bm / b0``; ``bm`` default :func:`exact_model_numerator`.  Arrays, highest power first.
    """
    _, am = reference_model()
    bm = exact_model_numerator() if bm is None else np.asarray(bm, dtype=float)
    ao = paper_observer()
    r_prime, rem = np.polydiv(np.polymul(am, ao), plant.A)
    s = np.zeros(5)
    s[5 - rem.size:] = rem / plant.gain
    return np.polymul(r_prime, [1.0, *plant.zero_poly]), s, np.polymul(ao, bm) / plant.gain


def coefficient_errors(plant: DesignPlant) -> dict:
    """Relative errors ``(computed - printed) / printed`` by name: R3..R0, S3..S0, T3..T0."""
    r, s, t = mrc_polynomials(plant)
    out = {}
    for name, got, printed in (('R', r, PRINTED_R), ('S', s, PRINTED_S), ('T', t, PRINTED_T)):
        for i in range(1, 5):
            out[f'{name}{4 - i}'] = float((got[i] - printed[i]) / printed[i])
    return out


def _residuals(plant: DesignPlant) -> np.ndarray:
    e = coefficient_errors(plant)
    return np.array([e[k] for k in RESIDUALS])


def type2_s1(gain: float = PINNED_GAIN) -> float:
    """S's s^1 coefficient forced by a double integrator: ``(Am Ao)_1 / b0`` [rad/m]."""
    _, am = reference_model()
    return float(np.polymul(am, paper_observer())[-2] / gain)


def _type2_plant(x, actuator_pole: float | None) -> DesignPlant:
    """``x`` = (z1, z0, c1, c0) with the actuator pole fixed, or (z1, z0, a2, a1, a0) free."""
    z1, z0, *p = (float(v) for v in x)
    cubic = np.polymul([1.0, actuator_pole], [1.0, *p]) if actuator_pole else [1.0, *p]
    return DesignPlant(PINNED_GAIN, (z1, z0), tuple(np.polymul(cubic, [1.0, 0.0, 0.0])))


def fit_minimax(start, actuator_pole: float | None = 29.0, s4_positive: bool = True):
    """The type-2 plant (b0 pinned) with the smallest worst relative error over R3..R0, S3, S2.

    ``start`` = (z1, z0, c1, c0) [the vehicle quadratic ``s^2 + c1 s + c0`` behind the
    ``actuator_pole``] or (z1, z0, a2, a1, a0) [``A1 = s^3 + a2 s^2 + a1 s + a0``] when
    ``actuator_pole`` is None.  Epigraph form solved by ``scipy.optimize.minimize`` (SLSQP):
    minimise ``t`` subject to ``|e_i| <= t``, and ``S4 >= 0`` if ``s4_positive``.
    Returns ``(plant, worst_error)``.
    """
    start = np.asarray(start, dtype=float)
    n = start.size
    scale = np.where(start != 0.0, np.abs(start), 1.0)      # the variables as multiples of start

    def plant_of(y):
        return _type2_plant(y[:n] * scale, actuator_pole)

    def resid(y):
        return _residuals(plant_of(y))

    cons = [{'type': 'ineq', 'fun': lambda y: y[n] - resid(y)},
            {'type': 'ineq', 'fun': lambda y: y[n] + resid(y)}]
    if s4_positive:
        cons.append({'type': 'ineq', 'fun': lambda y: mrc_polynomials(plant_of(y))[1][0]})
    y0 = np.append(start / scale, np.max(np.abs(resid(np.append(start / scale, 0.0)))))
    sol = minimize(lambda y: y[n], y0, method='SLSQP', constraints=cons,
                   options={'maxiter': 500, 'ftol': 1e-12})
    sol.x[:n] *= scale
    plant = _type2_plant(sol.x[:n], actuator_pole)
    return plant, float(np.max(np.abs(_residuals(plant))))


def r_exact_plant(zero_pair: str = 'slow'):
    """The type-2 plant (b0 pinned) that reproduces the printed R exactly, best for S3 and S2.

    ``R = R' Z`` exactly makes ``Z`` one of R's root pairs (``'slow'``: -3.45 +- 1.70j,
    ``'fast'``: -19.0 +- 8.32j) and ``R'`` the other.  ``A R' + b0 S = Am Ao`` then fixes A's
    s^4 and s^3 coefficients (the top of ``quotient(Am Ao / R')``) and leaves ``a0`` free; S4,
    S3 and S2 are affine in it.  ``a0`` minimises the worst of the S3 and S2 errors
    (``minimize_scalar``).  Returns ``(plant, worst S3/S2 error)``.
    """
    roots = np.roots(PRINTED_R)
    slow = roots[np.argsort(np.abs(roots))][:2]
    fast = roots[np.argsort(np.abs(roots))][2:]
    if zero_pair not in ('slow', 'fast'):
        raise ValueError(f"zero_pair must be 'slow' or 'fast'; got {zero_pair!r}")
    z, rp = (slow, fast) if zero_pair == 'slow' else (fast, slow)
    z, rp = np.real(np.poly(z)), np.real(np.poly(rp))
    _, am = reference_model()
    q = np.polydiv(np.polymul(am, paper_observer()), rp)[0]

    def plant(a0):
        return DesignPlant(PINNED_GAIN, (float(z[1]), float(z[2])),
                           tuple(np.polymul([1.0, q[1], q[2], a0], [1.0, 0.0, 0.0])))

    def worst(a0):
        e = coefficient_errors(plant(a0))
        return max(abs(e['S3']), abs(e['S2']))

    scale = float(np.polymul(am, paper_observer())[-3])     # (Am Ao)_2, sets a0's range
    sol = minimize_scalar(worst, bounds=(-scale, scale), method='bounded',
                          options={'xatol': 1e-9 * scale})
    return plant(sol.x), float(sol.fun)


def _rounded(gain, zeros, poles) -> DesignPlant:
    """A DesignPlant from its zeros and its poles besides 0, 0 (the stored constants)."""
    return DesignPlant(gain, tuple(np.real(np.poly(zeros))[1:]),
                       tuple(np.polymul(np.real(np.poly(poles)), [1.0, 0.0, 0.0])))


#: Family A, found by :func:`fit_minimax` from the earlier fit (rounded to 5 digits): b0 pinned,
#: poles 0, 0, -29 (Eq. 6's actuator), -15.094 +- 11.468j, real zeros -19.043, -7.0897; R, S3,
#: S2 within 5.06 %, S4 = 6.55.  Vehicle part for the rig: K = b0 / 29 = 12.529 m/s^2/rad,
#: ``identified.numerator = [26.133, 135.02]``, ``identified.denominator = [30.188, 359.35]``.
INVERSE_PLANT = _rounded(PINNED_GAIN, [-19.043, -7.0897], [-29.0, -15.094 + 11.468j,
                                                             -15.094 - 11.468j])
#: Family B, :func:`r_exact_plant` ``('slow')``: R exact, zeros -3.4504 +- 1.6999j, poles 0, 0,
#: -5.3849, -10.739, -23.877 (2 pi 3.80 Hz: the paper's isolated-servo pole); S3 and S2 12.9 %
#: off, S4 = 8.98 (the OCR's "6000" could be a garbled 8.98 as well as a 6.xx).
R_EXACT_PLANT = _rounded(PINNED_GAIN, [-3.4504 + 1.6999j, -3.4504 - 1.6999j],
                         [-5.3849, -10.739, -23.877])
#: Family C, :func:`fit_minimax` without the sign condition: zeros -18.302 +- 11.746j (near R's
#: fast pair), poles 0, 0, -46.004, -12.637 +- 24.051j; R, S3, S2 within 3.5 %, but S4 = -24.7,
#: which would print with a minus sign: excluded.
COMPLEX_ZERO_PLANT = _rounded(PINNED_GAIN, [-18.302 + 11.746j, -18.302 - 11.746j],
                              [-46.004, -12.637 + 24.051j, -12.637 - 24.051j])


def family_table() -> list:
    """``[(name, plant, errors dict, S4), ...]`` of the three families (the doc's table)."""
    rows = []
    for name, plant in (('A: INVERSE_PLANT', INVERSE_PLANT), ('B: R_EXACT_PLANT', R_EXACT_PLANT),
                        ('C: COMPLEX_ZERO_PLANT', COMPLEX_ZERO_PLANT)):
        rows.append((name, plant, coefficient_errors(plant), float(mrc_polynomials(plant)[1][0])))
    return rows


def vehicle_part(plant: DesignPlant, actuator_pole: float = 29.0):
    """``(B_veh, A_veh)``: the plant with its actuator lag ``p/(s+p)`` removed (the vehicle the
    rig steps behind its actuator, and the plant of the design *without* the actuator).
    """
    a_veh, rem = np.polydiv(plant.A, [1.0, actuator_pole])
    if np.max(np.abs(rem)) > 1e-9 * np.max(np.abs(plant.A)):
        raise ValueError(f'the plant has no pole at -{actuator_pole} rad/s to remove')
    return plant.B / actuator_pole, a_veh


def figure10_on_plant(plant: DesignPlant, actuator_pole: float = 29.0, step: float = 0.02,
                      t_end: float = 8.0, dt: float = 1e-3) -> dict:
    """The three Figure 10 designs on ``plant`` (linear, ZOH-exact, +-15 deg, 1 kHz).

    MRC with the actuator: designed on ``plant`` (Ao = (s+12)^2); MRC without: designed on
    :func:`vehicle_part` (Ao = s + 12, the paper's degree rule); PI kp = 5, ki = 3. Each runs on
    ``plant`` for a ``step`` [m] set-point step at t = 0. Returns ``name -> StepMetrics``
    (:mod:`irs_control.metrics`; ISE against the Eq. 21 model response).
    """
    import control

    from .discrete_pi import DiscretePiController
    from .discrete_rst import DiscreteRstController
    from .loop_sim import simulate_loop
    from .metrics import step_metrics
    from .rst_design import design_rst

    bm, am = reference_model()
    b_veh, a_veh = vehicle_part(plant, actuator_pole)
    controllers = {
        'mrc_with_actuator': DiscreteRstController(
            design_rst(plant.B, plant.A, bm, am, paper_observer(), cancel='stable'), dt=dt),
        'mrc_without_actuator': DiscreteRstController(
            design_rst(b_veh, a_veh, bm, am, np.array([1.0, 12.0]), cancel='stable'), dt=dt),
        'pi': DiscretePiController(5.0, 3.0, dt=dt),
    }
    out = {}
    for name, ctl in controllers.items():
        res = simulate_loop(ctl, plant.B, plant.A, lambda t: step, t_end)
        y_model = control.forced_response(control.tf(bm, am), T=res.t,
                                          U=np.full(res.t.size, step)).outputs
        out[name] = step_metrics(res.t, res.y, step, y_model=y_model, steer=res.u)
    return out


def _fmt_roots(r) -> str:
    r = sorted(np.asarray(r), key=lambda z: (-z.real, abs(z.imag)))
    out = []
    for z in r:
        if abs(z.imag) < 1e-9 * max(1.0, abs(z)):
            out.append(f'{z.real:.4g}')
        elif z.imag > 0:
            out.append(f'{z.real:.4g} +- {z.imag:.4g}j')
    return ', '.join(out)


def main(argv=None) -> int:
    """``python -m irs_control.paper_inverse``: b0, the families, Figure 10 on each."""
    del argv
    lo, hi = gain_interval()
    print(f'b0 from T3..T0 and S0 (each printed integer +- 0.5): [{lo:.4f}, {hi:.4f}], '
          f'pinned {PINNED_GAIN:.4f}; with 2308 instead of 60000/26: T alone gives '
          f'{2308 * 3744 / 23779:.3f}')
    print(f'S1 forced by two integrators: {type2_s1():.0f} (printed 23140, '
          f'{(type2_s1() - 23140) / 23140:+.1%})')
    for pair in ('slow', 'fast'):
        plant, worst = r_exact_plant(pair)
        print(f"R exact, zeros = R's {pair} pair: S3/S2 worst {worst:.4f}, S4 "
              f'{mrc_polynomials(plant)[1][0]:.3f}, poles 0, 0, '
              f'{_fmt_roots(np.roots(plant.A[:-2]))}')
    start = np.real(np.poly([-29.0, -14.66 + 11.41j, -14.66 - 11.41j]))
    plant, worst = fit_minimax([25.79, 123.7, *start[1:]], actuator_pole=None)
    print(f'type 2, three poles free, S4 >= 0: worst R/S3/S2 {worst:.4f} at S4 '
          f'{mrc_polynomials(plant)[1][0]:.3f}; zeros {_fmt_roots(plant.zeros)}, poles 0, 0, '
          f'{_fmt_roots(np.roots(plant.A[:-2]))}')
    for name, plant, e, s4 in family_table():
        worst = max(abs(e[k]) for k in RESIDUALS)
        t_worst = max(abs(e[f'T{i}']) for i in range(4))
        print(f'{name:22s} worst R/S3/S2 {worst:.4f} (S1 {e["S1"]:+.3f}, S0 {e["S0"]:+.1e}, '
              f'T {t_worst:.1e}), S4 {s4:.3f}\n    zeros {_fmt_roots(plant.zeros)}; poles 0, 0, '
              f'{_fmt_roots(np.roots(plant.A[:-2]))}')
    for label, plant, pole in (('A', INVERSE_PLANT, 29.0), ('B', R_EXACT_PLANT, 23.877)):
        print(f'Figure 10 on family {label} (0.02 m step, actuator pole {pole} rad/s):')
        for name, m in figure10_on_plant(plant, pole).items():
            print(f'  {name:22s} rise {m.rise_time:.3f} s  overshoot {m.overshoot_percent:.1f} %'
                  f'  settle {m.settling_time:.2f} s  osc {m.oscillation_count}  '
                  f'ISE {m.ise_vs_model:.2e}  peak steer {m.peak_steer:.3f} rad')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
