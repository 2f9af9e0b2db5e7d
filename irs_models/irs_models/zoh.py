"""Exact zero-order-hold discretisation of a continuous state-space model.

For ``x' = A x + B u`` with ``u`` held over each step ``dt`` [s]::

    x[k+1] = Ad x[k] + Bd u[k],      [[Ad, Bd], [0, I]] = expm(dt [[A, B], [0, 0]])

This is the ``method='zoh'`` branch of ``scipy.signal.cont2discrete``, operation for operation
(the same block matrix, ``dt`` times it, ``scipy.linalg.expm``), so the results are equal to the
bit (``irs_models/test/test_zoh.py`` checks it against ``cont2discrete``). It exists because the
nodes that discretise at start-up (the rig, the RST controller, the board emulator) would
otherwise import ``scipy.signal``, which costs about 0.8 s of CPU more than ``scipy.linalg`` at
every process start; the cores need nothing else from it.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

__all__ = ['zoh']


def zoh(A, B, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Ad, Bd)`` of ``x' = A x + B u`` (``A`` n x n, ``B`` n x m) for a held input over
    steps of ``dt`` [s]; equal to ``cont2discrete((A, B, C, D), dt, method='zoh')[:2]``.
    """
    a = np.asarray(A)
    b = np.asarray(B)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or b.ndim != 2 or b.shape[0] != a.shape[0]:
        raise ValueError(f'zoh expected A n x n and B n x m, got {a.shape} and {b.shape}')
    em_upper = np.hstack((a, b))
    em_lower = np.hstack((np.zeros((b.shape[1], a.shape[0])), np.zeros((b.shape[1], b.shape[1]))))
    ms = linalg.expm(dt * np.vstack((em_upper, em_lower)))[:a.shape[0], :]
    return ms[:, :a.shape[1]], ms[:, a.shape[1]:]
