"""The paper's identified plant, reference model and MRC (RST) designs (Eqs. 6, 21-25).

Plant (Eq. 6, steer [rad] -> lateral sensor displacement y_s [m], V = 1.2 m/s, ds = 0.33 m)::

    G(s) = b0 (s + 2.4)(s + 4.8) / (s^2 (s + 8)(s + 20)(s + 29))

Reference model (Eq. 21) ``Gm = 2308 (s^2 + 10 s + 26) / ((s^2+8s+25)(s^2+16s+80)(s+30))``
(DC gain 60008/60000 = 1.00013) and observer ``Ao = (s + 12)^2`` (Eq. 25).

Reconstruction of the plant gain ``b0`` (not printed)
----------------------------------------------------
The OCR of Eq. 24, ``T = "6000"s^4 + 216 s^3 + 2604 s^2 + 13109 s + 23779``, is proportional
to ``Ao (s^2+10s+26) = s^4 + 34 s^3 + 410 s^2 + 2064 s + 3744`` with ratio
23779/3744 = 6.3512 (216/34 = 6.35, 2604/410 = 6.35, 13109/2064 = 6.35; "6000" is an
OCR-garbled "6.351"). ``T = Ao Bm'`` with ``Bm = B- Bm'`` and a T that contains all of
``Bm`` means ``B- = b0`` is a constant, i.e. both zeros were cancelled and
``T = Ao Bm / b0``, so ``b0 = 2308 / 6.3512 = 2308 * 3744 / 23779 = 363.394``.
Independently ``S(0)``: with ``A(0) = 0``, ``b0 S(0) = Am(0) Ao(0) = 8.64e6`` and the
printed ``S(0) = 23779`` gives ``b0 = 363.34`` (0.015 % apart; the printed S(0) = T(0)
is the type-2 unit-DC-gain condition). ``PAPER_PLANT_GAIN = 363.394`` (from T, 5 digits).
Check: the design below reproduces the printed T to 3e-4 relative on every coefficient.

The printed R (Eq. 22) is not reproduced *on Eq. 6's plant*
-----------------------------------------------------------
(What follows holds for designs on Eq. 6's poles. Freeing the design plant's poles and zeros,
:mod:`irs_control.paper_inverse` finds two families of plants -- neither Eq. 6 -- that explain the
printed R and S to 5.1 % or reproduce R exactly; no single design gives both, and S's s^1
coefficient none with two integrators; see docs/control_design.md.) Cancelling both zeros
forces ``(s+2.4)(s+4.8)`` to divide R (Eq. 16), and the printed
``R = s^4 + 44.9 s^3 + 707.2 s^2 + 3530.8 s + 6364.5`` has roots -19.0 +- 8.32j and
-3.45 +- 1.70j, so Eq. 22 is inconsistent with Eqs. 16, 18 and 24 for any ``A``,
``Ao``, ``b0``. The design that the printed T, Ao, Am and the stated degree rule
``deg Ao = deg A - deg B+ - 1 = 2`` all imply gives
``R = (s^2 + 21 s + 224)(s + 2.4)(s + 4.8) = s^4 + 28.2 s^3 + 386.7 s^2 + 1854.7 s + 2580.5``
(relative coefficient errors vs Eq. 22: 37 %, 45 %, 47 %, 59 %). Likewise the printed
``S`` s^1 coefficient (23140) contradicts ``b0 S_1 = (Am Ao)_1 = 6.2208e6`` (gives 17119)
for every type-2 plant once T fixes b0 and Ao. Hypotheses tried (max relative R
coefficient error; see :func:`reconstruction_hypotheses` and docs/control_design.md):
cancel both, pole 29 or 28.90: 0.595 / 0.596; actuator at 3.8 Hz (23.9 rad/s): 0.62;
vehicle-only plant, cancel -2.4 only, Ao = (s+12)^2: 0.49; no cancellation or one zero
cancelled on the plant with actuator: infeasible -- Bm lacks the uncancelled zeros, and
putting them into the model numerator leaves a model pole excess < 3 = deg A - deg B, so
T is non-causal (and solving A R + B S = Am Ao4 for the Ao4 that would reproduce R gives
roots -22.7 +- 8.1j, -1.27 +- 1.27j: nothing like the printed (s+12)^2); vehicle-only
plant with Ao = s + 12 (the minimum-degree observer for that plant): 0.32 -- the closest, it has
the same ``s^2 + 38 s`` leading factor as the printed R's complex pair -19 +- 8.3j
(but 377 vs 430 as constant term). No hypothesis consistent with the printed T reaches
the printed R; we conclude Eq. 22 (and S beyond S(0)) are misprinted or from another
iteration and use the design implied by T, Ao, Am and the paper's Eqs. 16-20.

Actuator pole: Eq. 6 prints -29 while 2 pi 4.6 = 28.90 rad/s. T and S(0) do not depend
on it; the R and S coefficients change by < 0.4 % and < 5 % respectively (leading S
coefficient). We use the printed 29.0 (``actuator_pole`` is a parameter).

Design without the actuator
---------------------------
Vehicle-only plant ``(b0/29) (s+2.4)(s+4.8) / (s^2 (s+8)(s+20))``: the actuator lag
``29/(s+29)`` (unit DC gain) is replaced by 1, so the high-frequency gain becomes
``b0/29 = 12.53``. R does not depend on the gain (B- is a constant); S and T scale by 1/gain. The
paper's rule gives ``deg Ao = 4 - 2 - 1 = 1``; we use
``Ao = s + 12`` (one of the paper's observer roots): R = s^4 + 45.2 s^3 + 662.1 s^2 +
3152.2 s + 4343.0, deg S = 3, deg T = 3 -- causal. ``observer='paper'`` keeps
``(s+12)^2`` instead (deg R = 5, deg S = 3, deg T = 4, also causal).
"""
from __future__ import annotations

import numpy as np

from irs_models.constants import (PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN, PAPER_VEHICLE_POLES,
                                  PAPER_ZEROS)
from irs_models.identified import identified_plant

from .rst_design import RstDesign, RstDesignError, design_rst

__all__ = ['PAPER_PLANT_GAIN', 'PAPER_ACTUATOR_POLE', 'PAPER_VEHICLE_POLES', 'PAPER_ZEROS',
           'PRINTED_R', 'PRINTED_T', 'identified_plant', 'reference_model', 'paper_observer',
           'paper_mrc_design', 'relative_coefficient_errors', 'reconstruction_hypotheses']

#: Eq. 22 as printed.
PRINTED_R = np.array([1.0, 44.9, 707.2, 3530.8, 6364.5])
#: Eq. 24 with the OCR-garbled leading "6000" replaced by 23779/3744.
PRINTED_T = np.array([23779.0 / 3744.0, 216.0, 2604.0, 13109.0, 23779.0])


def reference_model():
    """Reference model Eq. 21 as ``(Bm, Am)``; ``Am`` monic, DC gain 1.00013."""
    Am = np.polymul(np.polymul([1.0, 8, 25], [1.0, 16, 80]), [1.0, 30])
    return 2308.0 * np.array([1.0, 10.0, 26.0]), Am


def paper_observer():
    """Observer polynomial Eq. 25, ``Ao = s^2 + 24 s + 144 = (s + 12)^2``."""
    return np.array([1.0, 24.0, 144.0])


def paper_mrc_design(include_actuator: bool = True, actuator_pole: float = PAPER_ACTUATOR_POLE,
                     gain: float = PAPER_PLANT_GAIN, observer: str = 'minimal') -> RstDesign:
    """MRC design of Sec. 5: both (stable, real) zeros cancelled.

    Parameters
    ----------
    include_actuator : bool
        True: plant with the actuator pole, ``Ao = (s+12)^2`` (Eq. 25).
        False: vehicle-only plant; ``observer='minimal'`` uses ``Ao = s + 12``,
        ``observer='paper'`` keeps ``(s+12)^2``.
    actuator_pole, gain : float
        See :func:`identified_plant`.
    observer : {'minimal', 'paper'}
        Only used when ``include_actuator`` is False.
    """
    B, A = identified_plant(include_actuator, actuator_pole, gain)
    Bm, Am = reference_model()
    if include_actuator or observer == 'paper':
        Ao = paper_observer()
    elif observer == 'minimal':
        Ao = np.array([1.0, 12.0])
    else:
        raise ValueError(f"observer must be 'minimal' or 'paper'; got {observer!r}.")
    return design_rst(B, A, Bm, Am, Ao, cancel='stable')


def relative_coefficient_errors(p, printed=PRINTED_R) -> np.ndarray:
    """Per-coefficient ``|p_i - printed_i| / |printed_i|`` (nan array if degrees differ)."""
    p = np.asarray(p, dtype=float)
    printed = np.asarray(printed, dtype=float)
    if p.size != printed.size:
        return np.full(printed.size, np.nan)
    return np.abs(p - printed) / np.abs(printed)


def reconstruction_hypotheses():
    """Designs tried to reproduce Eq. 22; list of ``(label, R, rel_errors, max_rel_error)``.

    Sorted by the max relative coefficient error. Infeasible designs (e.g. non-causal T when
    the uncancelled zeros must be absorbed into the model numerator) have ``R = None`` and
    ``inf`` error, with the reason in the label.
    """
    Bm, Am = reference_model()
    a12 = paper_observer()
    cases = [
        ('cancel both, act 29, Ao=(s+12)^2 [chosen]', True, 29.0, a12, 'stable'),
        ('cancel both, act 28.90 (2 pi 4.6), Ao=(s+12)^2', True, 2 * np.pi * 4.6, a12, 'stable'),
        ('cancel both, act 23.88 (3.8 Hz), Ao=(s+12)^2', True, 2 * np.pi * 3.8, a12, 'stable'),
        ('cancel none, act 29, Ao=(s+12)^4', True, 29.0, np.polymul(a12, a12), 'none'),
        ('cancel -2.4 only, act 29, Ao=(s+12)^3', True, 29.0, np.polymul(a12, [1, 12]), [-2.4]),
        ('cancel -4.8 only, act 29, Ao=(s+12)^3', True, 29.0, np.polymul(a12, [1, 12]), [-4.8]),
        ('vehicle only, cancel both, Ao=s+12', False, 29.0, np.array([1.0, 12.0]), 'stable'),
        ('vehicle only, cancel -2.4, Ao=(s+12)^2', False, 29.0, a12, [-2.4]),
        ('vehicle only, cancel none, Ao=(s+12)^3', False, 29.0, np.polymul(a12, [1, 12]), 'none'),
    ]
    out = []
    for label, act, pole, Ao, cancel in cases:
        B, A = identified_plant(act, pole)
        try:
            d = design_rst(B, A, Bm, Am, Ao, cancel=cancel, absorb_zeros=True)
        except RstDesignError as exc:
            out.append((f'{label}: infeasible ({exc})', None, None, np.inf))
            continue
        err = relative_coefficient_errors(d.R)
        out.append((label, d.R, err, float(np.max(err)) if np.all(np.isfinite(err)) else np.inf))
    out.sort(key=lambda r: r[3])
    return out
