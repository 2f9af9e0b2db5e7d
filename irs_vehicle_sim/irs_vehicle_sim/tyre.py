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

Forces (combined slip on the normalised slip vector; Pacejka 2012 sec. 4.3.2, the "similarity"
combination with one magic-formula shape for the magnitude)::

    phi   = (C_k kappa, -C_a s_y)               linear force per unit load [-]
    p     = |phi| / mu                          (mu: surface friction of this wheel)
    f(p)  = sin(C atan(B p - E (B p - atan(B p)))),  B = 1 / C  (so f'(0) = 1)
    F     = F_z mu f(p) phi / |phi|             [N], wheel frame (F_x, F_y)

so at small slip ``F_x = C_k F_z kappa`` and ``F_y = -C_a F_z s_y`` (cornering stiffness
``C_a F_z`` [N/rad], independent of mu as in the magic formula with ``BCD`` fixed), the largest
``|F|`` is ``mu F_z`` (peak, ``f = 1``) and a fully sliding tyre keeps ``mu F_z sin(C pi / 2)``
(the sliding friction).  The force always opposes the slip vector, so a locked wheel
(``kappa = -1``) sliding sideways has its force along the sliding velocity, and braking hard
takes away cornering force (friction circle).

Parameters (1:10 rubber tyre on the belt)
-----------------------------------------
``C_k = 10`` per unit slip: assumed, because Pacejka (2012, table of sec. 4.3) gives
longitudinal slip stiffness of car tyres of about 15-20 times the load and a small, soft 1:10
rubber tyre is softer; ``C_a`` is NOT chosen here: the two-track model sets it per axle so that
the axle's cornering stiffness at the static load equals the ``irs_iwt`` preset's ``c_f``, ``c_r``
(the car must be the same car as the bicycle model).  ``C = 1.41``: sliding/peak ratio
``sin(1.41 pi / 2) = 0.80``, assumed, because rubber on a rubber/fabric treadmill belt loses about
20 % from peak to sliding (Pacejka's passenger-car ``C_x = 1.65`` gives 0.52, too low for a
hard 1:10 compound).  ``E = 0``: the plain shape, no data to fit a curvature.  ``sigma =
0.02 m``: Pacejka gives relaxation lengths of the order of the tyre radius for car tyres; 0.6
of the 0.033 m radius, assumed.  ``v_low = 0.1 m/s``: assumed, a twelfth of the 1.2 m/s belt
speed; below it the slips are regularised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from irs_common.field_checks import check_numbers

__all__ = ['TyreParams', 'magic_shape', 'tyre_forces', 'lateral_slip', 'slip_rate',
           'sliding_ratio']


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
    """

    c_kappa: float = 10.0
    c_alpha: float = 2.2
    shape_c: float = 1.41
    shape_e: float = 0.0
    relaxation_length: float = 0.02
    v_low: float = 0.1

    def __post_init__(self):
        check_numbers(self, ('c_kappa', 'c_alpha', 'relaxation_length', 'v_low'), above=0.0)
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


def slip_rate(kappa: float, omega_r: float, v_cx: float, params: TyreParams) -> float:
    """``dkappa/dt = ((omega R - V_cx) - max(|V_cx|, v_low) kappa) / sigma`` [1/s].

    ``omega_r`` is the wheel's circumferential speed ``omega R`` [m/s].
    """
    return ((omega_r - v_cx) - max(abs(v_cx), params.v_low) * kappa) / params.relaxation_length


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
