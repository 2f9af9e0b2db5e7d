"""Sampled closed-loop simulation of a discrete controller on a linear plant ``B/A``.

Used by tests, :mod:`design_cli` and metric comparisons; it is *not* the vehicle
simulator (that lives in ``irs_vehicle_sim``). The plant ``y = B/A u`` (u steer [rad],
y lateral sensor displacement [m]) is discretised with zero-order hold at the controller
rate, so the loop is exact for the piecewise-constant steer.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from irs_models.zoh import zoh

from .discrete_rst import observable_canonical_miso
from .polynomials import trim

__all__ = ['LoopResult', 'simulate_loop']


@dataclass
class LoopResult:
    """Time histories of :func:`simulate_loop` (all length N).

    Attributes
    ----------
    t : numpy.ndarray  time [s]
    r : numpy.ndarray  reference u_c [m]
    y : numpy.ndarray  plant output y_s [m]
    u_unsat, u : numpy.ndarray  requested / applied steer [rad]
    saturated : numpy.ndarray of bool
    """

    t: np.ndarray
    r: np.ndarray
    y: np.ndarray
    u_unsat: np.ndarray
    u: np.ndarray
    saturated: np.ndarray


def simulate_loop(controller, B, A, reference, t_end: float, y0: float = 0.0) -> LoopResult:
    """Simulate ``controller`` (with ``.dt`` and ``.step(r, y)``) on the plant ``B/A``.

    Parameters
    ----------
    controller : object
        :class:`~irs_control.discrete_rst.DiscreteRstController` or
        :class:`~irs_control.discrete_pi.DiscretePiController`.
    B, A : array_like
        Strictly proper plant, s-domain, ``A`` monic.
    reference : callable
        ``reference(t) -> float`` set-point [m].
    t_end : float
        Duration [s].
    y0 : float
        Initial output (the plant state is set so that y = y0 with zero derivatives).
    """
    B, A = trim(B), trim(A)
    A = A / A[0]
    B = B / trim(A)[0]
    if B.size >= A.size:
        raise ValueError('simulate_loop expected a strictly proper plant (deg B < deg A).')
    Ac, Bc, Cc, Dc = observable_canonical_miso(A, [B])
    dt = controller.dt
    Ad, Bd = zoh(Ac, Bc, dt)
    n = int(round(t_end / dt)) + 1
    t = np.arange(n) * dt
    x = np.zeros(A.size - 1)
    x[0] = y0  # observable form: x0 = y; with no input this is only an equilibrium if A(0)=0
    out = {k: np.zeros(n) for k in ('r', 'y', 'u_unsat', 'u')}
    sat = np.zeros(n, dtype=bool)
    for k in range(n):
        y = float(Cc[0] @ x)
        r = float(reference(t[k]))
        o = controller.step(r, y)
        out['r'][k], out['y'][k], out['u_unsat'][k], out['u'][k] = r, y, o.u_unsat, o.u_sat
        sat[k] = o.saturated
        x = Ad @ x + Bd[:, 0] * o.u_sat
    return LoopResult(t=t, saturated=sat, **out)
