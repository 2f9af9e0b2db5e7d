r"""Many discrete linear systems stepped at once (numpy), for sweeps over linear plants.

Pure numpy/scipy; no rclpy.

``M`` systems of the same shape (``n`` states, ``m`` inputs, ``p`` outputs), one per sweep
point::

    x_i[k+1] = Ad_i x_i[k] + Bd_i u_i[k]
    y_i[k]   = C_i  x_i[k] + D_i  u_i[k]          i = 0 .. M-1

:meth:`BatchLti.simulate` runs all ``M`` with one ``numpy.einsum`` per time step (the Python
loop is over time only, its cost shared by the ``M`` systems), which is what
``scipy.signal.dlsim`` does for one system (a Python loop over time with a matrix product per
step); the results are the same to round-off (tested against ``dlsim``).
:meth:`BatchLti.from_continuous` discretises each continuous ``(A, B, C, D)`` by exact
zero-order hold (``scipy.signal.cont2discrete``), as :class:`irs_models.lateral_plant.ZohSteps`
does for the rig's plants.
"""
from __future__ import annotations

import numpy as np

__all__ = ['BatchLti']


class BatchLti:
    """``M`` discrete systems of one shape; arrays ``Ad (M,n,n)``, ``Bd (M,n,m)``,
    ``C (M,p,n)``, ``D (M,p,m)``; ``dt`` [s] the sample period.
    """

    def __init__(self, Ad, Bd, C, D, dt: float):
        self.Ad, self.Bd, self.C, self.D = (np.asarray(a, dtype=float) for a in (Ad, Bd, C, D))
        M, n, n2 = self.Ad.shape
        if n != n2 or self.Bd.shape[:2] != (M, n) or self.C.shape[0] != M \
                or self.C.shape[2] != n or self.D.shape != (M, self.C.shape[1], self.Bd.shape[2]):
            raise ValueError(
                'shapes must be Ad (M,n,n), Bd (M,n,m), C (M,p,n), D (M,p,m); got '
                f'{self.Ad.shape}, {self.Bd.shape}, {self.C.shape}, {self.D.shape}')
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f'dt must be a positive sample period in s, got {dt!r}')
        self.dt = float(dt)

    @property
    def size(self) -> int:
        return self.Ad.shape[0]

    @classmethod
    def from_continuous(cls, systems, dt: float) -> 'BatchLti':
        """Exact ZOH of each continuous ``(A, B, C, D)`` in ``systems`` (same shapes)."""
        from scipy.signal import cont2discrete
        mats = [cont2discrete(tuple(np.atleast_2d(np.asarray(a, float)) for a in s), dt,
                              method='zoh')[:4] for s in systems]
        return cls(*(np.stack([m[i] for m in mats]) for i in range(4)), dt)

    def simulate(self, u, x0=None) -> tuple[np.ndarray, np.ndarray]:
        """Outputs and states for inputs ``u`` of shape ``(M, N, m)`` (or ``(N, m)``/``(N,)``:
        the same input for every system).

        Returns ``y (M, N, p)`` and ``x (M, N, n)``: ``y[:, k]``, ``x[:, k]`` at sample k
        (``x[:, 0] = x0``, zero by default), as ``scipy.signal.dlsim`` numbers them.
        """
        M, n, m = self.size, self.Ad.shape[1], self.Bd.shape[2]
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        if u.ndim == 2:
            u = np.broadcast_to(u, (M,) + u.shape)
        if u.shape[0] != M or u.shape[2] != m:
            raise ValueError(f'u must have shape (M={M}, N, m={m}); got {u.shape}')
        N = u.shape[1]
        x = np.empty((M, N, n))
        x[:, 0] = 0.0 if x0 is None else np.broadcast_to(np.asarray(x0, float), (M, n))
        Ad, Bd = self.Ad, self.Bd
        for k in range(N - 1):
            x[:, k + 1] = (np.einsum('mij,mj->mi', Ad, x[:, k])
                           + np.einsum('mij,mj->mi', Bd, u[:, k]))
        y = np.einsum('mpn,mkn->mkp', self.C, x) + np.einsum('mpq,mkq->mkp', self.D, u)
        return y, x
