"""Combined-slip tyre of the 1:10 torque car on the belt (ROS-free).

Slip quantities
---------------
The contact point of a wheel moves over the **belt surface** with velocity ``(V_cx, V_cy)`` in
the wheel frame (x along the wheel's heading, y to its left) [m/s]; the wheel spins at ``omega``
[rad/s] with effective rolling radius ``R`` [m].

Lateral slip (algebraic, as in the linear bicycle model)::

    s_y = V_cy / max(|V_cx|, v_low)            (= tan(alpha) with alpha = atan(V_cy/|V_cx|))

Longitudinal slip (a state: Pacejka, Tyre and Vehicle Dynamics, 3rd ed. 2012, sec. 7.2, the
single-contact-point transient model with relaxation length ``sigma``)::

    sigma dkappa/dt = (omega R - V_cx) - max(|V_cx|, v_low) kappa

In steady state ``kappa = (omega R - V_cx) / |V_cx|``, the usual practical slip (> 0 driving,
-1 for a locked wheel rolling forward).  The relaxation length keeps the wheel's spin equation
non-stiff at 1 kHz (the algebraic slip's time constant ``J |V| / (R^2 F_z C_k)`` is a fraction of
a millisecond for a 1:10 wheel), and ``max(|V_cx|, v_low)`` is the low-speed regularisation: at
standstill (``V_cx = omega = 0``) both slips are 0 and finite, and ``kappa`` relaxes with the
time constant ``sigma / v_low``.

Low speed and standstill
------------------------
Near standstill the relaxed slip is a spring: ``sigma kappa`` is the carcass' longitudinal
deflection and ``F_x = C_k F_z kappa`` its force, a stiffness ``C_k F_z / sigma`` per wheel
(14,000 N/m for the whole car, ``omega_n = sqrt(C_k g / sigma)`` = 70 rad/s) damped only by
``v_low / sigma`` = 5 1/s (damping ratio 0.04).  And a locked wheel that slid to a stop arrives
with ``kappa`` near -1: a virtual deflection 15 times the one its sliding force can hold, which
a ``sigma / v_low`` = 0.2 s relaxation releases at the full sliding force.  Together they made a
stopped car rock over the belt as a sliding limit cycle (+-0.1 to 0.4 m/s, 0.2-0.4 s period).
The damping alone (change 1) does not end it: with it the car still swung at 0.12-0.23 m/s
0.2 s after a locked-wheel stop (mu 0.3, 0.8, split), because the slip of -1 keeps the force
saturated, where a damper on the slip speed adds little.  Two changes:

1. **Low-speed damping** (Pacejka, Tyre and Vehicle Dynamics, 3rd ed. 2012, sec. 7.2.2, the
   damping ``k_Vlow`` of the transient slip model used in MF-Tyre/MF-Swift): the slip that
   enters the force formula is::

       kappa_F = kappa + (k_Vlow / C_Fk) (omega R - V_cx),
       k_Vlow  = 0.5 k_Vlow0 (1 + cos(pi |V_cx| / V_low,d))   for |V_cx| < V_low,d, else 0

   i.e. a viscous force ``k_Vlow (omega R - V_cx)`` [N] on the slip speed, faded in smoothly
   below ``V_low,d`` and exactly zero at driving speed (the bicycle limit at 1.2 m/s and the
   sliding friction are untouched).  Here ``k_Vlow0 = k_d F_z`` with ``k_d`` per unit load
   [s/m], so ``k_Vlow / C_Fk = k_d / C_k`` does not depend on the load.  The form (the slip
   correction and the cosine fade) was checked against a public MATLAB implementation of a
   four-wheel MF model (``kappa_corr = kappa + kVlow Vsx / C_Fk``, ``kVlow = 0.5 kVlow0 (1 +
   cos(pi |u| / Vlow))`` with ``kVlow0 = 770 N s/m, Vlow = 4 m/s`` for a passenger car), not
   against the book's text itself, which was not available here.
   **Choice of k_d**: a held car at rest is a mass on the four slip springs; per unit mass,
   with the regularised relaxation, ``u'' + (g k_d + v_low/sigma) u' + (C_k g / sigma +
   g k_d v_low / sigma) u = 0``.  Damping ratio 0.7 needs ``g k_d + 5 = 1.4 sqrt(4905 +
   5 g k_d)``, ``k_d = 10.0 s/m`` (``k_Vlow0`` = 70 N s/m per wheel at 7 N; the
   passenger-car value above, 770 N s/m at about 4 kN, is 0.19 s/m per unit load: a light
   damping, not one chosen for a damping ratio).  ``V_low,d = 0.3 m/s``: assumed, a quarter
   of the belt speed, because the car rebounds from a locked-wheel stop at up to 0.2 m/s,
   which a 0.1 m/s fade would miss.
   With a free wheel the damper adds ``R^2 k_Vlow0 / J`` = 1500 1/s to its spin mode:
   ``|lambda dt|`` = 1.7 at 1 kHz with rolling resistance, inside RK4's stability limit 2.78
   up to 11.3 N per wheel (two_track.py); this bounds ``k_d`` from above.

2. **Relaxation length shrinking with saturation, near standstill**: the carcass deflection
   cannot exceed what the contact patch holds, ``F / C_x`` with the carcass stiffness
   ``C_x = C_k F_z / sigma`` (Pacejka 2012 sec. 7.2: ``sigma = C_Fk / C_x``).  With the secant
   stiffness of the force formula, ``F / kappa = C_k F_z f(p) / p``, a saturated tyre's
   relaxation length is ``sigma_sat = max(sigma_min, sigma f(p) / p)``; it is faded in with
   the same weight ``w = 0.5 (1 + cos(pi |V_cx| / V_low,d))`` as the damping::

       sigma_eff = sigma - w (sigma - sigma_sat)       (= sigma for |V_cx| >= V_low,d)

   so the slip a locked wheel carries into the stop (about -1) is released in milliseconds
   instead of ``sigma / v_low`` = 0.2 s.  That the relaxation length falls with slip is
   measured (Higuchi and Pacejka, "The relaxation length concept at large wheel slip and
   camber", Vehicle System Dynamics 27 suppl., 1997); the secant form is this module's
   choice (the tangent is 0 at the peak and negative past it), not a formula checked against
   the book, and it is applied only below ``V_low,d`` so that the model at driving speed
   (the bicycle limit, ABS at 1.2 m/s) is the one before, to the bit.  ``sigma_min = 2 mm``:
   assumed, of the order of half a 1:10 tyre's contact length; it bounds the slip state's
   rate ``max(|V_cx|, v_low) / sigma_eff`` to 150 1/s below 0.3 m/s (``|lambda dt|`` = 0.15).
   At zero slip ``sigma_eff = sigma`` with zero derivative (``f(p)/p`` is even in the slip).

   Measured (irs_vehicle_sim/test/test_sim_two_track.py): a car braked on locked wheels from
   1.2 m/s is at rest over the belt (``|u| < 0.01 m/s``, no further sign change above
   1 mm/s) within 0.2 s of the stop on mu 0.3, 0.8 and split 0.8/0.3; before, it rocked at
   +-0.1 to 0.4 m/s for 1.3-1.6 s.  What is left: on mu 0.8 the car still rebounds backwards
   by up to 0.28 m/s for about 0.1 s after the stop (the slip state's lag behind the sliding
   contact; the carcass spring alone would give about ``F / sqrt(K m)`` = 0.1 m/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from irs_common.field_checks import check_numbers

__all__ = ['TyreParams', 'magic_shape', 'tyre_forces', 'lateral_slip', 'slip_rate',
           'sliding_ratio', 'low_speed_damping', 'damped_slip', 'relaxation_length']


@dataclass
class TyreParams:
    """Tyre parameters (see the module docstring for sources).

    Attributes
    ----------
    c_kappa : float
        Longitudinal slip stiffness per unit normal load C_k [1/unit slip] (default 10).
    c_alpha : float
        Cornering stiffness per unit normal load C_a [1/rad] (default 2.2: the irs_iwt front
        axle's 31 N/rad over its static load 2 x 7.0 N; the two-track model sets it per axle).
    shape_c : float
        Magic-formula shape factor C, 1 < C < 2 (default 1.41: sliding/peak 0.80).
    shape_e : float
        Magic-formula curvature factor E, E < 1 (default 0).
    relaxation_length : float
        Longitudinal relaxation length sigma [m] (default 0.02).
    v_low : float
        Low-speed regularisation speed [m/s] (default 0.1).
    low_speed_damping : float
        Low-speed damping per unit load ``k_d = k_Vlow0 / F_z`` [s/m] (default 10: damping
        ratio 0.7 of a held car at rest; 0 switches it off).
    v_low_damping : float
        Speed ``V_low,d`` below which the low-speed damping fades in [m/s] (default 0.3).
    relaxation_length_min : float
        Shortest relaxation length ``sigma_min`` of a saturated tyre [m] (default 0.002;
        ``>= relaxation_length`` keeps sigma constant, the model before).
    """

    c_kappa: float = 10.0
    c_alpha: float = 2.2
    shape_c: float = 1.41
    shape_e: float = 0.0
    relaxation_length: float = 0.02
    v_low: float = 0.1
    low_speed_damping: float = 10.0
    v_low_damping: float = 0.3
    relaxation_length_min: float = 0.002

    def __post_init__(self):
        check_numbers(self, ('c_kappa', 'c_alpha', 'relaxation_length', 'v_low', 'v_low_damping',
                             'relaxation_length_min'), above=0.0)
        check_numbers(self, ('low_speed_damping',), at_least=0.0)
        check_numbers(self, ('shape_c', 'shape_e'))
        if not 1.0 < self.shape_c < 2.0:
            raise ValueError(f'TyreParams.shape_c must be in (1, 2) so the force has a peak and '
                             f'a positive sliding value, got {self.shape_c!r}.')
        if self.shape_e >= 1.0:
            raise ValueError(f'TyreParams.shape_e must be < 1, got {self.shape_e!r}.')

    @classmethod
    def from_dict(cls, d: dict) -> 'TyreParams':
        """Build from a plain dict; unknown keys are refused with their names."""
        if not isinstance(d, dict):
            raise ValueError(f'tyre parameters must be a mapping, got {type(d).__name__}.')
        unknown = sorted(set(d) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f'unknown tyre parameter(s) {unknown}; known: '
                             f'{sorted(cls.__dataclass_fields__)}.')
        return cls(**d)


def magic_shape(p: float, params: TyreParams) -> float:
    """Normalised force magnitude ``f(p)`` [-] for the normalised slip ``p >= 0``.

    ``f(p) = sin(C atan(B p - E (B p - atan(B p))))`` with ``B = 1/C``: slope 1 at 0, peak 1,
    sliding value ``sin(C pi / 2)``.
    """
    c = params.shape_c
    bp = p / c
    return math.sin(c * math.atan(bp - params.shape_e * (bp - math.atan(bp))))


def sliding_ratio(params: TyreParams) -> float:
    """Sliding / peak friction ratio ``sin(C pi / 2)`` [-] (``f`` for ``p -> inf``, E < 1)."""
    return math.sin(0.5 * math.pi * params.shape_c)


def lateral_slip(v_cx: float, v_cy: float, params: TyreParams) -> float:
    """``s_y = V_cy / max(|V_cx|, v_low)`` [-] (tan of the slip angle, regularised)."""
    return v_cy / max(abs(v_cx), params.v_low)


def slip_rate(kappa: float, omega_r: float, v_cx: float, params: TyreParams,
              sigma: float | None = None) -> float:
    """``dkappa/dt = ((omega R - V_cx) - max(|V_cx|, v_low) kappa) / sigma`` [1/s].

    ``omega_r`` is the wheel's circumferential speed ``omega R`` [m/s]; ``sigma`` [m] defaults
    to ``params.relaxation_length`` (pass :func:`relaxation_length` for the saturating one).
    """
    if sigma is None:
        sigma = params.relaxation_length
    return ((omega_r - v_cx) - max(abs(v_cx), params.v_low) * kappa) / sigma


def low_speed_damping(v_cx: float, params: TyreParams) -> float:
    """Faded damping per unit load ``0.5 k_d (1 + cos(pi |V_cx| / V_low,d))`` [s/m], 0 for
    ``|V_cx| >= V_low,d`` (module docstring, Pacejka 2012 sec. 7.2.2).
    """
    return params.low_speed_damping * _fade(v_cx, params)


def damped_slip(kappa: float, omega_r: float, v_cx: float, params: TyreParams) -> float:
    """Slip for the force formula ``kappa + (k_d(V_cx) / C_k) (omega R - V_cx)`` [-]: the
    relaxed slip plus the low-speed damping (equal to ``kappa`` for ``|V_cx| >= V_low,d``).
    """
    k = low_speed_damping(v_cx, params)
    if k == 0.0:
        return kappa
    return kappa + k * (omega_r - v_cx) / params.c_kappa


def _fade(v_cx: float, params: TyreParams) -> float:
    """``0.5 (1 + cos(pi |V_cx| / V_low,d))`` for ``|V_cx| < V_low,d``, else 0 [-]."""
    v = abs(v_cx)
    if v >= params.v_low_damping:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.pi * v / params.v_low_damping))


def relaxation_length(kappa: float, s_y: float, v_cx: float, mu: float, params: TyreParams,
                      c_alpha: float | None = None) -> float:
    """Relaxation length [m] ``sigma - w (sigma - sigma_sat)``, ``w`` the low-speed fade,
    ``sigma_sat = max(sigma_min, sigma f(p) / p)`` the saturated tyre's, ``p = |(C_k kappa,
    -C_a s_y)| / mu`` (module docstring); ``sigma`` for ``|V_cx| >= V_low,d`` or zero slip.
    """
    sigma = params.relaxation_length
    w = _fade(v_cx, params)
    if w == 0.0:
        return sigma
    ca = params.c_alpha if c_alpha is None else c_alpha
    p = math.hypot(params.c_kappa * kappa, ca * s_y) / mu if mu > 0.0 else math.inf
    if p < 1e-9:
        return sigma
    ratio = magic_shape(p, params) / p if math.isfinite(p) else 0.0
    sat = min(sigma, max(params.relaxation_length_min, sigma * ratio))
    return sigma - w * (sigma - sat)


def tyre_forces(kappa: float, s_y: float, fz: float, mu: float, params: TyreParams,
                c_alpha: float | None = None):
    """Wheel-frame tyre forces ``(F_x, F_y)`` [N] (module docstring equations).

    Parameters
    ----------
    kappa : float
        Longitudinal slip [-].
    s_y : float
        Lateral slip ``V_cy / max(|V_cx|, v_low)`` [-].
    fz : float
        Normal load [N] (negative loads give zero force: the wheel has lifted).
    mu : float
        Surface friction coefficient [-] (> 0).
    c_alpha : float, optional
        Cornering stiffness per unit load [1/rad]; default ``params.c_alpha``.
    """
    ca = params.c_alpha if c_alpha is None else c_alpha
    if fz <= 0.0 or mu <= 0.0:
        return 0.0, 0.0
    phx = params.c_kappa * kappa
    phy = -ca * s_y
    mag = math.hypot(phx, phy)
    if mag < 1e-12:
        return 0.0, 0.0
    scale = fz * mu * magic_shape(mag / mu, params) / mag
    return scale * phx, scale * phy
