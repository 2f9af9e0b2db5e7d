"""Linear bicycle model (Peng & Tomizuka form) of the IRS paper, section 4.

Two dynamic degrees of freedom (lateral velocity ``v_y`` at the c.g. and yaw rate ``r``) at a
constant forward speed ``V`` [m/s], linear tyres with per-axle cornering stiffnesses ``C_f``,
``C_r`` [N/rad], plus the two kinematic states lateral position ``y`` of the c.g. and yaw
``psi`` (small angle, road-fixed frame)::

    Fyf = C_f (delta_f - (v_y + l_f r) / V)          Fyr = C_r (delta_r - (v_y - l_r r) / V)
    m   (dv_y/dt + V r) = Fyf + Fyr
    I_z  dr/dt          = l_f Fyf - l_r Fyr
    dy/dt   = v_y + V psi
    dpsi/dt = r
    y_s     = y + d_s psi                             (sensor point d_s ahead of the c.g.)

State ``x = [v_y, r, y, psi]``, input ``u = [delta_f, delta_r]`` (rad, positive steers the car
left, i.e. CCW yaw), output ``y_s`` [m].

The front-steer zeros obey ``1/z1 + 1/z2 = -(l_r + d_s) / V``, independently of mass, inertia
and tyres. The model is the physical reference the paper's identified plant (Eq. 6) and the
full-size presets are compared with (numpy, python-control; no rclpy). Matrices and Eq. 4:
:func:`bicycle_state_space`; Eq. 5 and its reconstruction from the OCR: :func:`tf_coefficients`.
"""

from __future__ import annotations

from dataclasses import dataclass, asdict
import math

import numpy as np

__all__ = [
    'BicycleParams',
    'bicycle_state_space',
    'tf_coefficients',
    'transfer_function',
    'zpk',
    'DEFAULT_ACTUATOR_HZ',
]

#: Default steering actuator first-order lag corner [Hz] (paper section 4, Fig. 8 fit).
DEFAULT_ACTUATOR_HZ = 4.6


def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a positive finite number, got {value!r}.') from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f'{name} must be a positive finite number, got {value!r}.')
    return v


@dataclass(frozen=True)
class BicycleParams:
    """Parameters of the linear bicycle model.

    Parameters
    ----------
    mass : float
        Vehicle mass m [kg].
    yaw_inertia : float
        Yaw moment of inertia about the vertical axis through the c.g., I_z [kg m^2].
    lf, lr : float
        Distance from the c.g. to the front / rear axle [m]; wheelbase L = lf + lr.
    c_f, c_r : float
        Cornering stiffness of the whole front / rear axle (both tyres) [N/rad].
    track : float
        Track width [m] (not used by the linear model; kept for kinematics / plots).
    wheel_radius : float
        Wheel rolling radius [m] (not used by the linear model).
    rear_steer : bool
        Whether the car *has* a rear steering actuator.  The model's rear-steer input column is
        always the physical one; this flag only says if the input is available.
    """

    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    c_f: float
    c_r: float
    track: float
    wheel_radius: float
    rear_steer: bool = False

    def __post_init__(self):
        for name in ('mass', 'yaw_inertia', 'lf', 'lr', 'c_f', 'c_r', 'track', 'wheel_radius'):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        if not isinstance(self.rear_steer, (bool, np.bool_)):
            raise ValueError(f'rear_steer must be a bool (True/False), got {self.rear_steer!r}.')
        object.__setattr__(self, 'rear_steer', bool(self.rear_steer))

    @property
    def wheelbase(self) -> float:
        """Wheelbase L = lf + lr [m]."""
        return self.lf + self.lr

    def to_dict(self) -> dict:
        """Plain dict of the fields (for YAML)."""
        return asdict(self)


def _check_speed_ds(speed, ds):
    v = _positive('speed', speed)
    try:
        d = float(ds)
    except (TypeError, ValueError):
        raise ValueError(f'ds must be a finite distance in metres, got {ds!r}.') from None
    if not math.isfinite(d):
        raise ValueError(f'ds must be a finite distance in metres, got {ds!r}.')
    return v, d


def bicycle_state_space(params: BicycleParams, speed: float, ds: float = 0.0):
    """State-space matrices of the linear bicycle model.

    Parameters
    ----------
    params : BicycleParams
    speed : float
        Forward speed V [m/s], > 0.
    ds : float
        Sensor distance ahead of the c.g. along the car axis [m] (may be 0 or negative).

    Returns
    -------
    A (4x4), B (4x2), C (1x4), D (1x2) : numpy.ndarray
        States [v_y, r, y, psi], inputs [delta_f, delta_r], output y_s = y + ds psi.

    Notes
    -----
    With ``L = l_f + l_r``::

            | -(C_f+C_r)/(mV)              -(C_f l_f - C_r l_r)/(mV) - V      0  0 |
        A = | -(C_f l_f - C_r l_r)/(I_z V)  -(C_f l_f^2 + C_r l_r^2)/(I_z V)  0  0 |
            |  1                             0                                 0  V |
            |  0                             1                                 0  0 |

            | C_f/m        C_r/m       |
        B = | C_f l_f/I_z  -C_r l_r/I_z |
            | 0            0           |
            | 0            0           |
        C = [0, 0, 1, d_s],  D = [0, 0]

    These are the paper's A1..A4, B1, B2 of Eq. (4) (A1 = -(C_f + C_r)/m, A2 = (C_r l_r - C_f
    l_f)/m, A3 = (C_r l_r - C_f l_f)/I_z, A4 = -(C_f l_f^2 + C_r l_r^2)/I_z, B1 = C_f/m, B2 = l_f
    C_f/I_z, with the velocity-dependent entries A_i/V as in Peng & Tomizuka 1993), written in the
    ``[v_y, r, y, psi]`` state order.
    """
    V, d = _check_speed_ds(speed, ds)
    p = params
    m, iz, lf, lr, cf, cr = p.mass, p.yaw_inertia, p.lf, p.lr, p.c_f, p.c_r
    A = np.array(
        [
            [-(cf + cr) / (m * V), -(cf * lf - cr * lr) / (m * V) - V, 0.0, 0.0],
            [-(cf * lf - cr * lr) / (iz * V), -(cf * lf**2 + cr * lr**2) / (iz * V), 0.0, 0.0],
            [1.0, 0.0, 0.0, V],
            [0.0, 1.0, 0.0, 0.0],
        ]
    )
    B = np.array([[cf / m, cr / m], [cf * lf / iz, -cr * lr / iz], [0.0, 0.0], [0.0, 0.0]])
    C = np.array([[0.0, 0.0, 1.0, d]])
    D = np.zeros((1, 2))
    return A, B, C, D


def tf_coefficients(params: BicycleParams, speed: float, ds: float = 0.0, axle: str = 'front'):
    """Symbolic (Eq. 5) numerator / denominator coefficients, highest power first.

    Returns
    -------
    num : ndarray, shape (3,)
        Front: ``C_f [V^2 (I_z + m l_f d_s), C_r L V (l_r + d_s), C_r L V^2]``;
        rear: ``C_r [V^2 (I_z - m l_r d_s), C_f L V (l_f - d_s), -C_f L V^2]``.
    den : ndarray, shape (5,)
        ``[I_z m V^2, V (I_z (C_f + C_r) + m (C_f l_f^2 + C_r l_r^2)),
        m V^2 (C_r l_r - C_f l_f) + C_f C_r L^2, 0, 0]``.

    Notes
    -----
    From the kinematic rows, ``s Y = V_y + V Psi`` and ``s Psi = R``, so ``Y_s = (s V_y + (V + d_s
    s) R) / s^2``.  Solving the 2x2 dynamic block by Cramer's rule with ``Delta(s) = (s - a11)(s -
    a22) - a12 a21`` and collecting powers of ``s`` (the ``V`` in ``a12`` cancels against ``V b2``)
    gives, after multiplying numerator and denominator by ``m I_z V^2``:

    Front steer (paper Eq. 5)::

        Y_s      C_f [ V^2 (I_z + m l_f d_s) s^2 + C_r L V (l_r + d_s) s + C_r L V^2 ]
        ------ = -----------------------------------------------------------------------------
        delta_f  s^2 [ I_z m V^2 s^2 + V (I_z (C_f + C_r) + m (C_f l_f^2 + C_r l_r^2)) s
                       + (m V^2 (C_r l_r - C_f l_f) + C_f C_r L^2) ]

      numerator coefficients:  n2 = C_f V^2 (I_z + m l_f d_s),  n1 = C_f C_r L V (l_r + d_s),
      n0 = C_f C_r L V^2.  Hence the zeros obey
      ``z1 z2 = C_r L / (I_z + m l_f d_s)`` and
      ``z1 + z2 = -C_r L (l_r + d_s) / (V (I_z + m l_f d_s))``,
      so ``1/z1 + 1/z2 = -(l_r + d_s) / V`` *independently of mass, inertia and tyres*.
      With ``d_s = 0`` the zeros are the roots of ``I_z V s^2 + C_r L l_r s + C_r L V``.

    Rear steer (same denominator)::

        numerator = C_r [ V^2 (I_z - m l_r d_s) s^2 + C_f L V (l_f - d_s) s - C_f L V^2 ]

      (constant term negative: at the c.g. (d_s = 0) one right-half-plane zero, i.e. non-minimum
      phase; for a point ahead both zeros are in the LHP only if ``I_z < m l_r d_s`` and
      ``d_s > l_f``; ``1/z1 + 1/z2 = (l_f - d_s)/V``.)

    The OCR of the paper garbles Eq. 5; the form above is the one consistent with the legible
    fragments ("C_sf C_sr L V (d_s + L_2) s", "C_sf C_sr L V^2", "I_z m V^2 s^4", "V(I_z(C_sr +
    C_sf) + m(C_sr L_r^2 + C_sf L_f^2)) s^3", "(m V^2 (C_sr L_2 - C_sf L_1) + C_sf C_sr L^2) s^2")
    and it is verified numerically against the state-space model in the tests.
    """
    V, d = _check_speed_ds(speed, ds)
    p = params
    m, iz, lf, lr, cf, cr = p.mass, p.yaw_inertia, p.lf, p.lr, p.c_f, p.c_r
    L = lf + lr
    if axle == 'front':
        num = cf * np.array([V**2 * (iz + m * lf * d), cr * L * V * (lr + d), cr * L * V**2])
    elif axle == 'rear':
        num = cr * np.array([V**2 * (iz - m * lr * d), cf * L * V * (lf - d), -cf * L * V**2])
    else:
        raise ValueError(f"axle must be 'front' or 'rear', got {axle!r}.")
    den = np.array(
        [
            iz * m * V**2,
            V * (iz * (cf + cr) + m * (cf * lf**2 + cr * lr**2)),
            m * V**2 * (cr * lr - cf * lf) + cf * cr * L**2,
            0.0,
            0.0,
        ]
    )
    return num, den


def _actuator_omega(actuator_pole):
    """Actuator corner as a positive rad/s number from a pole spec (None -> no actuator).

    ``actuator_pole`` is the pole location in rad/s; either sign is accepted (``-28.9`` or
    ``28.9`` both mean a lag ``28.9/(s + 28.9)``).
    """
    if actuator_pole is None:
        return None
    w = abs(float(actuator_pole))
    if not math.isfinite(w) or w == 0.0:
        raise ValueError(
            f'actuator_pole must be a finite non-zero pole in rad/s, got {actuator_pole!r}.'
        )
    return w


def transfer_function(params: BicycleParams, speed: float, ds: float = 0.0, axle: str = 'front',
                      actuator_pole=None, as_control: bool = True):
    """Steer-to-lateral-displacement transfer function Y_s(s)/delta(s) [m/rad].

    Parameters
    ----------
    params, speed, ds : see :func:`bicycle_state_space`.
    axle : {'front', 'rear'}
        Which steer input.
    actuator_pole : float or None
        Actuator first-order lag pole [rad/s] (sign ignored), e.g. ``2*pi*4.6``; None = no lag.
        The lag has unit DC gain: ``w_a/(s + w_a)``.
    as_control : bool
        True returns a ``control.TransferFunction``; False returns ``(num, den)`` arrays.

    The optional actuator is a first-order lag ``w_a / (s + w_a)``, ``w_a = 2 pi f_a`` (paper: 4.6
    Hz, i.e. the -29 rad/s pole of Eq. 6).
    """
    num, den = tf_coefficients(params, speed, ds, axle)
    w = _actuator_omega(actuator_pole)
    # normalise to monic denominator for numerical hygiene
    num = num / den[0]
    den = den / den[0]
    if w is not None:
        num = np.polymul(num, [w])
        den = np.polymul(den, [1.0, w])
    if not as_control:
        return num, den
    import control

    return control.tf(num, den)


def zpk(
    params: BicycleParams, speed: float, ds: float = 0.0, axle: str = 'front', actuator_pole=None
):
    """Zeros, poles and high-frequency gain of :func:`transfer_function`.

    ``G(s) = k prod(s - z_i) / prod(s - p_j)``.

    Returns
    -------
    zeros, poles : ndarray (complex), sorted by (real, imag)
    k : float
        Leading-coefficient ratio (the paper's "high-frequency gain").
    """
    num, den = transfer_function(params, speed, ds, axle, actuator_pole, as_control=False)
    num = np.trim_zeros(np.asarray(num, float), 'f')
    zeros = np.roots(num) if len(num) > 1 else np.array([], complex)
    poles = np.roots(den)
    # exact integrators: the two trailing zeros of den
    poles = np.where(np.abs(poles) < 1e-12 * max(1.0, np.max(np.abs(poles))), 0.0, poles)
    k = float(num[0] / den[0])
    return _sort_roots(zeros), _sort_roots(poles), k


def _sort_roots(r):
    r = np.asarray(r, dtype=complex)
    return r[np.lexsort((r.imag, r.real))]
