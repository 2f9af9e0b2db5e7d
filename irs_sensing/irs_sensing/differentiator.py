"""Causal numerical differentiators for the arm pose (paper Sec. 3.2).

The paper differentiates the arm pose numerically ("instead of using analytical derivatives of
Equation (3)").  Two filters are provided; both are fixed-step (sample period ``dt`` [s]) and
are linear time-invariant, described by ``H(z) = B(z^-1) / A(z^-1)`` with
``y_k = (sum_i b_i x_{k-i} - sum_{i>=1} a_i y_{k-i}) / a_0``.

:class:`BackwardDifferenceLowPass` is a backward difference then a first-order low pass with
cut-off ``fc`` [Hz] (``'matched'`` or ``'zoh'``); :class:`SavitzkyGolayDifferentiator` the
slope, at the newest sample, of a least-squares polynomial over the last ``N`` samples. Each
reports its ``transfer_function()``, its low-frequency ``group_delay()`` [s] and its
``noise_gain()`` [-] (:class:`Differentiator`), so the delay and the noise of a choice are
numbers, not guesses (docs/sensing.md).
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

__all__ = ['Differentiator', 'BackwardDifferenceLowPass', 'SavitzkyGolayDifferentiator',
           'make_differentiator']


class Differentiator:
    """Base class: LTI causal differentiator ``H(z) = B/A`` at sample period ``dt`` [s].

    Figures of merit:

    ``transfer_function()``
        ``(b, a)`` coefficient arrays in powers of ``z^-1`` (``scipy.signal.lfilter`` convention).
    ``group_delay()`` [s]
        Delay of the estimate relative to the true derivative at low frequency:
        ``H(e^{jwT}) ~ jw e^{-jw tau_d}`` as ``w -> 0``.  With ``B(z) = (1 - z^-1) B'(z)``,
        ``tau_d = dt/2 + dt (sum k b'_k / sum b'_k - sum k a_k / sum a_k)``.
        A parabola ``x = t^2/2`` (derivative ``t``) is differentiated to ``t - tau_d`` in steady
        state.
    ``noise_gain()`` [-]
        For white input noise of std ``sigma``, the output std is ``sigma sqrt(sum h_k^2)``. The
        gain is reported normalised by ``sigma/dt``: ``G = dt sqrt(sum_k h_k^2)`` (``h`` the
        impulse response, computed by running the recursion until it has decayed). A plain
        backward difference has ``G = sqrt(2)``.
    """

    _settling: int | None = None

    def __init__(self, dt: float, b: np.ndarray, a: np.ndarray) -> None:
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a finite sample period > 0 s, got {dt!r}.')
        self.dt = float(dt)
        self._b = np.asarray(b, dtype=float)
        self._a = np.asarray(a, dtype=float)
        # The running filter works on plain floats: the coefficients as tuples, the histories
        # as lists (numpy on 2- and 3-element arrays costs more than the arithmetic).
        self._bt = tuple(float(v) for v in self._b)
        self._at = tuple(float(v) for v in self._a[1:])
        self._a0 = float(self._a[0])
        self.reset()

    # ------------------------------------------------------------------ running filter
    def reset(self) -> None:
        """Forget the history; the next sample initialises it (output 0 at start)."""
        self._x: Optional[list] = None
        self._y = [0.0] * max(len(self._a) - 1, 0)
        self.samples_since_reset = 0

    def update(self, x: float) -> float:
        """Feed sample ``x`` (the signal at the newest instant); return its derivative [x/s].

        ``y_k = (sum_i b_i x_{k-i} - sum_{i>=1} a_i y_{k-i}) / a_0``, each sum accumulated from
        the newest sample on; the histories are newest first.
        """
        if not math.isfinite(x):
            raise ValueError(f'differentiator input must be finite, got {x!r}.')
        xs = self._x
        if xs is None:
            xs = self._x = [float(x)] * len(self._bt)
        else:
            xs.pop()
            xs.insert(0, x)
        y = 0.0
        for b, v in zip(self._bt, xs):
            y += b * v
        ys = self._y
        if ys:
            acc = 0.0
            for a, v in zip(self._at, ys):
                acc += a * v
            y -= acc
            ys.pop()
            ys.insert(0, y / self._a0)
        y /= self._a0
        self.samples_since_reset += 1
        return y

    @property
    def settling_samples(self) -> int:
        """Samples after a reset before the output is trusted [-] (overridden)."""
        return len(self._b)

    @property
    def ready(self) -> bool:
        """True once ``settling_samples`` samples have been fed since the last reset."""
        n: int | None = self._settling
        if n is None:   # fixed by the filter's parameters: computed once
            n = self._settling = self.settling_samples
        return self.samples_since_reset >= n

    # ------------------------------------------------------------------ analysis
    def transfer_function(self) -> Tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` in powers of ``z^-1`` [output units: input units per second]."""
        return self._b.copy(), self._a.copy()

    def impulse_response(self, n: Optional[int] = None) -> np.ndarray:
        """First ``n`` samples of the impulse response (default: until decayed to 1e-12)."""
        from scipy.signal import lfilter

        if n is None:
            n = len(self._b) + 16
            if len(self._a) > 1:
                # slowest pole magnitude -> samples to decay by 1e-14
                r = float(np.max(np.abs(np.roots(self._a)))) if len(self._a) > 1 else 0.0
                if 0.0 < r < 1.0:
                    n = max(n, int(math.ceil(math.log(1e-14) / math.log(r))) + len(self._b))
        imp = np.zeros(n)
        imp[0] = 1.0
        return lfilter(self._b, self._a, imp)

    def group_delay(self) -> float:
        """Low-frequency delay of the derivative estimate [s] (see the class docstring)."""
        bp, rem = np.polydiv(self._b, np.array([1.0, -1.0]))  # B = (1 - z^-1) B'
        if np.max(np.abs(rem)) > 1e-9 * max(1.0, np.max(np.abs(self._b))):
            raise ValueError('filter has no zero at z = 1, it is not a differentiator.')
        k_b = np.arange(len(bp))
        k_a = np.arange(len(self._a))
        return self.dt * (0.5 + float(k_b @ bp) / float(np.sum(bp))
                          - float(k_a @ self._a) / float(np.sum(self._a)))

    def dc_slope_gain(self) -> float:
        """Gain on a unit ramp (1 for a correct differentiator) [-]."""
        bp, _ = np.polydiv(self._b, np.array([1.0, -1.0]))
        return float(np.sum(bp) / np.sum(self._a)) * self.dt

    def noise_gain(self) -> float:
        """White-noise gain ``dt sqrt(sum h_k^2)`` = std(out) / (std(in)/dt) [-]."""
        h = self.impulse_response()
        return self.dt * float(np.sqrt(np.sum(h * h)))

    def frequency_response(self, f_hz: np.ndarray) -> np.ndarray:
        """Complex ``H(e^{j 2 pi f dt})`` at frequencies ``f_hz`` [Hz]."""
        z1 = np.exp(-1j * 2 * np.pi * np.asarray(f_hz, dtype=float) * self.dt)
        num = np.polyval(self._b[::-1], z1)
        den = np.polyval(self._a[::-1], z1)
        return num / den


class BackwardDifferenceLowPass(Differentiator):
    """Backward difference followed by a first-order low pass.

    The low pass has the cut-off ``fc`` [Hz], ``tau = 1/(2 pi fc)``,
    ``alpha = exp(-dt/tau)`` (the exact image of the continuous pole ``-1/tau``)::

        'matched' (default):  H(z) = (1 - z^-1)/dt * (1 - alpha) / (1 - alpha z^-1)
        'zoh':                H(z) = (1 - z^-1)/dt * (1 - alpha) z^-1 / (1 - alpha z^-1)

    'zoh' is the exact zero-order-hold discretization of 1/(tau s + 1); it costs one extra sample
    of delay, so the pole-matched form with unit DC gain is the default. Low-frequency delay:
    ``dt/2 + alpha dt/(1 - alpha)`` (+ ``dt`` for 'zoh').

    Parameters
    ----------
    dt : float
        Sample period [s].
    cutoff_hz : float
        Low-pass cut-off ``fc`` [Hz], ``0 < fc``; ``alpha = exp(-2 pi fc dt)``.
    discretization : {'matched', 'zoh'}
        See above.
    """

    def __init__(self, dt: float, cutoff_hz: float, discretization: str = 'matched') -> None:
        if not (isinstance(cutoff_hz, (int, float)) and math.isfinite(cutoff_hz)
                and cutoff_hz > 0.0):
            raise ValueError(f'cutoff_hz must be a finite frequency > 0 Hz, got {cutoff_hz!r}.')
        if discretization not in ('matched', 'zoh'):
            raise ValueError(f"discretization must be 'matched' or 'zoh', got {discretization!r}.")
        self.cutoff_hz = float(cutoff_hz)
        self.discretization = discretization
        alpha = math.exp(-2.0 * math.pi * cutoff_hz * dt)
        self.alpha = alpha
        g = (1.0 - alpha) / dt
        if discretization == 'matched':
            b = np.array([g, -g])
        else:
            b = np.array([0.0, g, -g])
        super().__init__(dt, b, np.array([1.0, -alpha]))

    @property
    def settling_samples(self) -> int:
        """About five low-pass time constants [samples]."""
        tau = 1.0 / (2.0 * math.pi * self.cutoff_hz)
        return max(2, int(math.ceil(5.0 * tau / self.dt)))

    def analytic_group_delay(self) -> float:
        """Closed form ``dt/2 + alpha dt/(1-alpha)`` (+ dt for 'zoh') [s]."""
        extra = self.dt if self.discretization == 'zoh' else 0.0
        return self.dt / 2 + self.alpha * self.dt / (1 - self.alpha) + extra

    def analytic_noise_gain(self) -> float:
        """Closed form ``sqrt(2 (1 - alpha) / (1 + alpha))`` [-].

        ``h = g (1-z^-1)/(1 - alpha z^-1)``: ``h_0 = g``, ``h_k = g (alpha - 1) alpha^{k-1}``,
        ``sum h^2 = g^2 (1 + (1-alpha)^2/(1-alpha^2)) = 2 g^2/(1+alpha)``, ``g = (1-alpha)/dt``.
        """
        a = self.alpha
        return math.sqrt(2.0 * (1 - a) ** 2 / (1 + a))


class SavitzkyGolayDifferentiator(Differentiator):
    """Causal least-squares polynomial-fit (Savitzky-Golay) derivative at the newest sample.

    A least-squares polynomial of order ``p`` is fitted to the newest ``N`` samples and its slope
    evaluated at the newest sample. FIR with ``h_m = [pinv(V)]_{1, N-1-m}``, ``V_{ij} =
    t_i^j``, ``t_i = -(N-1-i) dt``. Low-frequency delay ``(N-1) dt / 2`` for ``p = 1``; 0 for ``p
    >= 2`` (exact for ramps and parabolas, paid for with a larger noise gain).

    Parameters
    ----------
    dt : float
        Sample period [s].
    window : int
        Number of samples ``N`` in the fit, ``N >= order + 1`` and ``N >= 2``.
    order : int
        Polynomial order ``p >= 1``.
    """

    def __init__(self, dt: float, window: int, order: int = 1) -> None:
        if not isinstance(order, int) or isinstance(order, bool) or order < 1:
            raise ValueError(f'order must be an integer >= 1, got {order!r}.')
        if not isinstance(window, int) or isinstance(window, bool) or window < order + 1 \
                or window < 2:
            raise ValueError(f'window must be an integer >= order + 1 = {order + 1}, got '
                             f'{window!r}.')
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a finite sample period > 0 s, got {dt!r}.')
        self.window = window
        self.order = order
        t = -(window - 1 - np.arange(window)) * float(dt)   # oldest ... newest (= 0)
        vander = np.vander(t, order + 1, increasing=True)
        coef_row = np.linalg.pinv(vander)[1]                # d/dt of fit at t = 0
        b = coef_row[::-1].copy()                           # b_m multiplies x_{k-m}
        super().__init__(dt, b, np.array([1.0]))

    @property
    def settling_samples(self) -> int:
        return self.window

    def analytic_group_delay(self) -> float:
        """``(N-1) dt/2`` for order 1, 0 for order >= 2 [s]."""
        return (self.window - 1) * self.dt / 2 if self.order == 1 else 0.0


def make_differentiator(kind: str, dt: float, cutoff_hz: float = 10.0, window: int = 10,
                        order: int = 1, discretization: str = 'matched') -> Differentiator:
    """Factory: ``kind`` is ``'lowpass'`` (backward difference + low pass) or ``'savgol'``."""
    if kind == 'lowpass':
        return BackwardDifferenceLowPass(dt, cutoff_hz, discretization)
    if kind == 'savgol':
        return SavitzkyGolayDifferentiator(dt, window, order)
    raise ValueError(f"differentiator kind must be 'lowpass' or 'savgol', got {kind!r}.")
