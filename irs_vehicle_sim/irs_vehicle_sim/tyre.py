"""Combined-slip tyre of the 1:10 torque car on the belt: TMeasy (Rill), relaxed slip (ROS-free).

Slips of a wheel whose contact point moves over the belt at ``(V_cx, V_cy)`` [m/s] (wheel frame)
and spins at ``omega`` [rad/s] with radius ``R`` [m]: lateral ``s_y = V_cy / max(|V_cx|, v_low)``
(tan of the slip angle), longitudinal ``kappa`` a state with relaxation length ``sigma`` (Pacejka,
Tyre and Vehicle Dynamics, 3rd ed. 2012, sec. 7.2)::

    sigma dkappa/dt = (omega R - V_cx) - max(|V_cx|, v_low) kappa     (steady: (omega R - V)/|V|)

Forces: TMeasy's characteristic and combined-slip normalisation (Rill, Road Vehicle Dynamics,
CRC 2012, sec. 3.4; :func:`tmeasy_curve`, :func:`tyre_forces`). Per direction it takes the
initial stiffness ``dF0 = C F_z``, the peak ``(s_M, mu F_z)`` and the sliding ``(s_S,
r_S mu F_z)``, each set on its own. Friction scaling: the peak slips at the reference friction
``mu_ref`` scale as ``(mu / mu_ref)^q``; Rill scales them (and ``s_S``) with ``mu / mu_ref``,
which puts the peak slip in proportion to mu. Burckhardt's dry asphalt, wet asphalt and snow
(peaks 0.170, 0.131, 0.060 at mu 1.17, 0.80, 0.19) give q = 0.56 by least squares in log; their
locked / peak ratios are 0.64-0.68, hence ``r_S = 0.65``. Parameter sources:
:class:`TyreParams`; the low-speed damping and the saturating relaxation length that bring a
stopped car to rest: :func:`damped_slip`, :func:`relaxation_length` (and docs/torque_car.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from irs_common.field_checks import check_numbers

#: Highest surface friction (irs_vehicle_sim.surface refuses more) [-].
MU_MAX = 2.0
#: Lowest surface friction (irs_vehicle_sim.surface refuses less) [-]: below wet ice (about
#: 0.05); a subnormal friction would divide by zero in the slip normalisation.
MU_MIN = 0.01

__all__ = ['MU_MAX', 'MU_MIN', 'TyreParams', 'tmeasy_curve', 'tyre_forces', 'lateral_slip',
           'slip_rate', 'slip_scale', 'peak_slips', 'low_speed_damping', 'damped_slip',
           'relaxation_length', 'characteristic', 'contact']


@dataclass
class TyreParams:
    """Tyre parameters; slips at the reference friction ``mu_ref``, forces per unit load.

    Attributes
    ----------
    c_kappa : float
        Longitudinal slip stiffness per unit load ``dF0x / F_z`` [1/unit slip] (default 10:
        assumed; Pacejka 2012 gives 15-20 for car tyres, a soft 1:10 tyre is softer).
    c_alpha : float
        Cornering stiffness per unit load ``dF0y / F_z`` [1/rad] (default 4.95: f1tenth_gym's
        1:10 rubber tyre, irs_models.torque_car; the two-track model sets it per axle).
    peak_slip_x, peak_slip_y : float
        Slip of the force peak at ``mu_ref`` [-] (defaults 0.16 and 0.33, i.e. 18.3 deg). Chosen
        so that ``dF0 s_M / F_M >= 2`` at mu_ref (TMeasy's curve is concave from zero only then:
        its curvature at zero is ``-2 (rho - 2) F_M / s_M^2``, ``rho = dF0 s_M / F_M``), which
        with ``c_kappa`` = 10 needs 0.16 (Burckhardt's asphalt: 0.13-0.17) and with the front
        axle's 4.95 /rad needs 0.323; 18 deg is inside the 10-20 deg of rubber RC tyres.
    sliding_slip_x, sliding_slip_y : float
        Slip from which the force is the sliding force [-] (default 1.0: a locked wheel, and
        45 deg sideways), above the peak slip at the highest friction (mu 2). Not scaled with
        mu (Rill scales it as the peak slip): Burckhardt's curves fall until the wheel locks on
        every surface.
    sliding_ratio_x, sliding_ratio_y : float
        Sliding / peak force ``r_S`` [-] (default 0.65 both: Burckhardt's locked / peak 0.64-0.68;
        equal in both directions because a fully sliding patch has one Coulomb friction).
    mu_ref : float
        Friction at which the slips above hold [-] (default 0.8, the dry belt).
    slip_mu_exponent : float
        q in ``s(mu) = s(mu_ref) (mu / mu_ref)^q`` [-] (default 0.56; 1 = Rill's, 0 = fixed).
    relaxation_length : float
        Longitudinal relaxation length sigma [m] (default 0.02, of the order of the radius).
    v_low : float
        Low-speed regularisation speed [m/s] (default 0.1).
    low_speed_damping : float
        Low-speed damping per unit load ``k_d`` [s/m] (default 10; 0 switches it off).
    v_low_damping : float
        Speed below which the damping and the saturated relaxation fade in [m/s] (0.3).
    relaxation_length_min : float
        Shortest relaxation length of a saturated tyre [m] (0.002).
    """

    c_kappa: float = 10.0
    c_alpha: float = 4.95
    peak_slip_x: float = 0.16
    peak_slip_y: float = 0.33
    sliding_slip_x: float = 1.0
    sliding_slip_y: float = 1.0
    sliding_ratio_x: float = 0.65
    sliding_ratio_y: float = 0.65
    mu_ref: float = 0.8
    slip_mu_exponent: float = 0.56
    relaxation_length: float = 0.02
    v_low: float = 0.1
    low_speed_damping: float = 10.0
    v_low_damping: float = 0.3
    relaxation_length_min: float = 0.002

    def __post_init__(self):
        check_numbers(self, ('c_kappa', 'c_alpha', 'peak_slip_x', 'peak_slip_y',
                             'sliding_slip_x', 'sliding_slip_y', 'sliding_ratio_x',
                             'sliding_ratio_y', 'mu_ref', 'relaxation_length', 'v_low',
                             'v_low_damping', 'relaxation_length_min'), above=0.0)
        check_numbers(self, ('low_speed_damping', 'slip_mu_exponent'), at_least=0.0)
        if self.slip_mu_exponent > 1.0:
            raise ValueError(f'TyreParams.slip_mu_exponent must be in [0, 1], got '
                             f'{self.slip_mu_exponent!r}.')
        top = (MU_MAX / self.mu_ref) ** self.slip_mu_exponent
        for axis in 'xy':
            sm, ss = getattr(self, f'peak_slip_{axis}'), getattr(self, f'sliding_slip_{axis}')
            if not sm * max(1.0, top) < ss:
                raise ValueError(f'TyreParams.peak_slip_{axis} must be below sliding_slip_{axis}'
                                 f' up to mu {MU_MAX} (times {top:.3g}), got {sm!r} and {ss!r}.')
            if getattr(self, f'sliding_ratio_{axis}') > 1.0:
                raise ValueError(f'TyreParams.sliding_ratio_{axis} must be in (0, 1] (sliding '
                                 f'force at most the peak), got '
                                 f'{getattr(self, f"sliding_ratio_{axis}")!r}.')

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


def tmeasy_curve(s: float, df0: float, s_m: float, f_m: float, s_s: float, f_s: float) -> float:
    """TMeasy's force characteristic ``F(s)`` for a slip ``s >= 0`` (Rill 2012, sec. 3.4).

    ::

        s <= s_M:        F = dF0 s / (1 + sigma (sigma + dF0 s_M / F_M - 2)),  sigma = s / s_M
        s_M < s < s_S:   F = F_M - (F_M - F_S) sigma^2 (3 - 2 sigma),  sigma = (s-s_M)/(s_S-s_M)
        s >= s_S:        F = F_S

    Slope ``dF0`` at zero, peak ``F_M`` at ``s_M``, sliding ``F_S`` from ``s_S`` on.
    """
    if s <= s_m:
        sig = s / s_m
        return df0 * s / (1.0 + sig * (sig + df0 * s_m / f_m - 2.0))
    if s < s_s:
        sig = (s - s_m) / (s_s - s_m)
        return f_m - (f_m - f_s) * sig * sig * (3.0 - 2.0 * sig)
    return f_s


def slip_scale(mu: float, params: TyreParams) -> float:
    """``(mu / mu_ref)^q`` [-]: the factor on the slips at friction ``mu``."""
    return (mu / params.mu_ref) ** params.slip_mu_exponent


def peak_slips(mu: float, params: TyreParams) -> tuple:
    """``(s_Mx, s_My)`` [-]: the pure-slip peaks at friction ``mu`` (``s_My`` = tan of the
    peak slip angle).
    """
    k = slip_scale(mu, params)
    return params.peak_slip_x * k, params.peak_slip_y * k


def characteristic(mu: float, params: TyreParams, c_alpha: float) -> tuple:
    """The slip-independent part of the combined-slip characteristic at friction ``mu`` > 0
    [-] and cornering stiffness ``c_alpha`` [1/rad] (both per unit load): the normalising
    factors ``(n_x, n_y)`` and the products of the blend (:func:`tyre_forces`), in the order
    :func:`_combined_at` takes them. A wheel's friction is held over a step, so the two-track
    model computes it once per wheel and step instead of once per force evaluation.
    """
    k = slip_scale(mu, params)
    sxm, sym = params.peak_slip_x * k, params.peak_slip_y * k
    # normalising factors (Rill 2012 sec. 3.4.2): equal weight to the peak slips and to the
    # slips the initial stiffnesses would need to reach the peak force mu
    hx, hy = mu / params.c_kappa, mu / c_alpha
    nx = sxm / (sxm + sym) + hx / (hx + hy)
    ny = sym / (sxm + sym) + hy / (hx + hy)
    # the sliding slips are not scaled with mu (class docstring)
    return (nx, ny, params.c_kappa * nx, c_alpha * ny, sxm / nx, sym / ny,
            params.sliding_slip_x / nx, params.sliding_slip_y / ny, mu,
            params.sliding_ratio_x, params.sliding_ratio_y)


def _combined_at(kappa, s_y, ch):
    """``(F, cos phi, sin phi, dF0 s_N)`` per unit load of the slips ``(kappa, -s_y)`` on the
    characteristic ``ch`` (:func:`characteristic`).
    """
    nx, ny, dfx_nx, dfy_ny, sxm_nx, sym_ny, sxs_nx, sys_ny, mu, rx, ry = ch
    sxn, syn = kappa / nx, -s_y / ny
    s = math.hypot(sxn, syn)
    if s < 1e-15:
        return 0.0, 1.0, 0.0, 0.0
    c, sn = sxn / s, syn / s
    df0 = math.hypot(dfx_nx * c, dfy_ny * sn)
    s_m = math.hypot(sxm_nx * c, sym_ny * sn)
    f_s = mu * math.hypot(rx * c, ry * sn)
    s_s = math.hypot(sxs_nx * c, sys_ny * sn)
    # isotropic peak friction F_M = mu
    return tmeasy_curve(s, df0, s_m, mu, s_s, f_s), c, sn, df0 * s


def _combined(kappa, s_y, mu, params, ca):
    """``(F, cos phi, sin phi, dF0 s_N)`` per unit load of the slips ``(kappa, -s_y)``."""
    return _combined_at(kappa, s_y, characteristic(mu, params, ca))


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


def _fade(v_cx: float, params: TyreParams) -> float:
    """``w = 0.5 (1 + cos(pi |V_cx| / V_low,d))`` for ``|V_cx| < V_low,d``, else 0 [-]."""
    v = abs(v_cx)
    if v >= params.v_low_damping:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.pi * v / params.v_low_damping))


def low_speed_damping(v_cx: float, params: TyreParams) -> float:
    """Faded damping per unit load ``w k_d`` [s/m] (0 for ``|V_cx| >= V_low,d``).

    Pacejka 2012 sec. 7.2.2 (MF-Tyre's ``k_Vlow``, form checked against a public MF
    implementation): at rest the relaxed slip is a spring ``C_k F_z / sigma`` damped only by
    ``v_low / sigma`` (ratio 0.04), and a stopped car rocked over the belt. ``k_d = 10 s/m``
    gives the held car damping ratio 0.7: ``g k_d + v_low/sigma = 1.4 sqrt(C_k g / sigma +
    g k_d v_low / sigma)``. A free wheel at rest gets ``R^2 k_d F_z / J`` = 1500 1/s, inside
    RK4's limit at 1 kHz up to 11.3 N per wheel (two_track.py).
    """
    return params.low_speed_damping * _fade(v_cx, params)


def damped_slip(kappa: float, omega_r: float, v_cx: float, params: TyreParams) -> float:
    """Slip for the force ``kappa + (w k_d / C_k) (omega R - V_cx)`` [-]: the relaxed slip
    plus the low-speed damping (:func:`low_speed_damping`; ``kappa`` at driving speed).
    """
    k = low_speed_damping(v_cx, params)
    if k == 0.0:
        return kappa
    return kappa + k * (omega_r - v_cx) / params.c_kappa


def relaxation_length(kappa: float, s_y: float, v_cx: float, mu: float, params: TyreParams,
                      c_alpha: float | None = None) -> float:
    """Relaxation length [m] ``sigma - w (sigma - max(sigma_min, sigma F / (dF0 s)))``.

    The carcass cannot hold more deflection than its force: ``sigma_sat = sigma`` times the
    secant over the initial stiffness of the combined characteristic (relaxation length falling
    with slip: Higuchi and Pacejka 1997; the secant form is this module's choice), faded in
    with the low-speed weight ``w``, so a locked wheel's slip of about -1 is released in
    milliseconds when the car stops; exactly ``sigma`` for ``|V_cx| >= V_low,d`` or zero slip.
    """
    sigma = params.relaxation_length
    w = _fade(v_cx, params)
    if w == 0.0:
        return sigma
    if mu <= 0.0:
        ratio = 0.0
    else:
        f, _c, _s, lin = _combined(kappa, s_y, mu, params,
                                   params.c_alpha if c_alpha is None else c_alpha)
        if lin < 1e-12:
            return sigma
        ratio = f / lin
    sat = min(sigma, max(params.relaxation_length_min, sigma * ratio))
    return sigma - w * (sigma - sat)


def tyre_forces(kappa: float, s_y: float, fz: float, mu: float, params: TyreParams,
                c_alpha: float | None = None):
    """Wheel-frame tyre forces ``(F_x, F_y)`` [N] (Rill 2012 sec. 3.4, combined slip).

    The slips ``(kappa, -s_y)`` are normalised per direction, ``s_N = |(kappa / n_x,
    -s_y / n_y)|`` with ``n_x = s_Mx / (s_Mx + s_My) + (mu / C_k) / (mu / C_k + mu / C_a)``
    (``n_y`` alike); the characteristic's parameters are blended over the direction ``phi`` of
    the normalised slip (``dF0 = |(C_k n_x cos phi, C_a n_y sin phi)|``, ``s_M = |(s_Mx / n_x
    cos phi, s_My / n_y sin phi)|``, ``F_M = mu``, ``F_S``, ``s_S`` alike) and ``(F_x, F_y) =
    F_z F(s_N) (cos phi, sin phi)``. Pure slip gives each direction's curve exactly.

    Parameters
    ----------
    kappa : float
        Longitudinal slip [-].
    s_y : float
        Lateral slip ``V_cy / max(|V_cx|, v_low)`` [-].
    fz : float
        Normal load [N] (a negative load gives zero force: the wheel has lifted).
    mu : float
        Surface (peak) friction coefficient [-] (> 0).
    c_alpha : float, optional
        Cornering stiffness per unit load [1/rad]; default ``params.c_alpha``.
    """
    if fz <= 0.0 or mu <= 0.0:
        return 0.0, 0.0
    f, c, s, lin = _combined(kappa, s_y, mu, params,
                             params.c_alpha if c_alpha is None else c_alpha)
    if lin == 0.0:
        return 0.0, 0.0
    return fz * f * c, fz * f * s


def contact(kappa: float, omega_r: float, v_cx: float, s_y: float, fz: float, mu: float,
            params: TyreParams, c_alpha: float, ch: tuple | None = None) -> tuple:
    """One wheel's ``(kappa_F, F_x, F_y, sigma)``: the slip for the force [-]
    (:func:`damped_slip`), the wheel-frame forces [N] (:func:`tyre_forces`) and the relaxation
    length [m] (:func:`relaxation_length`), from the relaxed slip ``kappa`` [-], the wheel's
    circumferential speed ``omega_r`` [m/s], the contact point's velocity ``v_cx`` [m/s] and
    lateral slip ``s_y`` [-], the load ``fz`` [N], the friction ``mu`` [-] and the cornering
    stiffness per unit load ``c_alpha`` [1/rad]; ``ch`` is ``characteristic(mu, params,
    c_alpha)`` where the caller holds it (computed here when ``None``).

    Equal to the three functions called in turn, to the bit
    (``irs_vehicle_sim/test/test_sim_tyre.py``); the low-speed weight ``w`` and the
    combined-slip characteristic, which two of them need, are evaluated once. The two-track
    model calls it for each wheel five times per step.
    """
    sigma = params.relaxation_length
    w = _fade(v_cx, params)
    k = params.low_speed_damping * w
    kap = kappa if k == 0.0 else kappa + k * (omega_r - v_cx) / params.c_kappa
    if mu <= 0.0:                          # no grip: no force, the carcass holds nothing
        fx = fy = ratio = 0.0
    elif fz <= 0.0 and w == 0.0:           # a lifted wheel at speed
        return kap, 0.0, 0.0, sigma
    else:
        f, c, sn, lin = _combined_at(kap, s_y, characteristic(mu, params, c_alpha)
                                     if ch is None else ch)
        fx, fy = (0.0, 0.0) if fz <= 0.0 or lin == 0.0 else (fz * f * c, fz * f * sn)
        if w == 0.0 or lin < 1e-12:
            return kap, fx, fy, sigma
        ratio = f / lin
    if w == 0.0:
        return kap, fx, fy, sigma
    sat = min(sigma, max(params.relaxation_length_min, sigma * ratio))
    return kap, fx, fy, sigma - w * (sigma - sat)
