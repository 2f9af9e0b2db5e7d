"""Incremental wheel encoders: counts and windowed velocity (ROS-free).

Each wheel's angle ``theta`` [rad] (integrated from its spin) is quantised to whole counts::

    n_k = floor(theta_k N / (2 pi))                (N counts per revolution)

and the velocity is the count difference over a window of ``W`` samples (the last ``W + 1``
counts)::

    omega_k = 2 pi (n_k - n_{k-W}) / (N W dt)      [rad/s]

a moving average over ``W dt`` seconds, so it lags by ``W dt / 2`` and its resolution is
``2 pi / (N W dt)``.  Until ``W`` samples exist the window is the samples there are (0 at the
first sample).

Defaults: ``N = 2048`` (a 512-line quadrature encoder decoded x4 -- assumed, because that is
the common small hub-motor / magnetic encoder class and the paper gives no number) and
``W = 5`` samples at 1 kHz (5 ms, a lag of 2.5 ms): a resolution of 0.61 rad/s, i.e. 0.020 m/s
at the wheel's 0.033 m radius, 1.7 % slip at 1.2 m/s -- fine enough for an ABS slip target of
10 %.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ['EncoderParams', 'WheelEncoders']


@dataclass
class EncoderParams:
    """Encoder parameters.

    Attributes
    ----------
    counts_per_rev : int
        Counts per wheel revolution N (default 2048).
    window : int
        Velocity window W [samples] (default 5).
    """

    counts_per_rev: int = 2048
    window: int = 5

    def __post_init__(self):
        for name in ('counts_per_rev', 'window'):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f'EncoderParams.{name} must be an integer >= 1, got {v!r}.')


class WheelEncoders:
    """Four (or ``n``) encoders fed with the true wheel spins each step.

    Parameters
    ----------
    params : EncoderParams, optional
    n : int
        Number of wheels (default 4: FL, FR, RL, RR).
    """

    def __init__(self, params: EncoderParams | None = None, n: int = 4):
        self.params = params if params is not None else EncoderParams()
        self.n = int(n)
        self.reset()

    def reset(self, omega0=None, dt: float | None = None) -> None:
        """Angles and counts to zero; an empty velocity window, or with ``omega0`` [rad/s] and
        ``dt`` [s] a window primed as though the wheels had spun at ``omega0`` for the ``W``
        samples before (angles ``-j omega0 dt``, ``j = W..1``), so the first velocity is
        ``omega0`` to the count resolution instead of 0 (a run that starts rolling).
        """
        self.theta = np.zeros(self.n)
        self.counts = np.zeros(self.n, dtype=np.int64)
        self.velocity = np.zeros(self.n)
        self._hist = deque([self.counts.copy()], maxlen=self.params.window + 1)
        self._dts = deque(maxlen=self.params.window)
        if omega0 is None:
            return
        if dt is None or not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'priming the encoders needs a positive finite step dt in s, '
                             f'got {dt!r}.')
        w = np.broadcast_to(np.asarray(omega0, dtype=float), (self.n,))
        if not np.all(np.isfinite(w)):
            raise ValueError(f'omega0 must be finite wheel speeds [rad/s], got {omega0!r}.')
        n, W = self.params.counts_per_rev, self.params.window
        self._hist.clear()
        for j in range(W, 0, -1):
            self._hist.append(np.floor(-j * w * dt * n / (2.0 * math.pi)).astype(np.int64))
            self._dts.append(dt)
        self._hist.append(self.counts.copy())
        self.velocity = 2.0 * math.pi * (self._hist[-1] - self._hist[0]) / (n * W * dt)

    def step(self, omega, dt: float):
        """Advance ``dt`` [s] with true spins ``omega`` [rad/s] (held, i.e. the angle grows by
        ``omega dt``); returns ``(counts, velocity [rad/s])``.
        """
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite step in s, got {dt!r}.')
        w = np.asarray(omega, dtype=float)
        if w.shape != (self.n,) or not np.all(np.isfinite(w)):
            raise ValueError(f'omega must be {self.n} finite wheel speeds [rad/s], got {omega!r}.')
        n = self.params.counts_per_rev
        self.theta = self.theta + w * dt
        self.counts = np.floor(self.theta * n / (2.0 * math.pi)).astype(np.int64)
        self._hist.append(self.counts.copy())
        self._dts.append(dt)
        span = sum(self._dts)
        self.velocity = 2.0 * math.pi * (self._hist[-1] - self._hist[0]) / (n * span)
        return self.counts.copy(), self.velocity.copy()
