r"""Dynamic similitude of the bicycle model: the 1:10 cars against the full-size presets.

Lengths scale with the wheelbase ``L = l_f + l_r``, times with ``L/V``, masses with ``m``. The
dimensionless bicycle model (:class:`PiGroups` derives it) depends on these groups [-]::

    Pi1 = l_f / L              Pi2 = l_r / L = 1 - Pi1          (weight distribution)
    Pi3 = C_f L / (m V^2)      Pi4 = C_r L / (m V^2)            (tyre stiffness vs inertia force)
    Pi5 = I_z / (m L^2)                                          (yaw inertia ratio)
    Pi6 = d_s / L                                                (sensor point)

Two cars with equal Pi1, Pi3, Pi4, Pi5 have identical responses ``r'(tau)``, ``v'(tau)`` to the
same steer angle: that is the mapping between the 1:10 car and a full-size car. A derived group
is the dimensionless understeer gradient ``Pi_us = K_us V^2 / L = Pi2/Pi3 - Pi1/Pi4`` with
``K_us = m (l_r/C_f - l_f/C_r) / L`` [rad s^2/m] (steady turn: ``delta = (L/R)(1 + Pi_us)``;
> 0 understeer, < 0 oversteer).

It exists to say how far a 1:10 car at a given speed is dynamically similar to a full-size car
(:func:`mismatch`, :func:`best_speed`) and which speed scaling matches them
(:func:`froude_speed`, :func:`equal_time_speed`). Pure Python (numpy, scipy); no rclpy.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from .bicycle import BicycleParams

__all__ = ['PiGroups', 'pi_groups', 'mismatch', 'best_speed', 'SpeedMatch',
           'dimensionless_step', 'dimensionless_roots', 'equal_time_speed', 'froude_speed',
           'MATCHED_GROUPS']

#: The groups the mismatch compares (log ratios).
MATCHED_GROUPS = ('pi1', 'pi3', 'pi4', 'pi5')


@dataclass(frozen=True)
class PiGroups:
    """The dimensionless groups of one car at one speed (defined in the module docstring) [-].

    Take the wheelbase ``L = l_f + l_r`` as the length, ``L/V`` as the time and the mass ``m`` as
    the mass scale: ``tau = t V / L``, ``v' = v_y / V`` (= sideslip angle), ``r' = r L / V``, ``y'
    = y / L``. Dividing the bicycle equations of :mod:`irs_models.bicycle` (``m (v_y' + V r) = F_f
    + F_r``, ``I_z r' = l_f F_f - l_r F_r``, ``F_f = C_f (delta_f - (v_y + l_f r)/V)``, ``F_r =
    -C_r (v_y - l_r r)/V``, ``y' = v_y + V psi``, ``psi' = r``) by ``m V^2 / L`` and ``m V^2``
    gives::

        dv'/dtau = -r' + Pi3 (delta_f - v' - Pi1 r') - Pi4 (v' - Pi2 r')
        dr'/dtau = [Pi1 Pi3 (delta_f - v' - Pi1 r') + Pi2 Pi4 (v' - Pi2 r')] / Pi5
        dy'/dtau = v' + psi,    dpsi/dtau = r',    y_s' = y' + Pi6 psi

    with the Pi-groups of the module docstring (Buckingham: 7 quantities m, I_z, l_f, l_r, C_f,
    C_r, V in 3 units leave 4 independent groups, plus the sensor's ``d_s``; derived here from the
    equations above. The IRS paper itself defines none -- it only says the scale cars' dynamics are
    "similar enough" to the full-size ones of Eqs. 7-10 -- and we recall, without the source at
    hand, that its authors' later dimensionless analysis of the IRS cars used groups of this form).
    """

    pi1: float
    pi2: float
    pi3: float
    pi4: float
    pi5: float
    pi6: float
    understeer: float      # Pi_us = K_us V^2 / L

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in ('pi1', 'pi2', 'pi3', 'pi4', 'pi5', 'pi6',
                                              'understeer')}


def pi_groups(p: BicycleParams, speed: float, ds: float = 0.0) -> PiGroups:
    """Pi-groups of the car ``p`` at ``speed`` [m/s] with a sensor ``ds`` [m] ahead."""
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f'speed must be a positive finite speed in m/s, got {speed!r}')
    L = p.wheelbase
    pi3 = p.c_f * L / (p.mass * speed ** 2)
    pi4 = p.c_r * L / (p.mass * speed ** 2)
    pi1, pi2 = p.lf / L, p.lr / L
    return PiGroups(pi1=pi1, pi2=pi2, pi3=pi3, pi4=pi4, pi5=p.yaw_inertia / (p.mass * L ** 2),
                    pi6=float(ds) / L, understeer=pi2 / pi3 - pi1 / pi4)


def mismatch(a: PiGroups, b: PiGroups) -> float:
    """RMS of the log ratios of :data:`MATCHED_GROUPS` [-] (0: dynamically similar)."""
    r = [math.log(getattr(a, g) / getattr(b, g)) for g in MATCHED_GROUPS]
    return float(np.sqrt(np.mean(np.square(r))))


@dataclass(frozen=True)
class SpeedMatch:
    """Outcome of :func:`best_speed`."""

    speed: float               # [m/s] scale car's best-matching speed
    mismatch: float            # [-] RMS log ratio there
    froude_speed: float        # [m/s] V_full sqrt(L_scale / L_full), for comparison
    speeds: np.ndarray         # [m/s] the swept grid
    mismatches: np.ndarray     # [-] mismatch on the grid
    log_ratios: dict           # group -> log(Pi_scale / Pi_full) at the best speed


def best_speed(scale: BicycleParams, full: BicycleParams, full_speed: float,
               speeds=None) -> SpeedMatch:
    """The scale car's speed whose groups best match ``full`` at ``full_speed`` [m/s].

    :func:`mismatch` is the RMS of ``log(Pi_i,scale / Pi_i,full)`` over Pi1, Pi3, Pi4, Pi5 (Pi2 is
    1 - Pi1; Pi6 is a sensor choice, not the car). Only Pi3 and Pi4 depend on V, so the best speed
    is where ``log V^2`` equals the mean of their log ratios at V = 1; :func:`best_speed` sweeps
    ``speeds`` (a grid) and refines the minimum with ``scipy.optimize.minimize_scalar`` (bounded to
    the grid's neighbours). The speed-independent groups (Pi1, Pi5) set a floor no speed can
    remove.
    """
    from scipy.optimize import minimize_scalar
    speeds = np.geomspace(0.1, 10.0, 400) if speeds is None else np.asarray(speeds, float)
    target = pi_groups(full, full_speed)
    m = np.array([mismatch(pi_groups(scale, v), target) for v in speeds])
    i = int(np.argmin(m))
    lo, hi = speeds[max(i - 1, 0)], speeds[min(i + 1, speeds.size - 1)]
    best, best_m = float(speeds[i]), float(m[i])
    if hi > lo:
        res = minimize_scalar(lambda v: mismatch(pi_groups(scale, v), target),
                              bounds=(lo, hi), method='bounded',
                              options={'xatol': 1e-9 * hi})
        if res.fun <= best_m:
            best, best_m = float(res.x), float(res.fun)
    g = pi_groups(scale, best)
    ratios = {k: math.log(getattr(g, k) / getattr(target, k)) for k in MATCHED_GROUPS}
    return SpeedMatch(speed=best, mismatch=best_m,
                      froude_speed=full_speed * math.sqrt(scale.wheelbase / full.wheelbase),
                      speeds=speeds, mismatches=m, log_ratios=ratios)


def dimensionless_step(p: BicycleParams, speed: float, tau_end: float = 20.0, n: int = 2001):
    """Response to a unit front-steer step on scaled axes.

    Returns ``(tau, r', v')``: ``tau = t V / L`` [-], dimensionless yaw rate ``r L / V`` and
    sideslip ``v_y / V`` per radian of steer, from :func:`irs_models.bicycle.bicycle_state_space`
    simulated by ``scipy.signal.lsim`` at ``t = tau L / V``.
    """
    from scipy.signal import lsim

    from .bicycle import bicycle_state_space
    A, B, _C, _D = bicycle_state_space(p, speed, 0.0)
    L = p.wheelbase
    tau = np.linspace(0.0, tau_end, n)
    t = tau * L / speed
    C = np.array([[0.0, L / speed, 0.0, 0.0], [1.0 / speed, 0.0, 0.0, 0.0]])
    _, y, _ = lsim((A, B[:, :1], C, np.zeros((2, 1))), np.ones_like(t), t)
    return tau, y[:, 0], y[:, 1]


def froude_speed(full_speed: float, scale_length: float, full_length: float) -> float:
    """Froude-similar speed [m/s] of a car of ``scale_length`` [m]: ``V_full sqrt(L_s / L_f)``
    (equal ``V^2 / (g L)``; similar when ``C/m`` is the same).

    Speed scaling: Pi3 and Pi4 are the only speed-dependent groups, both ``prop. 1/V^2``, so
    matching them at fixed tyre stiffness per unit mass ``C/m`` gives ``V_scale = V_full
    sqrt(L_scale / L_full) sqrt((C/m)_scale / (C/m)_full)``: speed scales with the square root of
    length (Froude scaling when ``C/m`` is the same, as for tyres whose stiffness is proportional
    to load); times then scale with ``sqrt(L)`` and poles in rad/s with ``1/sqrt(L)``. The paper's
    own comparison, the 1:10 car at 1.2 m/s against full-size cars at 12 m/s by their poles in
    rad/s, is the other scaling, **equal L/V** (:func:`equal_time_speed`): the time scale ``L/V``
    is the same, so dimensionless and rad/s poles compare alike, and Pi3, Pi4 match only if ``C/m``
    scales with ``L``. :func:`dimensionless_roots` gives poles and zeros as ``s L / V``.
    """
    return full_speed * math.sqrt(scale_length / full_length)


def equal_time_speed(full_speed: float, scale_length: float, full_length: float) -> float:
    """Speed [m/s] at which a car of ``scale_length`` [m] has the full-size car's time scale
    ``L/V``: ``V_full L_s / L_f`` (poles in rad/s then compare as dimensionless ones).
    """
    return full_speed * scale_length / full_length


def dimensionless_roots(roots, length: float, speed: float) -> np.ndarray:
    """Poles or zeros ``s`` [1/s] on the car's time scale: ``s L / V`` [-] (complex)."""
    if not (math.isfinite(length) and length > 0 and math.isfinite(speed) and speed > 0):
        raise ValueError(f'length and speed must be positive finite [m], [m/s], got '
                         f'{length!r} and {speed!r}')
    return np.asarray(roots, dtype=complex) * (length / speed)
