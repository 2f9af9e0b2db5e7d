r"""Continuous-time RST / model-reference pole-placement design (Astrom & Wittenmark).

Plant ``y = B/A u``, controller ``R u = T u_c - S y``, reference model ``y_m = Bm/Am u_c``.

With ``B = B+ B-`` (``B+`` monic, the cancelled zeros), the minimum-degree solution of the
Diophantine equation

.. math:: A R' + B^- S = A_m A_o ,

``R = R' B+`` and ``T = A_o B_m'`` (``B_m = B^- B_m'``), the closed loop is

.. math:: \frac{B T}{A R + B S} = \frac{B^+ B^- A_o B_m'}{B^+ A_m A_o} = \frac{B_m}{A_m},

with characteristic polynomial ``A_m A_o B+`` (the cancelled factors ``A_o B+`` are
unobservable / uncontrollable from ``u_c`` but must be stable).

It exists to compute the paper's MRC (Eq. 21-24) and other model-following designs from plant
and model polynomials, with every impossible case refused in one sentence. Algorithm and checks:
:func:`design_rst`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .polynomials import (
    DiophantineError,
    coeff_rel_error,
    common_roots,
    degree,
    is_hurwitz,
    poly_div_exact,
    poly_from_roots,
    require_polynomial,
    solve_diophantine,
    trim,
)

__all__ = ['RstDesignError', 'RstDesign', 'design_rst', 'select_cancelled_zeros']


class RstDesignError(ValueError):
    """The requested RST design is impossible or inconsistent (message says why)."""


@dataclass
class RstDesign:
    """Result of :func:`design_rst` (all polynomials highest power first, in s).

    Attributes
    ----------
    R, S, T : numpy.ndarray
        Controller polynomials, ``R u = T u_c - S y`` (u in rad, y in m).
    Ao : numpy.ndarray
        Observer polynomial used in the Diophantine equation.
    B_plus, B_minus : numpy.ndarray
        Cancelled (monic) and kept factors of ``B``.
    A, B, Am, Bm : numpy.ndarray
        Plant and (effective) reference model.
    R_prime : numpy.ndarray
        Diophantine solution, ``R = R_prime * B_plus``.
    closed_loop_poles : numpy.ndarray
        Roots of ``A R + B S`` (= roots of ``Am Ao B+``), rad/s.
    cancelled_zeros : numpy.ndarray
        Plant zeros cancelled by the controller.
    notes : list of str
        Human-readable remarks (e.g. model numerator modified).
    """

    R: np.ndarray
    S: np.ndarray
    T: np.ndarray
    Ao: np.ndarray
    B_plus: np.ndarray
    B_minus: np.ndarray
    A: np.ndarray
    B: np.ndarray
    Am: np.ndarray
    Bm: np.ndarray
    R_prime: np.ndarray
    closed_loop_poles: np.ndarray
    cancelled_zeros: np.ndarray
    notes: list = field(default_factory=list)

    def closed_loop(self):
        """Closed loop ``u_c -> y`` as ``(num, den) = (B T, A R + B S)`` (uncancelled)."""
        num = trim(np.polymul(self.B, self.T))
        den = trim(np.polyadd(np.polymul(self.A, self.R), np.polymul(self.B, self.S)))
        return num, den

    def closed_loop_tf(self, minreal: bool = False):
        """Closed loop as a ``control.TransferFunction`` (optionally ``minreal``-reduced)."""
        import control

        num, den = self.closed_loop()
        sys = control.tf(num, den)
        return control.minreal(sys, verbose=False) if minreal else sys

    def model_tf(self):
        """Reference model ``Bm/Am`` as a ``control.TransferFunction``."""
        import control

        return control.tf(self.Bm, self.Am)

    def closed_loop_freq_error(self, w=None) -> float:
        """Max relative error ``|G_cl(jw) - G_m(jw)| / |G_m(jw)|`` over ``w`` [rad/s]."""
        if w is None:
            w = np.logspace(-2, 3, 400)
        s = 1j * np.asarray(w)
        num, den = self.closed_loop()
        g_cl = np.polyval(num, s) / np.polyval(den, s)
        g_m = np.polyval(self.Bm, s) / np.polyval(self.Am, s)
        return float(np.max(np.abs(g_cl - g_m) / np.abs(g_m)))


def _damping(z: complex) -> float:
    return -z.real / abs(z) if abs(z) > 0 else 0.0


def select_cancelled_zeros(zeros, cancel='stable', zeta_min: float = 0.5,
                           sigma_min: float = 0.1, tol: float = 1e-6):
    """Choose which plant zeros to cancel.

    Parameters
    ----------
    zeros : array_like of complex
        Plant zeros [rad/s].
    cancel : {'stable', 'none'} or sequence of complex
        ``'stable'``: zeros with ``Re z < -sigma_min`` and damping ``-Re z/|z| >= zeta_min``.
        A sequence: exactly these zeros (each must match a plant zero within ``tol``).
    zeta_min, sigma_min : float
        Damping-ratio threshold [-] and real-part margin [rad/s] for ``'stable'``.

    Returns
    -------
    cancelled, kept : numpy.ndarray of complex
    """
    zeros = [complex(z) for z in np.atleast_1d(zeros)]
    if isinstance(cancel, str):
        if cancel == 'none':
            return np.array([], dtype=complex), np.array(zeros, dtype=complex)
        if cancel != 'stable':
            raise RstDesignError(
                f"cancel must be 'stable', 'none' or a list of zeros; got {cancel!r}."
            )
        canc = [z for z in zeros if z.real < -sigma_min and _damping(z) >= zeta_min]
    else:
        canc = []
        remaining = list(zeros)
        for c in np.atleast_1d(cancel):
            c = complex(c)
            if not remaining:
                raise RstDesignError(f'Cannot cancel {c}: it is not a zero of the plant.')
            d = [abs(z - c) for z in remaining]
            i = int(np.argmin(d))
            if d[i] > tol * max(1.0, abs(c)):
                raise RstDesignError(
                    f'Cannot cancel {c}: it is not a zero of the plant (zeros: {zeros}).'
                )
            canc.append(remaining.pop(i))
        for z in canc:
            if z.real >= 0:
                raise RstDesignError(
                    f'Cannot cancel the zero {z}: it is not in the open left half plane, so '
                    'the cancelled mode would be unstable.'
                )
    kept = list(zeros)
    for z in canc:
        i = int(np.argmin([abs(k - z) for k in kept]))
        kept.pop(i)
    return np.array(canc, dtype=complex), np.array(kept, dtype=complex)


def _checked_polynomials(A, B, Am, Bm, Ao):
    """The design's polynomials as arrays; :class:`RstDesignError` naming the first that is
    not a polynomial, not monic (A, Am, Ao), improper (B/A) or not Hurwitz (Am, Ao).
    """
    try:
        A, B, Am, Bm, Ao = (require_polynomial(name, p) for name, p in
                            (('A', A), ('B', B), ('Am', Am), ('Bm', Bm), ('Ao', Ao)))
    except ValueError as exc:
        raise RstDesignError(str(exc)) from None
    for name, p in (('A', A), ('Am', Am), ('Ao', Ao)):
        if abs(p[0] - 1.0) > 1e-12:
            raise RstDesignError(f'{name} must be monic (leading coefficient 1); got {p[0]}.')
    if degree(B) > degree(A):
        raise RstDesignError('The plant B/A must be proper (deg B <= deg A).')
    for name, p in (('Am', Am), ('Ao', Ao)):
        if not is_hurwitz(p):
            raise RstDesignError(
                f'{name} has roots {np.roots(p)} that are not in the open left half plane; '
                'the closed-loop poles it places would be unstable.'
            )
    return A, B, Am, Bm, Ao


def design_rst(B, A, Bm, Am, Ao, cancel='stable', zeta_min: float = 0.5,
               sigma_min: float = 0.1, coprime_tol: float = 1e-6,
               absorb_zeros: bool = False, verify_rtol: float = 1e-9) -> RstDesign:
    """Continuous-time MRC / RST design by pole placement.

    Parameters
    ----------
    B, A : array_like
        Plant numerator and (monic) denominator in s, highest power first.
    Bm, Am : array_like
        Reference model numerator and (monic, Hurwitz) denominator.
    Ao : array_like
        Observer polynomial (monic, Hurwitz).
    cancel : {'stable', 'none'} or sequence of complex
        Which plant zeros to cancel, see :func:`select_cancelled_zeros`.
    zeta_min, sigma_min : float
        Thresholds for ``cancel='stable'``.
    coprime_tol : float
        Relative distance under which a root of A and a root of B- are "common".
    absorb_zeros : bool
        If ``B-`` does not divide ``Bm``, use ``Bm_eff = Bm B-(s)/B-(0)`` instead of raising.
    verify_rtol : float
        Tolerance of the final closed-loop = model check (relative, coefficients).

    Returns
    -------
    RstDesign

    Raises
    ------
    RstDesignError

    Notes
    -----
    Algorithm (Astrom & Wittenmark, *Computer-Controlled Systems* / *Adaptive Control*, "MRC with
    zero cancellation"):

    1. Factor ``B = B+ B-``: ``B+`` is monic and holds the zeros that are cancelled
       (``cancel='stable'``: every zero with real part < ``-sigma_min`` and damping ratio >=
       ``zeta_min``; ``'none'``; or an explicit list of zeros). ``B-`` holds the remaining zeros
       and the high-frequency gain ``b0``.
    2. Solve the Diophantine equation, minimum-degree solution ``deg S < deg A``:

       .. math:: A R' + B^- S = A_m A_o .

    3. ``R = R' B+`` and ``T = A_o B_m'`` where ``B_m = B^- B_m'``. When ``B-`` is the constant
       ``b0`` (all zeros cancelled, the paper's case) this is ``T = A_o B_m / b_0``. If ``B-`` has
       zeros that ``Bm`` does not contain, exact model following is impossible: by default
       :class:`RstDesignError` is raised; with ``absorb_zeros=True`` the model numerator is
       replaced by ``Bm_eff = Bm * B-(s)/B-(0)`` (unit DC gain kept) and the design follows
       ``Bm_eff/Am`` instead (recorded in :attr:`RstDesign.Bm`).

    Checks (each raises :class:`RstDesignError` with an explanatory sentence): first, before any
    arithmetic, every polynomial is a non-empty list of finite coefficients, not all zero (NaN,
    inf, empty -> :class:`RstDesignError` naming it); then ``A`` monic, ``A`` and ``B-`` coprime
    (the common root is named), cancelled zeros stable, ``Am`` and ``Ao`` stable, causality ``deg S
    <= deg R`` and ``deg T <= deg R``, and that the computed closed loop equals the model to
    ``verify_rtol`` (coefficient comparison).
    """
    A, B, Am, Bm, Ao = _checked_polynomials(A, B, Am, Bm, Ao)

    zeros = np.roots(B) if degree(B) > 0 else np.array([], dtype=complex)
    canc, kept = select_cancelled_zeros(zeros, cancel, zeta_min, sigma_min)
    b0 = B[0]
    B_plus = poly_from_roots(canc)
    B_minus = poly_from_roots(kept, gain=b0)

    common = common_roots(A, B_minus, tol=coprime_tol)
    if common:
        raise RstDesignError(
            f'A and B- are not coprime: they share the root {common[0]:.6g}, so that plant '
            'mode cannot be moved by feedback and the Diophantine equation has no solution.'
        )
    common = common_roots(A, B_plus, tol=coprime_tol)
    if common:
        raise RstDesignError(
            f'The plant has a pole-zero cancellation at {common[0]:.6g} (A and B+ share it); '
            'remove it from the plant model first.'
        )

    notes = []
    Bm_prime, exact = poly_div_exact(Bm, B_minus)
    if not exact:
        if not absorb_zeros:
            raise RstDesignError(
                "The uncancelled plant zeros B- = "
                f"{np.roots(B_minus) if degree(B_minus) else '[]'} are not zeros of the "
                "reference model numerator Bm, so the closed loop cannot equal Bm/Am; "
                "cancel those zeros, put them in Bm, or pass absorb_zeros=True."
            )
        Bm = np.polymul(Bm, B_minus / np.polyval(B_minus, 0.0))
        Bm_prime = poly_div_exact(Bm, B_minus)[0]
        notes.append(
            'Bm multiplied by B-(s)/B-(0): the uncancelled zeros stay in the closed loop.'
        )

    C = np.polymul(Am, Ao)
    try:
        R_prime, S = solve_diophantine(A, B_minus, C)
    except DiophantineError as exc:
        raise RstDesignError(f"Diophantine equation A R' + B- S = Am Ao: {exc}") from exc
    R = trim(np.polymul(R_prime, B_plus))
    S = trim(S, 1e-13)
    T = trim(np.polymul(Ao, Bm_prime))
    if abs(R[0]) < 1e-12:
        raise RstDesignError(
            'The computed R has a zero leading coefficient; the controller is not proper.'
        )
    if degree(S) > degree(R):
        raise RstDesignError(
            f'Non-causal controller: deg S = {degree(S)} > deg R = {degree(R)}; raise the '
            'degree of the observer polynomial Ao (deg Ao >= deg A - deg B+ - 1).'
        )
    if degree(T) > degree(R):
        raise RstDesignError(
            f'Non-causal controller: deg T = {degree(T)} > deg R = {degree(R)}; the reference '
            'model has too small a pole excess (need deg Am - deg Bm >= deg A - deg B).'
        )

    design = RstDesign(R=R, S=S, T=T, Ao=Ao, B_plus=B_plus, B_minus=B_minus, A=A, B=B,
                       Am=Am, Bm=trim(Bm), R_prime=R_prime,
                       closed_loop_poles=np.array([]), cancelled_zeros=canc, notes=notes)
    num, den = design.closed_loop()
    den_expected = np.polymul(np.polymul(Am, Ao), B_plus)
    num_expected = np.polymul(np.polymul(Bm, Ao), B_plus)
    e_den = coeff_rel_error(den, den_expected)
    e_num = coeff_rel_error(num, num_expected)
    if e_den > verify_rtol or e_num > verify_rtol:
        raise RstDesignError(
            'The closed loop B T/(A R + B S) does not equal the model Bm/Am after cancelling '
            f'Ao B+ (relative coefficient errors {e_num:.1e} numerator, {e_den:.1e} '
            'denominator); the problem is numerically ill-conditioned.'
        )
    design.closed_loop_poles = np.roots(den)
    return design
