r"""Fixed-rate discrete implementation of a continuous RST controller with anti-windup.

Control law (continuous design, s-domain polynomials, u steer [rad], y, u_c [m]):

.. math:: R u = T u_c - S y .

Anti-windup (Astrom & Wittenmark, *Computer-Controlled Systems*, Sec. 9.4): with a monic,
Hurwitz polynomial ``F`` of the same degree as ``R`` the law is rewritten as

.. math:: F u = T u_c - S y + (F - R) v, \qquad v = \mathrm{sat}(u),

so the controller states are driven by the steer ``v`` that is actually applied: in the linear
range ``v = u`` and this is exactly ``R u = T u_c - S y``; in saturation the states evolve through
the stable filter ``1/F`` and stay consistent with what the plant received (without it the
double-integrator plant overshoots badly on leaving saturation). The linear law is discretised
by zero-order hold at the fixed rate (1 kHz) and the anti-windup added in observer form. Bad
inputs never raise and never give a non-finite steer (:class:`InputGuard`). Choice of ``F``:
:func:`anti_windup_polynomial`; discretisation: :class:`DiscreteRstController`.
"""
from __future__ import annotations

import math
from typing import Any
from dataclasses import dataclass

import numpy as np
from irs_common.input_checks import abs_limit_problem
from irs_models.constants import STEER_LIMIT  # [rad] +-15 deg
from irs_models.zoh import zoh

from .polynomials import degree, is_hurwitz, poly_from_roots, require_polynomial, trim
from .rst_design import RstDesign

__all__ = ['ControlOutput', 'DiscreteRstController', 'InputGuard', 'anti_windup_polynomial',
           'observable_canonical_miso', 'STATE_RUNNING', 'STATE_INVALID',
           'DEFAULT_INPUT_LIMIT', 'ANTI_WINDUP_MODES', 'anti_windup_mode']

#: Default bound on |measurement| and |reference| [m] (the belt is 4 x 8 ft: |y| < 0.61 m).
DEFAULT_INPUT_LIMIT = 2.0
#: Anti-windup choices of both lateral controllers (the paper describes none, Sec. 5):
#: ``'back_calculation'`` -- the controller state is driven by the steer actually applied
#: (RST: the Astrom-Wittenmark polynomial form ``F u = T u_c - S y + (F - R) v`` above, of
#: which PI back-calculation with tracking time ``T_t`` is the first-order case ``F = s + 1/T_t``);
#: ``'clip'`` -- no anti-windup: the linear law runs on and only its output is clipped
#: (the integrating states keep integrating while the steer is at its limit).
ANTI_WINDUP_MODES = ('back_calculation', 'clip')


def anti_windup_mode(value) -> str:
    """Normalise an anti-windup choice: one of :data:`ANTI_WINDUP_MODES`, or a bool (an alias:
    ``True`` = ``'back_calculation'``, ``False`` = ``'clip'``); ``ValueError`` else.
    """
    if isinstance(value, bool):
        return ANTI_WINDUP_MODES[0] if value else 'clip'
    if value in ANTI_WINDUP_MODES:
        return value
    raise ValueError(f"anti_windup must be one of {', '.join(ANTI_WINDUP_MODES)}; got {value!r}")


#: ``ControlOutput.state``: the loop was closed this step.
STATE_RUNNING = 'RUNNING'
#: ``ControlOutput.state``: no valid feedback (or a non-finite state): zero steer, state reset.
STATE_INVALID = 'INVALID'


@dataclass(init=False)
class ControlOutput:
    """One controller step.

    Attributes
    ----------
    u_unsat : float
        Steer the linear law asks for [rad] (0 when the step was INVALID).
    u_sat : float
        Steer actually commanded, clipped to ``[u_min, u_max]`` [rad]; always finite.
    saturated : bool
        True when clipping was active.
    state : str
        :data:`STATE_RUNNING` (loop closed) or :data:`STATE_INVALID` (zero steer, see the module
        docstring's bad-input rule).
    reason : str
        Empty when every input was valid, else one sentence per problem (a held reference is
        reported with ``state = RUNNING``).
    reference : float
        The reference the step used [m] (the held one when the given one was invalid).
    reset : bool
        True when this step reset the controller state.
    """

    u_unsat: float
    u_sat: float
    saturated: bool
    state: str = STATE_RUNNING
    reason: str = ''
    reference: float = 0.0
    reset: bool = False

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, u_unsat: float, u_sat: float, saturated: bool, state: str = STATE_RUNNING,
                       reason: str = '', reference: float = 0.0, reset: bool = False) -> None:
        self.u_unsat = u_unsat
        self.u_sat = u_sat
        self.saturated = saturated
        self.state = state
        self.reason = reason
        self.reference = reference
        self.reset = reset

    @property
    def valid(self) -> bool:
        """True when the loop was closed this step (``state == STATE_RUNNING``)."""
        return self.state == STATE_RUNNING


class InputGuard:
    """The bad-input rule shared by the lateral controllers.

    ``step(reference, measurement)`` never raises for bad data and always returns a finite steer
    within ``[u_min, u_max]``; :attr:`ControlOutput.state` and :attr:`ControlOutput.reason` say
    what happened. With ``L_y = measurement_limit`` and ``L_r = reference_limit`` [m] (default 2 m
    each: the belt is 1.22 m wide, so no genuine lateral position or set point comes near):

    1. **Reference** ``u_c`` NaN, +-inf, not a number or ``|u_c| > L_r``: the step uses the *last
       valid reference* (``initial_reference``, default 0 m, before any valid one) and the
       controller keeps running, its state untouched by the bad value; the output says ``reason =
       "reference ... holding the last valid reference ..."`` with ``state = RUNNING``. A glitch in
       the reference stream therefore neither resets the loop nor reaches the plant.
    2. **Measurement** ``y`` NaN, +-inf, not a number or ``|y| > L_y``: no valid feedback, so zero
       steer (0 rad clipped into the limits) this step, the controller state is **reset** (rest, as
       after :meth:`reset`) and ``state = INVALID``, ``reset = True``. The next valid measurement
       starts from rest: from then on the output equals that of a freshly built controller fed the
       same inputs (the recovery the unit tests check).
    3. **State**: should the next state or the output ever be non-finite (only possible with limits
       raised towards ``inf``), the state is reset, the step answers zero steer with ``state =
       INVALID``, ``reset = True`` and a reason; nothing non-finite is ever stored.

    For valid inputs the arithmetic is exactly the unchecked law above (bit-identical results). The
    stale case (no measurement for a while) is the node's: it calls :meth:`reset` and reports
    STALE; the controller has no clock.

    Subclasses call :meth:`_init_guard` in ``__init__``, define ``reset()``, ``u_min``, ``u_max``
    and use :meth:`_screen` / :meth:`_invalid` in ``step``.
    """

    u_min: float    # [rad] the steer limits, set by the subclass
    u_max: float

    def reset(self) -> None:
        """Return the controller to rest (the subclass's)."""
        raise NotImplementedError

    def step(self, reference: Any, measurement: Any) -> ControlOutput:
        """One sample under the bad-input rule (the subclass's)."""
        raise NotImplementedError

    def _init_guard(self, measurement_limit: Any, reference_limit: Any,
                    initial_reference: Any) -> None:
        for name, v in (('measurement_limit', measurement_limit),
                        ('reference_limit', reference_limit)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
                raise ValueError(f'{name} must be a positive bound in m (inf allowed); got {v!r}.')
        if abs_limit_problem('initial_reference', initial_reference, reference_limit) is not None:
            raise ValueError(f'initial_reference must be a finite reference in m within '
                             f'+-reference_limit = {reference_limit}; got {initial_reference!r}.')
        self.measurement_limit = float(measurement_limit)
        self.reference_limit = float(reference_limit)
        self._held_reference = float(initial_reference)

    @property
    def held_reference(self) -> float:
        """The last valid reference [m] (used in place of an invalid one)."""
        return self._held_reference

    def _screen(self, reference, measurement):
        """``(reference to use, reference problem or None, measurement problem or None)``."""
        ref_problem = abs_limit_problem('reference', reference, self.reference_limit, 'm')
        if ref_problem is None:
            ref = self._held_reference = float(reference)
        else:
            ref = self._held_reference
            ref_problem += f'; holding the last valid reference {ref:.6g} m'
        meas_problem = abs_limit_problem('measurement', measurement, self.measurement_limit, 'm')
        return ref, ref_problem, meas_problem

    def _invalid(self, ref: float, reason: str) -> ControlOutput:
        """Reset the state and answer zero steer (clipped into the limits), INVALID."""
        self.reset()
        zero = min(max(0.0, self.u_min), self.u_max)
        return ControlOutput(u_unsat=zero, u_sat=zero, saturated=False, state=STATE_INVALID,
                             reason=reason, reference=ref, reset=True)

    def _measurement_invalid(self, ref: float, ref_problem, meas_problem: str) -> ControlOutput:
        reason = f'{meas_problem}: no valid feedback, zero steer and controller reset'
        return self._invalid(ref, reason if ref_problem is None else f'{reason}; {ref_problem}')

    def step_checked(self, reference: Any, measurement: Any) -> ControlOutput:
        """The node's entry point: :meth:`step` (which applies the bad-input rule itself).

        Returns the :class:`ControlOutput` with ``state`` (RUNNING/INVALID), ``reason`` (empty
        when all inputs were valid) and ``reset``; the node publishes ``u_sat`` and maps
        ``state`` onto ``LateralControllerStatus.STATE_*``.
        """
        return self.step(reference, measurement)


def anti_windup_polynomial(design: RstDesign) -> np.ndarray:
    """Default anti-windup polynomial ``F = Ao (s + w_f)^k``: monic, Hurwitz, ``deg F = deg R``.

    ``A_o`` alone has lower degree than ``R`` (2 < 4), so the default is ``F = A_o (s + w_f)^k``,
    ``k = deg R - deg A_o`` and ``w_f`` the largest root magnitude of ``A_m`` (30 rad/s for Eq.
    21). The "natural" ``F = A_o B^+`` is not used: its slow roots -2.4 and -4.8 make the saturated
    controller sluggish and a 0.3 m step overshoots 37 % (worse than no anti-windup, 30 %), while
    ``A_o (s+30)^2`` gives 1.2 % (docs/control_design.md).
    """
    Ao = trim(design.Ao)
    k = degree(design.R) - degree(Ao)
    if k < 0:
        raise ValueError(
            f'Ao has degree {degree(Ao)} > deg R = {degree(design.R)}; pass an explicit '
            'anti-windup polynomial of degree deg R.'
        )
    wf = float(np.max(np.abs(np.roots(design.Am)))) if degree(design.Am) > 0 else 1.0
    F = np.polymul(Ao, poly_from_roots([-wf] * k))
    return F


def observable_canonical_miso(F, numerators):
    """State space of ``y = sum_i N_i/F u_i`` (common monic denominator ``F``).

    Parameters
    ----------
    F : array_like
        Monic denominator of degree n >= 1.
    numerators : sequence of array_like
        Numerators with ``deg N_i <= n``.

    Returns
    -------
    A (n, n), B (n, m), C (1, n), D (1, m) : numpy.ndarray
    """
    F = trim(F)
    n = F.size - 1
    if n < 1 or abs(F[0] - 1.0) > 1e-12:
        raise ValueError('observable_canonical_miso expected a monic denominator of degree >= 1.')
    A = np.zeros((n, n))
    A[:, 0] = -F[1:]
    A[: n - 1, 1:] = np.eye(n - 1)
    m = len(numerators)
    B = np.zeros((n, m))
    D = np.zeros((1, m))
    for i, N in enumerate(numerators):
        N = trim(N)
        if N.size > n + 1:
            raise ValueError(
                f'Numerator {i} has degree {N.size - 1} > {n}: improper transfer function.'
            )
        N = np.pad(N, (n + 1 - N.size, 0))
        D[0, i] = N[0]
        B[:, i] = N[1:] - N[0] * F[1:]
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    return A, B, C, D


def _ackermann_observer(A, c, poles):
    """Gain ``l`` with ``eig(A - l c^T) = poles`` (single output, Ackermann's formula)."""
    n = A.shape[0]
    obs = np.vstack([c @ np.linalg.matrix_power(A, k) for k in range(n)])
    p = np.real(np.poly(poles))
    pA = sum(coef * np.linalg.matrix_power(A, n - k) for k, coef in enumerate(p))
    e = np.zeros(n)
    e[-1] = 1.0
    return pA @ np.linalg.solve(obs, e)


class DiscreteRstController(InputGuard):
    """Discrete-time RST controller with steer saturation and anti-windup.

    Realisation and discretisation: the *linear* law ``u = [T/R, -S/R] [u_c, y]`` is realised as an
    observable-canonical state space (denominator ``R``) and discretised with **zero-order hold**
    (exact matrix exponential) to ``(Phi, Gamma, C, D)``. Anti-windup is then added in the
    equivalent observer form (Astrom & Wittenmark, Computer-Controlled Systems, "anti-windup in
    state-space/observer form")::

        u_k = C x_k + D w_k,   v_k = sat(u_k),   x_{k+1} = Phi x_k + Gamma w_k + L (v_k - u_k)

    whose characteristic polynomial from ``v`` is ``F_d(z) = prod(z - exp(f_i dt))``, the ZOH image
    of ``F``: this is the discrete ``F_d u = T_d u_c - S_d y + (F_d - R_d) v``. ``L`` is placed
    with Ackermann's formula on the delta-operator matrix ``(Phi - I)/dt`` (well conditioned at 1
    kHz). In the linear range ``v = u`` and the controller is *exactly* the ZOH discretisation of
    ``[T/R, -S/R]`` whatever ``F`` is. ZOH rather than Tustin because the steer really is held
    between samples, ZOH keeps the controller's direct term equal to the continuous high-frequency
    gain ``t_0/r_0`` (no extra feed-through from Tustin's warping), and the error it makes --
    treating the sampled ``y`` as held, a delay of about ``dt/2`` -- costs ``w dt/2 = 0.9 deg`` of
    phase at 30 rad/s at 1 kHz; the unit test measures the resulting step-response error against
    ``Bm/Am`` (< 1 %).

    Parameters
    ----------
    design : RstDesign
        Continuous design (``R`` monic).
    dt : float
        Sample time [s] (default 1 kHz).
    u_min, u_max : float
        Steer limits [rad] (default +-0.2618 rad = +-15 deg).
    anti_windup : str or bool
        ``'back_calculation'`` (default; ``True``): the polynomial form with ``F`` above;
        ``'clip'`` (``False``): the controller states are driven by the unsaturated ``u`` (plain
        ``R u = T u_c - S y`` followed by a clip). See :data:`ANTI_WINDUP_MODES`.
    aw_poly : array_like, optional
        Anti-windup polynomial ``F`` (monic, Hurwitz, degree ``deg R``); default
        :func:`anti_windup_polynomial`.
    measurement_limit, reference_limit : float
        Bounds on ``|y|`` and ``|u_c|`` [m] beyond which an input is invalid (bad-input
        rule: :class:`InputGuard`); default 2 m; ``inf`` allowed.
    initial_reference : float
        Reference held [m] until a valid one arrives (default 0).
    """

    def __init__(self, design: RstDesign, dt: float = 1e-3, u_min: float = -STEER_LIMIT,
                 u_max: float = STEER_LIMIT, anti_windup='back_calculation', aw_poly=None,
                 measurement_limit: Any = DEFAULT_INPUT_LIMIT,
                 reference_limit: Any = DEFAULT_INPUT_LIMIT, initial_reference: Any = 0.0):
        if not dt > 0:
            raise ValueError(f'dt must be a positive sample time in seconds; got {dt}.')
        if not (math.isfinite(u_min) and math.isfinite(u_max) and u_min < u_max):
            raise ValueError(
                f'Expected finite steer limits u_min < u_max; got {u_min} and {u_max}.'
            )
        self._init_guard(measurement_limit, reference_limit, initial_reference)
        R = trim(design.R)
        if abs(R[0]) < 1e-12:
            raise ValueError('design.R has a zero leading coefficient.')
        # Normalise so R is monic (R u = T uc - S y is invariant to scaling all three).
        r0 = R[0]
        R, S, T = R / r0, trim(design.S) / r0, trim(design.T) / r0
        F = require_polynomial('aw_poly', aw_poly) if aw_poly is not None \
            else anti_windup_polynomial(design)
        if degree(F) != degree(R) or abs(F[0] - 1.0) > 1e-12 or not is_hurwitz(F):
            raise ValueError(
                f'The anti-windup polynomial must be monic, Hurwitz and of degree deg R = '
                f'{degree(R)}; got {F}.'
            )
        self.design = design
        self.dt = float(dt)
        self.u_min, self.u_max = float(u_min), float(u_max)
        self.anti_windup_mode = anti_windup_mode(anti_windup)
        self.anti_windup = self.anti_windup_mode != 'clip'
        self.F = F
        Ac, Bc, Cc, Dc = observable_canonical_miso(R, [T, -S])
        self._Ad, self._Bd = zoh(Ac, Bc, self.dt)
        self._C = Cc[0]
        self._D = Dc[0]
        n = Ac.shape[0]
        if self.anti_windup:
            zf = np.exp(np.roots(F) * self.dt)
            self._L = _ackermann_observer((self._Ad - np.eye(n)) / self.dt, self._C,
                                          (zf - 1.0) / self.dt) * self.dt
            eig = np.linalg.eigvals(self._Ad - np.outer(self._L, self._C))
            if not np.all(np.abs(eig) < 1.0):
                raise ValueError(
                    'Anti-windup gain placement failed (saturated controller unstable).'
                )
        else:
            self._L = np.zeros(n)
        # The per-step law runs on plain floats (numpy on a 4-state vector costs more than the
        # arithmetic): the rows of Phi, Gamma, and C, D, L as tuples, the state as a list.
        self._rows = tuple((tuple(float(a) for a in self._Ad[i]), float(self._Bd[i, 0]),
                            float(self._Bd[i, 1]), float(self._L[i])) for i in range(n))
        self._Ct = tuple(float(c) for c in self._C)
        self._D0, self._D1 = float(self._D[0]), float(self._D[1])
        self._x = [0.0] * n

    def reset(self) -> None:
        """Zero the controller state."""
        self._x = [0.0] * len(self._x)

    def linear_state_space(self):
        """``(Ad, Bd, Cd, Dd)`` of the linear (unsaturated) law from the measurement y [m] to
        the steer u [rad] at the sample time ``dt`` (``u = -S/R y``, ZOH), for the design check
        (:mod:`.design_check`).
        """
        return (self._Ad.copy(), self._Bd[:, 1:2].copy(), self._C.reshape(1, -1).copy(),
                np.array([[self._D[1]]]))

    @property
    def state(self) -> np.ndarray:
        """Copy of the internal controller state."""
        return np.array(self._x, dtype=float)

    def step(self, reference: Any, measurement: Any) -> ControlOutput:
        """Advance one sample: compute the steer for ``u_c = reference``, ``y = measurement``.

        Bad inputs follow the rule of :class:`InputGuard` (invalid reference: last valid one
        held; invalid measurement: zero steer and reset; non-finite state: reset); never raises
        for bad data, the steer is always finite and within ``[u_min, u_max]``.

        Parameters
        ----------
        reference : float
            Lateral position set-point u_c [m].
        measurement : float
            Measured lateral sensor displacement y_s [m].

        Returns
        -------
        ControlOutput
        """
        ref, ref_problem, meas_problem = self._screen(reference, measurement)
        if meas_problem is not None:
            return self._measurement_invalid(ref, ref_problem, meas_problem)
        x = self._x
        y = float(measurement)
        u = self._D0 * ref + self._D1 * y
        for c, xi in zip(self._Ct, x):
            u += c * xi
        u_sat = min(max(u, self.u_min), self.u_max)
        e = u_sat - u
        x_next = []
        for row, b0, b1, li in self._rows:
            acc = b0 * ref + b1 * y + li * e
            for a, xi in zip(row, x):
                acc += a * xi
            x_next.append(acc)
        if not (math.isfinite(u) and all(map(math.isfinite, x_next))):
            return self._invalid(ref, f'controller state became non-finite (u = {u!r}): state '
                                      'reset, zero steer')
        self._x = x_next
        return ControlOutput(u_unsat=u, u_sat=u_sat, saturated=(u_sat != u),
                             state=STATE_RUNNING, reason=ref_problem or '', reference=ref,
                             reset=False)
