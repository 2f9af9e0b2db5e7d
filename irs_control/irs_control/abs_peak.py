"""Peak-seeking slip targets for the ABS: an online Burckhardt fit of mu(slip) per wheel.

ROS-free. Per wheel and sample, from measurements only (encoders, the applied torques, the
reference speed ``v`` of :mod:`.abs_reference`), ``s`` the braking slip (> 0), ``mu`` the used
friction (``_f``: first-order filter, time constant tau; T delayed by the encoders' lag)::

    sigma dkappa/dt = (omega R - v) - max(|v|, v_low) kappa      (the tyre's relaxed slip)
    F_x = (T_f - J domega_f/dt) / R,   F_z = F_z0 -+ m a_x h / (2 L),   a_x = sum F_x / m
    s = -kappa_f,  mu = -F_x / F_z,   fitted by  mu(s) = c1 (1 - exp(-c2 s)) - c3 s

Burckhardt 1993; Kiencke and Nielsen, Automotive Control Systems, 2005. The fit is linear in
``(c1, c3)`` for a fixed ``c2``: a bank of recursive least squares over a grid of ``c2``. It
exists because the fixed ABS target (-0.10) misses the friction peak on some surfaces; on a flat
curve the seeker stays the fixed-target ABS but for one probe. Settling, probing and the moves
of the target: :class:`PeakSeeker`.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from irs_common.field_checks import check_numbers

from .abs_reference import WheelSpeedObserver, WheelSpeedParams

__all__ = ['PeakSeekParams', 'PeakSeeker']

_G = 9.81
_P0 = 1e3          # initial covariance of (c1, c3): no prior
_SEEN = 100        # samples kept for the range of slips seen


@dataclass
class PeakSeekParams:
    """Parameters of the peak seeker (:class:`PeakSeeker`). Values chosen on the two-track model
    through the offline chassis loop (irs_bringup/offline_twin/chassis_loop.py), 1 kHz, W = 5.

    Attributes
    ----------
    baseline : float
        Starting target slip [-] (0.10, the fixed-target ABS's).
    slip_min, slip_max : float
        Range of the target [-] (0.05, 0.25: Burckhardt's snow to cobblestone peaks).
    gain_threshold : float
        Predicted relative friction gain needed to move [-] (0.03).
    sigmas : float
        Standard deviations of the predicted gain taken off it first [-] (1).
    knee : float
        The target is the lowest slip within this of the fit's maximum, relatively [-] (0.005).
    trust : float
        The target moves at most this beyond the slips seen [-] (0.03).
    confirm : int
        Samples in a row with the gain predicted before the target moves (10).
    probe, probe_samples, probe_after : float, int, int
        The probe: the target raised by 0.03 for 30 samples, 20 samples into a stop.
    forgetting : float
        RLS forgetting factor per sample [-] (0.98: a memory of 50 ms).
    c2_grid : tuple
        ``(min, max, count)`` of the log-spaced c2 grid [1/unit slip] (5, 150, 16).
    filter_time : float
        tau [s] (0.01).
    torque_delay : int
        Samples the torque is delayed by to meet the encoders' lag (3, for W = 5).
    quasi_steady, settle_slip, settle_samples : float, float, int
        q [-] (0.3), the slip tolerance [-] (0.01) and the samples (10) of a settled wheel.
    change_ratio, change_samples : float, int
        A surface change: this many residuals in a row above ``change_ratio |mu|`` (0.2, 5).
    v_learn : float
        Learning only above this speed [m/s] (0.2).
    min_samples : int
        Samples a fit needs before it moves the target (30).
    relaxation_length, v_low : float
        sigma of the tyre [m] and its low-speed regularisation [m/s] (0.02, 0.1: the
        two-track model's).
    lf, lr, cg_height : float
        Axle distances and c.g. height for the loads [m] (0.15, 0.15, 0.04).
    car : WheelSpeedParams
        Mass, wheel radius and inertia, rolling resistance.
    """

    baseline: float = 0.10
    slip_min: float = 0.05
    slip_max: float = 0.25
    gain_threshold: float = 0.03
    sigmas: float = 1.0
    knee: float = 0.005
    trust: float = 0.03
    confirm: int = 10
    probe: float = 0.03
    probe_samples: int = 30
    probe_after: int = 20
    forgetting: float = 0.98
    c2_grid: tuple = (5.0, 150.0, 16)
    filter_time: float = 0.01
    torque_delay: int = 3
    quasi_steady: float = 0.3
    settle_slip: float = 0.01
    settle_samples: int = 10
    change_ratio: float = 0.2
    change_samples: int = 5
    v_learn: float = 0.2
    min_samples: int = 30
    relaxation_length: float = 0.02
    v_low: float = 0.1
    lf: float = 0.15
    lr: float = 0.15
    cg_height: float = 0.04
    car: WheelSpeedParams = field(default_factory=WheelSpeedParams)

    def __post_init__(self):
        check_numbers(self, ('baseline', 'slip_min', 'slip_max', 'filter_time', 'quasi_steady',
                             'settle_slip', 'change_ratio', 'v_learn', 'relaxation_length',
                             'v_low', 'lf', 'lr'), above=0.0)
        check_numbers(self, ('gain_threshold', 'sigmas', 'knee', 'trust', 'probe', 'cg_height'),
                      at_least=0.0)
        if not 0.0 < self.slip_min <= self.baseline <= self.slip_max < 1.0:
            raise ValueError(f'PeakSeekParams needs 0 < slip_min <= baseline <= slip_max < 1, '
                             f'got {self.slip_min!r}, {self.baseline!r}, {self.slip_max!r}.')
        if not 0.0 < self.forgetting <= 1.0:
            raise ValueError(f'PeakSeekParams.forgetting must be in (0, 1], got '
                             f'{self.forgetting!r}.')
        for name in ('confirm', 'probe_samples', 'probe_after', 'torque_delay',
                     'settle_samples', 'change_samples', 'min_samples'):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ValueError(f'PeakSeekParams.{name} must be an integer >= 0, got {v!r}.')
        lo, hi, n = self.c2_grid
        if not (0.0 < lo < hi and isinstance(n, int) and n >= 2):
            raise ValueError(f'PeakSeekParams.c2_grid must be (min > 0, max > min, count >= 2), '
                             f'got {self.c2_grid!r}.')


class PeakSeeker:
    """Slip targets of the four wheels from a Burckhardt fit each.

    The fit and the moves of the target. (Burckhardt 1993; Kiencke and Nielsen, Automotive Control
    Systems, 2005): linear in ``(c1, c3)`` for a fixed ``c2``, so a bank of recursive least squares
    (forgetting ``lambda``) over a grid of ``c2``, the one of least discounted residual is the
    curve. A sample counts once the wheel has settled (filtered and raw slip within ``settle_slip``
    and ``|J domega_f/dt| < q |T_f|`` for ``settle_samples``): in transients the filtered pair is
    off the curve. A held slip only shows the curve at one point, so ``probe_after`` samples into a
    stop the target is raised by ``probe`` for ``probe_samples``. Then the target goes to the
    smallest slip within ``knee`` of the fit's maximum, clamped to ``trust`` around the slips seen,
    when the predicted gain less ``sigmas`` standard deviations (from the RLS covariance) exceeds
    ``gain_threshold`` for ``confirm`` samples; after a move up it probes again. Start: the fixed
    ABS's target (``baseline``); ``change_samples`` residuals above ``change_ratio |mu|`` (a new
    surface) restart the fit there. So on a flat curve it stays the fixed-target ABS but for one
    probe.
    """

    def __init__(self, params: PeakSeekParams | None = None, n: int = 4):
        self.params = params if params is not None else PeakSeekParams()
        p = self.params
        self.n = int(n)
        lo, hi, count = p.c2_grid
        self.c2 = np.geomspace(lo, hi, count)
        self.slips = np.linspace(p.slip_min, p.slip_max,
                                 int(round((p.slip_max - p.slip_min) / 1e-3)) + 1)
        self._rr = WheelSpeedObserver(p.car, n)      # its rolling-resistance torques
        load = p.car.mass * _G / (p.lf + p.lr)
        self.fz0 = np.array([load * p.lr / 2.0] * 2 + [load * p.lf / 2.0] * 2)[:self.n]
        self.sign = np.array([1.0, 1.0, -1.0, -1.0])[:self.n]     # front gains when braking
        self.reset()

    def reset(self) -> None:
        """Fits, filters, probes and targets back to the start."""
        n, g, p = self.n, self.c2.size, self.params
        self.theta = np.zeros((n, g, 2))
        self.cov = np.tile(np.eye(2) * _P0, (n, g, 1, 1))
        self.residual = np.zeros((n, g))
        self.samples = np.zeros(n, int)
        self.changes = np.zeros(n, int)
        self.agree = np.zeros(n, int)
        self.calm = np.zeros(n, int)
        self.braked = np.zeros(n, int)
        self.probing = np.zeros(n, int)
        self.probed = np.zeros(n, bool)
        self.restarts = 0
        self.target = np.full(n, p.baseline)
        self.seen = [deque(maxlen=_SEEN) for _ in range(n)]
        self.kappa = np.zeros(n)
        self.mu = np.zeros(n)
        self.slip = np.zeros(n)
        self._filt = None
        self._torques = deque(maxlen=p.torque_delay + 1)

    def curve(self, i: int, s) -> np.ndarray:
        """The best fit of wheel ``i`` at braking slips ``s`` [-]: mu [-]."""
        j = int(np.argmin(self.residual[i]))
        c1, c3 = self.theta[i, j]
        s = np.asarray(s, float)
        return c1 * (1.0 - np.exp(-self.c2[j] * s)) - c3 * s

    def output(self) -> np.ndarray:
        """The target braking slips now (raised by the probe while it runs) [-]."""
        p = self.params
        return np.minimum(self.target + np.where(self.probing > 0, p.probe, 0.0), p.slip_max)

    def step(self, omega, torques, v: float, learn, dt: float) -> np.ndarray:
        """Update with this sample; returns the target braking slips (> 0) [-].

        ``omega`` encoder speeds [rad/s], ``torques`` the torques applied over the last step
        [N m], ``v`` the reference speed [m/s], ``learn`` per wheel: braking under ABS now.
        """
        p = self.params
        w = np.asarray(omega, float)
        self._torques.append(np.asarray(torques, float) - self._rr.rolling_torques(w))
        t_d = self._torques[0]
        vv = max(abs(v), p.v_low)
        self.kappa += dt / p.relaxation_length * ((w * p.car.wheel_radius - v) - vv * self.kappa)
        if self._filt is None:
            self._filt = [w.copy(), t_d.copy(), self.kappa.copy()]
            return self.output()
        a = min(1.0, dt / p.filter_time)
        wf, tf, kf = self._filt
        wf += a * (w - wf)
        tf += a * (t_d - tf)
        kf += a * (self.kappa - kf)
        inertia = p.car.wheel_inertia * (w - wf) / p.filter_time
        fx = (tf - inertia) / p.car.wheel_radius
        ax = float(np.sum(fx)) / p.car.mass
        fz = self.fz0 - self.sign * p.car.mass * ax * p.cg_height / (2.0 * (p.lf + p.lr))
        self.mu = fx / np.maximum(fz, 1e-3)
        self.slip = -kf
        calm = ((np.abs(inertia) < p.quasi_steady * np.abs(tf))
                & (np.abs(self.kappa - kf) < p.settle_slip))
        self.calm = np.where(calm, self.calm + 1, 0)
        active = np.asarray(learn, bool) & (v > p.v_learn)
        for i in np.flatnonzero(active & (self.calm >= p.settle_samples)):
            self._learn(i, self.slip[i], -self.mu[i])
            if self.probing[i] == 0 and self.probed[i]:
                self._retarget(i)
        self._probe(active)
        return self.output()

    def _probe(self, active) -> None:
        """Count the stop's samples per wheel; start and end the probe."""
        p = self.params
        self.braked = np.where(active, self.braked + 1, 0)
        for i in range(self.n):
            if not active[i]:
                self.probing[i], self.probed[i] = 0, False       # the next stop probes again
            elif self.probing[i] > 0:
                self.probing[i] -= 1
                self.probed[i] = self.probing[i] == 0
            elif not self.probed[i] and self.braked[i] > p.probe_after:
                self.probing[i] = p.probe_samples

    def _learn(self, i: int, s: float, y: float) -> None:
        p = self.params
        phi = np.stack([1.0 - np.exp(-self.c2 * s), np.full(self.c2.size, -s)], axis=-1)
        cov, th = self.cov[i], self.theta[i]
        e = y - np.einsum('gk,gk->g', phi, th)
        cphi = np.einsum('gkl,gl->gk', cov, phi)
        gain = cphi / (p.forgetting + np.einsum('gk,gk->g', phi, cphi))[:, None]
        self.theta[i] = th + gain * e[:, None]
        self.cov[i] = (cov - np.einsum('gk,gl->gkl', gain, cphi)) / p.forgetting
        j = int(np.argmin(self.residual[i]))
        self.residual[i] = p.forgetting * self.residual[i] + e * e
        self.samples[i] += 1
        self.seen[i].append(s)
        if self.samples[i] <= p.min_samples:
            return
        self.changes[i] = self.changes[i] + 1 if abs(e[j]) > p.change_ratio * abs(y) else 0
        if self.changes[i] >= p.change_samples:        # the surface changed: start again
            self.theta[i] = 0.0
            self.cov[i] = np.eye(2) * _P0
            self.residual[i] = 0.0
            self.samples[i] = self.changes[i] = self.agree[i] = 0
            self.seen[i].clear()
            self.target[i] = p.baseline
            self.probing[i], self.probed[i], self.braked[i] = 0, False, 0
            self.restarts += 1

    def _retarget(self, i: int) -> None:
        p = self.params
        if self.samples[i] <= p.min_samples:
            return
        f = self.curve(i, self.slips)
        k = int(np.argmax(f >= (1.0 - p.knee) * f.max()))
        lo, hi = min(self.seen[i]) - p.trust, max(self.seen[i]) + p.trust
        k = int(np.argmin(np.abs(self.slips - min(max(self.slips[k], lo), hi))))
        now = float(self.curve(i, [self.target[i]])[0])
        # the predicted gain's standard deviation: RLS covariance times the residual variance
        j = int(np.argmin(self.residual[i]))
        c2 = self.c2[j]
        g = np.array([np.exp(-c2 * self.target[i]) - np.exp(-c2 * self.slips[k]),
                      self.target[i] - self.slips[k]])
        var = float(g @ self.cov[i, j] @ g) * self.residual[i, j] * (1.0 - p.forgetting)
        gain = f[k] - now - p.sigmas * np.sqrt(max(var, 0.0))
        self.agree[i] = self.agree[i] + 1 if gain > p.gain_threshold * now else 0
        if self.agree[i] >= max(p.confirm, 1):
            self.probed[i] = self.slips[k] <= self.target[i]    # climbing: probe again above
            self.target[i] = float(self.slips[k])
            self.agree[i] = 0
