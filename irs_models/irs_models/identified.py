"""The paper's identified lateral plant (Eq. 6) without the steering actuator.

Paper Eq. 6 (vehicle at U = 1.2 m/s, sensor ds = 0.33 m ahead of the c.g.), from the front steer
*command* to the sensor-point lateral displacement::

    P(s) = b0 (s + 2.4)(s + 4.8) / ( s^2 (s + 8)(s + 20)(s + 29) )

The -29 rad/s pole is the 4.6 Hz steering-actuator lag (2 pi 4.6 = 28.9 rad/s), which the
simulation reproduces with :mod:`irs_vehicle_sim.actuator` (unity DC gain, ``29/(s+29)``).  The
plant from the **achieved** front steer angle delta [rad] to y_s [m] is therefore::

    G(s) = K (s + 2.4)(s + 4.8) / ( s^2 (s + 8)(s + 20) ),    K = b0 / 29

``b0 = 363.394`` (:data:`irs_models.constants.PAPER_PLANT_GAIN`, derived in
:func:`identified_plant`), so ``K = 12.53 m/s^2/rad``. It exists as the paper's plant for the
rig and for the controller designs; it is LTI at the identification speed U. Eq. 6 has no yaw
or sideslip state, so the heading, yaw rate and c.g. position the rig derives from it are not
physical (:class:`IdentifiedPlant`); only y_s, v_s and a_s are.
"""

from __future__ import annotations

import math
from typing import Any
from dataclasses import dataclass

import numpy as np

from .constants import (IDENTIFICATION_SPEED, PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN,
                        PAPER_VEHICLE_POLES, PAPER_ZEROS, SENSOR_DISTANCE)
from .lateral_plant import ZohSteps

__all__ = ['IdentifiedParams', 'IdentifiedPlant', 'identified_matrices', 'identified_plant',
           'quadratic_roots', 'bicycle_realisation']


def identified_plant(include_actuator: bool = True, actuator_pole: float = PAPER_ACTUATOR_POLE,
                     gain: float = PAPER_PLANT_GAIN):
    """Identified plant ``B/A`` of Eq. 6 (steer [rad] -> y_s [m]), highest power first.

    Parameters
    ----------
    include_actuator : bool
        True: full identified plant with the actuator pole at ``-actuator_pole``.
        False: vehicle only, i.e. the actuator lag ``p/(s + p)`` (unit DC gain) replaced by 1:
        ``G_veh = G (s + p)/p``, so ``B_veh = (gain/p)(s+2.4)(s+4.8)`` and both plants have
        the same low-frequency behaviour ``y_s ~ gain*11.52/(160 p) / s^2 = 0.902/s^2``.
    actuator_pole : float
        Actuator pole magnitude p [rad/s] (> 0).
    gain : float
        High-frequency gain ``b0`` of the full plant (with actuator) [m rad^-1 s^-3].

    Returns
    -------
    B, A : numpy.ndarray
        ``B = gain (s+2.4)(s+4.8)``, ``A = s^2 (s+8)(s+20)(s+p)`` (with actuator) or
        ``B = (gain/p)(s+2.4)(s+4.8)``, ``A = s^2 (s+8)(s+20)`` (without).

    Notes
    -----
    Gain derivation: the high-frequency gain of the *full* plant is b0 = 2308 / 6.351 = 363.4
    (reference-model numerator 2308 of Eq. 21 over the OCR'd leading coefficient of T, Eq. 24),
    :data:`irs_models.constants.PAPER_PLANT_GAIN` = 363.394.  Because the actuator block is the
    unity-DC-gain lag ``29/(s+29)``, the actuator-free gain is ``K = b0 / 29 = 12.53 m/s^2/rad``.
    (Sanity check: with K = 363.4 the paper's PI loop Kp = 5, Ki = 3, which the paper ran on the
    car, would be unstable; with K = 12.53 it is stable with about 34 deg phase margin.)
    """
    if not (np.isfinite(actuator_pole) and actuator_pole > 0):
        raise ValueError('actuator_pole must be a positive finite magnitude in rad/s; '
                         f'got {actuator_pole}.')
    if not (np.isfinite(gain) and gain != 0):
        raise ValueError('gain must be a finite non-zero plant gain b0 in m rad^-1 s^-3; '
                         f'got {gain}.')
    poles = list(PAPER_VEHICLE_POLES)
    if include_actuator:
        poles.append(-float(actuator_pole))
    else:
        gain = gain / float(actuator_pole)
    # real roots: np.poly gives the real coefficients (numpy.poly is the product of (s - r_i))
    return (gain * np.real(np.poly(np.asarray(PAPER_ZEROS, dtype=complex))),
            np.real(np.poly(np.asarray(poles, dtype=complex))))


def _pair(name: str, values) -> tuple:
    """Two roots [rad/s] as a tuple: both real, or one complex-conjugate pair (else ValueError)."""
    try:
        roots = tuple(complex(v) for v in values)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be two roots in rad/s (real, or a complex-conjugate '
                         f'pair); got {values!r}') from None
    if len(roots) != 2:
        raise ValueError(f'{name} must hold exactly two roots in rad/s (real, or a '
                         f'complex-conjugate pair); got {len(roots)}')
    if not all(math.isfinite(r.real) and math.isfinite(r.imag) for r in roots):
        raise ValueError(f'{name} must be finite values in rad/s; got {values!r}')
    a, b = roots
    tol = 1e-9 * max(1.0, abs(a), abs(b))
    if (abs(a.imag) > tol or abs(b.imag) > tol) and abs(a - b.conjugate()) > tol:
        raise ValueError(f'{name} must be two real roots or a complex-conjugate pair in rad/s; '
                         f'got {a} and {b}')
    return roots


def quadratic_roots(a1: float, a0: float) -> tuple:
    """Roots [rad/s] of ``s^2 + a1 s + a0`` (a1 [1/s], a0 [1/s^2]): a real pair (float) or a
    complex-conjugate pair (complex), the form :class:`IdentifiedParams` takes.
    """
    if not (math.isfinite(a1) and math.isfinite(a0)):
        raise ValueError(f'quadratic coefficients must be finite; got {a1!r}, {a0!r}')
    r = np.roots([1.0, float(a1), float(a0)])
    if np.all(np.abs(r.imag) == 0.0):
        return tuple(sorted(float(x) for x in r.real))
    return (complex(r[0].real, abs(r[0].imag)), complex(r[0].real, -abs(r[0].imag)))


@dataclass
class IdentifiedParams:
    """Parameters of the identified plant G(s) (Eq. 6 without the actuator).

    Attributes
    ----------
    gain : float or None
        K [m/s^2 per rad], high-frequency gain of y_s'' / delta.  None -> b0 / 29
        (:data:`~irs_models.constants.PAPER_PLANT_GAIN` / the actuator pole).
    zeros : tuple
        The two zeros of G [rad/s]: two real values (default (-2.4, -4.8), Eq. 6) or one
        complex-conjugate pair, e.g. ``(-18.8+8.6j, -18.8-8.6j)`` (the complex-zero candidate
        for the printed R, S, T; :mod:`irs_control.paper_inverse`).  Only the quadratic
        ``s^2 + n1 s + n0 = (s - z1)(s - z2)`` enters the model, so any real or conjugate pair
        works (:func:`quadratic_roots` turns coefficients into this form).
    poles : tuple
        The two non-origin poles of G [rad/s], real or a complex-conjugate pair, in the open
        left half plane (default (-8, -20)).  Two poles at the origin are implied.
    speed : float
        Identification speed U [m/s], used for psi = v_s / U.  Default 1.2.
    ds : float
        Sensor distance ahead of the c.g. [m].  Default 0.33.
    heading : {'kinematic', 'bicycle'}
        How heading, yaw rate and c.g. lateral velocity are formed. ``'kinematic'`` (default):
        ``psi = v_s / U``, unphysical (IdentifiedPlant).  ``'bicycle'``: from the bicycle
        that has this G(s) (:func:`bicycle_realisation`; a fifth state psi), physical; refused
        with a sentence when no bicycle realisation exists (Eq. 6 has none).
    """

    gain: float | None = None
    zeros: tuple = (-2.4, -4.8)
    poles: tuple = (-8.0, -20.0)
    speed: float = IDENTIFICATION_SPEED
    ds: float = SENSOR_DISTANCE
    heading: str = 'kinematic'

    def resolved_gain(self) -> float:
        """K [m/s^2/rad]: ``gain`` or b0 / 29 from the paper."""
        return (
            float(self.gain) if self.gain is not None else PAPER_PLANT_GAIN / PAPER_ACTUATOR_POLE
        )

    def numerator(self) -> tuple:
        """``(n1, n0)`` of ``s^2 + n1 s + n0 = (s - z1)(s - z2)`` [1/s, 1/s^2] (real)."""
        z1, z2 = _pair('zeros', self.zeros)
        return float(-(z1 + z2).real), float((z1 * z2).real)

    def denominator(self) -> tuple:
        """``(d1, d0)`` of ``s^2 + d1 s + d0 = (s - p1)(s - p2)`` [1/s, 1/s^2] (real)."""
        p1, p2 = _pair('poles', self.poles)
        return float(-(p1 + p2).real), float((p1 * p2).real)

    def validate(self) -> None:
        _pair('zeros', self.zeros)
        if not all(p.real < 0.0 for p in _pair('poles', self.poles)):
            raise ValueError('poles must lie in the open left half plane (negative real parts, '
                             f'rad/s; the two integrators are implied); got {self.poles!r}')
        if not (math.isfinite(self.resolved_gain()) and self.resolved_gain() > 0.0):
            raise ValueError(
                f'gain must be a positive finite value in m/s^2/rad, got {self.gain!r}'
            )
        if not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError(f'speed must be a positive speed in m/s, got {self.speed!r}')
        if not (math.isfinite(self.ds) and self.ds >= 0.0):
            raise ValueError(f'ds must be a non-negative distance in m, got {self.ds!r}')
        if self.heading not in ('kinematic', 'bicycle'):
            raise ValueError(f"heading must be 'kinematic' or 'bicycle', got {self.heading!r}")


def identified_matrices(params: IdentifiedParams | None = None):
    """Continuous realisation (A, B, C, D) of G(s), states [y_s, v_s, z1, z2], input delta [rad],
    output y_s [m].  Also returns the acceleration row (Ca, Da) with a_s = Ca x + Da delta.

    Returns
    -------
    A, B, C, D, Ca, Da : numpy.ndarray

    Notes
    -----
    Realisation (states chosen so that y_s and its rate are states)::

        x = [y_s, v_s, z1, z2]           v_s = dy_s/dt [m/s]
        z1' = z2,   z2' = -160 z1 - 28 z2 + delta        (denominator (s+8)(s+20) = s^2+28s+160)
        v_s' = a_s = K (delta - 148.48 z1 - 20.8 z2)
                     (numerator/denominator - 1 = (-20.8 s - 148.48)/(...))
        y_s' = v_s

    so ``a_s / delta = K (s^2 + 7.2 s + 11.52) / (s^2 + 28 s + 160)``.  Discretised exactly (ZOH on
    delta) by ``scipy.signal.cont2discrete`` (the matrix exponential of ``[[A, B], [0, 0]] dt``).
    :func:`identified_plant` gives the same plant (with or without the actuator) as polynomials.
    """
    p = params if params is not None else IdentifiedParams()
    p.validate()
    K = p.resolved_gain()
    n1, n0 = p.numerator()                    # s^2 + n1 s + n0 (real or complex zeros)
    d1, d0 = p.denominator()                  # s^2 + d1 s + d0 (real or complex poles)
    # a_s = K [1 + ((n1-d1) s + (n0-d0)) / (s^2 + d1 s + d0)] delta
    Ca = np.array([[0.0, 0.0, K * (n0 - d0), K * (n1 - d1)]])
    Da = np.array([[K]])
    A = np.zeros((4, 4))
    A[0, 1] = 1.0
    A[1, :] = Ca[0]
    A[2, 3] = 1.0
    A[3, 2] = -d0
    A[3, 3] = -d1
    B = np.array([[0.0], [K], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0, 0.0]])
    D = np.zeros((1, 1))
    return A, B, C, D, Ca, Da


#: |x| in which the error-free product below is exact (far from overflow and underflow)
_EXACT_LOW, _EXACT_HIGH = 2.0 ** -400, 2.0 ** 400
_SPLIT = 134217729.0        # 2^27 + 1, Veltkamp's splitting constant for 53-bit floats


def fma(a: float, b: float, c: float) -> float:
    """``a b + c`` rounded once (a fused multiply-add), for ``2^-400 < |a|, |b| < 2^400``.

    Python 3.11 has no ``math.fma``. Dekker's product gives ``a b = p + e`` exactly (``p`` the
    rounded product, ``e`` its error, from Veltkamp's split of each factor into 26- and 27-bit
    halves), and ``math.fsum`` rounds the exact sum ``p + e + c`` once (Shewchuk's algorithm,
    correctly rounded). Outside that range the split can overflow or ``e`` underflow.
    """
    p = a * b
    t = _SPLIT * a
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = _SPLIT * b
    b_hi = t - (t - b)
    b_lo = b - b_hi
    e = ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return math.fsum((p, e, c))


def _plain_dot(c2: float, x2: float, c3: float, x3: float) -> float:
    return c2 * x2 + c3 * x3


def _fused_dot(c2: float, x2: float, c3: float, x3: float) -> float:
    return fma(c3, x3, c2 * x2)


def numpy_dot_form(ca: np.ndarray):
    """The float form of numpy's ``ca @ x`` for ``ca = [0, 0, c2, c3]`` on this machine, or None.

    OpenBLAS kernels differ: ``Haswell`` sums ``c2 x2 + c3 x3``, ``SkylakeX`` fuses the second
    product into the sum, ``fma(c3, x3, c2 x2)`` (measured on 20,000 random states each,
    2026-12-05). 64 probe states on which the two forms differ decide which one numpy computes
    here; None (use numpy) if ``ca`` has another shape, or numpy equals neither form on them all.
    """
    ca = np.asarray(ca, dtype=float)
    if ca.shape != (4,) or ca[0] != 0.0 or ca[1] != 0.0:
        return None
    c2, c3 = float(ca[2]), float(ca[3])
    if not (_EXACT_LOW < abs(c2) < _EXACT_HIGH and _EXACT_LOW < abs(c3) < _EXACT_HIGH):
        return None
    rng = np.random.default_rng(20261205)
    probes: list = []
    while len(probes) < 64:
        x = rng.uniform(-1.0, 1.0, 4) * 10.0 ** rng.uniform(-6, 0, 4)
        if _plain_dot(c2, x[2], c3, x[3]) != _fused_dot(c2, x[2], c3, x[3]):
            probes.append(x)
    for form in (_plain_dot, _fused_dot):
        if all(float(ca @ x) == form(c2, float(x[2]), c3, float(x[3])) for x in probes):
            return form
    return None


class IdentifiedPlant(ZohSteps):
    """Discrete (exact ZOH) identified plant implementing the ``LateralPlant`` interface.

    Heading and yaw rate are not physical. Eq. 6 is an input-output model (steer -> y_s); it has no
    yaw or sideslip state.  The pose the rig publishes for it (``ground_truth/odom``, the car drawn
    on the belt) takes the heading kinematically from the sensor-point lateral velocity, ``psi =
    v_s / U`` (small-angle), the yaw rate ``r = a_s / U``, zero body lateral velocity at the c.g.
    and ``y_cg = y_s - ds sin(psi)`` (conventions: ``y_s = y + ds sin psi``).  This ignores the
    sideslip ``v`` and the ``ds r`` term of ``v_s = v + U psi + ds r``: on the ``irs_2wd`` preset a
    5 deg steer doublet gives heading errors of 33 % (1 s per half) to 460 % (0.1 s per half) of
    the peak heading (159 % at 0.25 s).  So **heading, yaw rate and c.g. position from this plant
    are not physical**; only y_s (and v_s, a_s) are.  A physically consistent heading would need a
    bicycle realisation of G(s) (``num`` and ``den`` of Eq. 5 with some m, I_z, C_f, C_r, l_f, l_r
    at U and ds): for Eq. 6 none exists -- ``n1 / n0 = (l_r + ds) / U`` fixes l_r = 0.42 m, and no
    positive (m, I_z, C_f, C_r, l_f) then matches the poles (closest: 1 % off with l_f = 1.2 m);
    :func:`bicycle_realisation` checks a given plant, and ``heading='bicycle'``
    (:class:`IdentifiedPlant`) uses it when it exists.  Use ``plant: bicycle`` when heading or yaw
    rate matter.  The model is LTI at the identification speed U; it does not rescale with the
    actual car speed.

    ``step(delta_front, delta_rear, dt)`` ignores ``delta_rear`` (Eq. 6 is front-steer only).

    With ``heading='bicycle'`` the state gains psi (x[4]): for the bicycle of
    :func:`bicycle_realisation`, ``r / delta = (e1 s + e0) / (s^2 + d1 s + d0)`` with
    ``e1 = C_f l_f / I_z`` [1/s^2] and ``e0 = C_f C_r L / (m I_z U)`` [1/s^3], so with the
    realisation's ``z1 = delta / (s^2 + d1 s + d0)``, ``z2 = z1'``: ``r = e1 z2 + e0 z1``,
    ``psi' = r``, and the c.g. lateral velocity ``v = v_s - U psi - ds r`` (linear,
    ``v_s = v + U psi + ds r``).  y_s is unchanged (same G(s)).

    The state is kept as plain floats. A step is ``x <- Ad x + Bd_front delta``: with the
    kinematic heading (4 states) each row is summed as ``((a0 x0 + a2 x2) + (a1 x1 + a3 x3)) +
    b delta``, which is how numpy's OpenBLAS kernels ``Haswell`` and ``SkylakeX`` sum a 4 x 4
    matrix-vector product (no fused multiply-add), so the results are numpy's to the bit there
    and cost no numpy call; the 5-state bicycle heading steps through numpy (no sum of floats
    reproduces its 5 x 5 product). The kinematic yaw rate's ``Ca x`` is in floats too, in the
    form numpy's dot takes under the kernel this process runs (:func:`numpy_dot_form`).
    ``docs/performance.md`` ("Where the time goes") shows the check.
    """

    def __init__(self, params: IdentifiedParams | None = None):
        self.params = params if params is not None else IdentifiedParams()
        self.A, self.B, self.C, self.D, self.Ca, self.Da = identified_matrices(self.params)
        self._zoh_cache: dict = {}
        self.bicycle: Any = None
        if self.params.heading == 'bicycle':
            self.bicycle = bicycle_realisation(self.params)
            if self.bicycle is None:
                n1, n0 = self.params.numerator()
                raise ValueError(
                    "heading 'bicycle': this G(s) is not the transfer function of any bicycle "
                    f'at U = {self.params.speed} m/s, ds = {self.params.ds} m (zeros give '
                    f'l_r + ds = U n1/n0 = {self.params.speed * n1 / n0:.3g} m; see '
                    "irs_models.identified.bicycle_realisation); use heading 'kinematic' "
                    "or plant 'bicycle'")
            b = self.bicycle
            L = b['lf'] + b['lr']
            self._e1 = b['c_f'] * b['lf'] / b['yaw_inertia']
            self._e0 = b['c_f'] * b['c_r'] * L / (b['mass'] * b['yaw_inertia']
                                                  * self.params.speed)
            A = np.zeros((5, 5))
            A[:4, :4] = self.A
            A[4, 2], A[4, 3] = self._e0, self._e1
            self.A = A
            self.B = np.vstack([self.B, [[0.0]]])
            self.C = np.hstack([self.C, [[0.0]]])
        self._x = (0.0,) * self.A.shape[0]      # the state [y_s, v_s, z1, z2 (, psi)]
        self._delta = 0.0
        self._step_zoh: Any = None
        # the kinematic yaw rate's a_s = Ca x + Da delta with Ca = [0, 0, c2, c3]: in floats, in
        # the form numpy's dot takes on this machine (None: numpy's dot itself)
        self._ca = (float(self.Ca[0, 2]), float(self.Ca[0, 3]))
        self._da = float(self.Da[0, 0])
        self._ca_form: Any = numpy_dot_form(self.Ca[0]) if self.bicycle is None else None

    @property
    def x(self) -> np.ndarray:
        """The state ``[y_s, v_s, z1, z2]`` (and ``psi`` with the bicycle heading), a copy."""
        return np.array(self._x)

    def reset(self, y_s: float = 0.0) -> None:
        """Zero state with the sensor point at lateral position ``y_s`` [m], heading 0."""
        self._x = (float(y_s),) + (0.0,) * (len(self._x) - 1)
        self._delta = 0.0

    def step(self, delta_front: float, delta_rear: float = 0.0, dt: float = 1e-3) -> None:
        """Advance dt [s] with the achieved front steer ``delta_front`` [rad] held constant."""
        zoh: Any = self._step_zoh
        if zoh is None or zoh[0] != dt:   # Phi and the steer column of Gamma, per step size
            Ad, Bd = self.discrete(dt)
            rows: Any = None
            if Ad.shape == (4, 4):        # each row (a0, a1, a2, a3, b) as floats
                rows = tuple(tuple(float(v) for v in (*a, b)) for a, b in zip(Ad, Bd[:, 0]))
            zoh = self._step_zoh = (dt, Ad, Bd[:, 0], rows)
        delta = float(delta_front)
        rows = zoh[3]
        if rows is not None:              # numpy's order of the 4 x 4 product (class docstring)
            x0, x1, x2, x3 = self._x
            self._x = tuple([((a0 * x0 + a2 * x2) + (a1 * x1 + a3 * x3)) + b * delta
                             for a0, a1, a2, a3, b in rows])
        else:
            self._x = tuple((zoh[1] @ np.array(self._x) + zoh[2] * delta).tolist())
        self._delta = delta

    # ---------------------------------------------------------- outputs
    @property
    def y_s(self) -> float:
        """Sensor-point lateral displacement [m]."""
        return self._x[0]

    @property
    def psi(self) -> float:
        """Heading [rad]: the bicycle realisation's psi, or the kinematic ``v_s / U`` (not
        physical: no sideslip, no ds r term).
        """
        if self.bicycle is not None:
            return self._x[4]
        return self._x[1] / self.params.speed

    @property
    def y_cg(self) -> float:
        """c.g. lateral position y = y_s - ds sin(psi) [m]."""
        return self.y_s - self.params.ds * math.sin(self.psi)

    @property
    def yaw_rate(self) -> float:
        """r [rad/s]: the realisation's ``e1 z2 + e0 z1``, or the kinematic ``a_s / U`` with the
        last held steer input (not physical, see module).
        """
        x = self._x
        if self.bicycle is not None:
            return self._e1 * x[3] + self._e0 * x[2]
        x2, x3 = x[2], x[3]
        form = self._ca_form
        if form is not None and _EXACT_LOW < abs(x2) < _EXACT_HIGH \
                and _EXACT_LOW < abs(x3) < _EXACT_HIGH:
            c2, c3 = self._ca
            dot = form(c2, x2, c3, x3)
        else:                       # zeros, extreme magnitudes, non-finite, another kernel
            dot = float(self.Ca[0] @ np.array(x))
        return (dot + self._da * self._delta) / self.params.speed

    @property
    def lateral_velocity(self) -> float:
        """Body-frame lateral velocity at the c.g. [m/s]: ``v_s - U psi - ds r`` for the bicycle
        realisation, 0 for the kinematic heading (no sideslip state).
        """
        if self.bicycle is not None:
            return self._x[1] - self.params.speed * self.psi - self.params.ds * self.yaw_rate
        return 0.0


def bicycle_realisation(params: IdentifiedParams | None = None, tol: float = 1e-6):
    """Bicycle parameters (Eq. 4-5) with the same steer -> y_s transfer function, or None.

    G(s) = K (s^2 + n1 s + n0) / (s^2 (s^2 + d1 s + d0)) is Eq. 5 of a bicycle at speed U with the
    sensor ds ahead of the c.g. iff (``W = I_z + m l_f ds``, ``L = l_f + l_r``)::

        K  = C_f W / (m I_z)            n1 / n0 = (l_r + ds) / U            n0 = C_r L / W
        d1 = (C_f + C_r)/(m U) + (C_f l_f^2 + C_r l_r^2)/(I_z U)
        d0 = C_f C_r L^2/(m I_z U^2) + (C_r l_r - C_f l_f)/I_z

    With m = 1 kg (m, I_z, C_f, C_r scale together without changing G): l_r from the zeros, C_r
    and C_f from n0 and K for given (I_z, l_f), and (I_z, l_f) > 0 from (d1, d0) by
    ``scipy.optimize.least_squares`` in log space from a grid of starts.

    Returns
    -------
    dict or None
        ``mass`` (1 kg), ``yaw_inertia`` [kg m^2], ``lf``, ``lr`` [m], ``c_f``, ``c_r`` [N/rad]
        when every parameter is positive and (d1, d0) are matched to ``tol`` (relative);
        None otherwise (complex zeros with l_r + ds <= 0, or no positive solution).
    """
    from scipy.optimize import least_squares

    p = params if params is not None else IdentifiedParams()
    p.validate()
    K, U, ds = p.resolved_gain(), float(p.speed), float(p.ds)
    n1, n0 = p.numerator()
    d1, d0 = p.denominator()
    if not (n0 > 0.0 and n1 > 0.0):
        return None
    lr = U * n1 / n0 - ds
    if lr <= 0.0:
        return None

    def unpack(x):
        iz, lf = np.exp(x)
        w = iz + lf * ds
        cr = n0 * w / (lf + lr)
        cf = K * iz / w
        return iz, lf, cf, cr

    def residual(x):
        iz, lf, cf, cr = unpack(x)
        a1 = (cf + cr) / U + (cf * lf**2 + cr * lr**2) / (iz * U)
        a0 = cf * cr * (lf + lr)**2 / (iz * U**2) + (cr * lr - cf * lf) / iz
        return np.array([a1 / d1 - 1.0, a0 / d0 - 1.0])

    best = None
    for iz0 in (1e-3, 1e-2, 1e-1, 1.0):
        for lf0 in (0.01, 0.1, 1.0):
            sol = least_squares(residual, np.log([iz0, lf0]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
            if best is None or sol.cost < best.cost:
                best = sol
    if best is None or np.max(np.abs(best.fun)) > tol:
        return None
    iz, lf, cf, cr = unpack(best.x)
    return {'mass': 1.0, 'yaw_inertia': float(iz), 'lf': float(lf), 'lr': float(lr),
            'c_f': float(cf), 'c_r': float(cr)}
