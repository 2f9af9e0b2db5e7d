"""Treadmill belt model of the IRS (paper Sec. 3.1, Eq. 1, Eq. 2).

The state is the belt *surface* speed ``V >= 0`` [m/s] (the surface moves in -x of the
``treadmill`` frame, ``docs/conventions.md``); ``position`` is the belt travel [m]. Eq. 1 is
written in ``V``, with inertia, damping and friction referred to the belt surface::

    dV/dt = max( -a V + b u_d ,  -c (V + k) )        (drive on, u_d > 0)
    dV/dt = -c (V + k)  for V > 0,  0 at V = 0       (drive off, u_d <= 0)

``a = 4.5 1/s`` and ``b = 2.38 m/s^2/V`` (Eq. 2, ``V/U = 2.38/(s + 4.5)`` [m/s/V]),
``c = B/J = 0.158 1/s``, ``k = F/B = 0.270 m/s``, ``u_d(t) = clip(u(t - T_d), 0, u_max)``;
steady state ``V = (b/a) u = 0.5289 m/s/V * u``, clamped to ``[0, v_top]`` (15 mph). The motor
only adds torque, so the drive cannot slow the belt faster than friction does (the ``max``).
Coast-down: ``V(t) = (V0 + F/B) exp(-(B/J) t) - F/B``, ``t_stop = (J/B) ln(1 + V0 B/F)``.

It exists so the rig has a belt that behaves like the paper's (drive delay, one-sided torque,
quantised encoder speed) and is stepped exactly and deterministically for any step size.
Reconstruction of Eq. 1 from the OCR and the three readings of the units of F/B:
docs/treadmill.md.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Deque, List, Tuple

from irs_common.field_checks import check_numbers

__all__ = ['BeltParams', 'TreadmillBelt', 'BeltEncoder', 'coast_speed', 'coast_stop_time',
           'coast_distance', 'MPH']

MPH = 0.44704  # [m/s] per mph


@dataclass(frozen=True)
class BeltParams:
    """Parameters of the treadmill belt model.

    Parameters
    ----------
    gain : float
        ``b`` of Eq. 2: high-frequency gain [m/s^2 per V] (paper: 2.38).
    pole : float
        ``a`` of Eq. 2: closed-loop drive pole [1/s] (paper: 4.5).
    b_over_j : float
        ``c = B/J`` [1/s] (paper: 0.158).
    f_over_b : float
        ``k = F/B`` [m/s] (paper: 0.270; 1.709 and 0.0137 are the other readings of its
        units, docs/treadmill.md). ``sysid treadmill`` identifies F/B in m/s from belt-speed
        data and recovers whichever of the three is configured.
    v_top : float
        Hard speed clamp [m/s] (15 mph = 6.7056 m/s).
    u_max : float
        Drive voltage range upper limit [V]; input is clamped to ``[0, u_max]`` (12.7 V: the
        smallest round value at which Eq. 2 reaches ``v_top`` = 15 mph, 12.68 V; assumed).
    delay : float
        Transport delay of the drive [s] (assumed 0.05 s; the paper gives no value).
    counts_per_rev : int
        Encoder counts per encoder-shaft revolution [-] (assumed 4096 = 1024 lines x4).
    roller_radius : float
        Drive-roller radius [m] (assumed 0.0508 m = 2 in).
    gear_ratio : float
        Encoder-shaft revolutions per roller revolution [-] (assumed 1).
    window_samples : int
        Number of steps over which counts are differenced for the speed estimate [-].
    delay_samples : int
        Extra measurement delay of the speed estimate [steps].
    """

    gain: float = 2.38
    pole: float = 4.5
    b_over_j: float = 0.158
    f_over_b: float = 0.270
    v_top: float = 15.0 * MPH
    u_max: float = 12.7
    delay: float = 0.05
    counts_per_rev: int = 4096
    roller_radius: float = 0.0508
    gear_ratio: float = 1.0
    window_samples: int = 10
    delay_samples: int = 1

    def __post_init__(self) -> None:
        check_numbers(self, ('gain', 'pole', 'b_over_j', 'f_over_b', 'v_top', 'u_max',
                             'roller_radius', 'gear_ratio'), above=0.0)
        if not isinstance(self.delay, (int, float)) or not math.isfinite(self.delay) \
                or self.delay < 0.0:
            raise ValueError(f'BeltParams.delay must be a finite time >= 0 s, got {self.delay!r}.')
        if self.pole <= self.b_over_j:
            raise ValueError(
                'BeltParams.pole (drive pole a) must exceed b_over_j (coast rate B/J) so that the '
                f'drive is faster than friction, got a={self.pole}, B/J={self.b_over_j}.')
        for name in ('counts_per_rev', 'window_samples'):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                raise ValueError(f'BeltParams.{name} must be an integer >= 1, got {v!r}.')
        if not isinstance(self.delay_samples, int) or isinstance(self.delay_samples, bool) \
                or self.delay_samples < 0:
            raise ValueError(
                f'BeltParams.delay_samples must be an integer >= 0, got {self.delay_samples!r}.')

    @property
    def dc_gain(self) -> float:
        """Steady-state speed per volt ``b/a`` [m/s/V] (0.5289 for the paper's values)."""
        return self.gain / self.pole

    @property
    def distance_per_count(self) -> float:
        """Belt travel per encoder count [m]."""
        return 2.0 * math.pi * self.roller_radius / (self.counts_per_rev * self.gear_ratio)

    def speed_resolution(self, dt: float) -> float:
        """Speed quantum of the encoder estimate ``d_c / (window_samples dt)`` [m/s]."""
        return self.distance_per_count / (self.window_samples * dt)


def coast_speed(v0: float, t: float, b_over_j: float = 0.158, f_over_b: float = 0.270) -> float:
    """Coast-down speed ``max(0, (V0 + F/B) exp(-(B/J) t) - F/B)`` [m/s]."""
    if v0 <= 0.0:
        return 0.0
    return max(0.0, (v0 + f_over_b) * math.exp(-b_over_j * t) - f_over_b)


def coast_stop_time(v0: float, b_over_j: float = 0.158, f_over_b: float = 0.270) -> float:
    """Coast-down stop time ``t_stop = (J/B) ln(1 + V0 B/F)`` [s]."""
    if v0 <= 0.0:
        return 0.0
    return math.log1p(v0 / f_over_b) / b_over_j


def coast_distance(v0: float, b_over_j: float = 0.158, f_over_b: float = 0.270) -> float:
    """Belt travel [m] during a full coast-down from ``V0`` [m/s] to standstill."""
    if v0 <= 0.0:
        return 0.0
    t = coast_stop_time(v0, b_over_j, f_over_b)
    return (v0 + f_over_b) * (1.0 - math.exp(-b_over_j * t)) / b_over_j - f_over_b * t


class BeltEncoder:
    """Quantized, windowed, delayed belt-speed measurement from a shaft encoder.

    The encoder has ``counts_per_rev`` counts per revolution of a shaft turning ``gear_ratio``
    times per drive-roller revolution (roller radius ``roller_radius``). Belt travel per count
    ``d_c = 2 pi r / (counts_per_rev * gear_ratio)`` [m]; the count is ``floor(position / d_c)``.
    The speed estimate is the count difference over the last ``window_samples`` steps divided by
    their duration, delayed by ``delay_samples`` steps: resolution ``d_c / (window_samples dt)``
    [m/s], mean lag about ``(window_samples/2 + delay_samples) dt``.

    ``update(position, dt)`` is called once per step with the true belt travel [m].
    ``speed`` is the delayed estimate [m/s]; ``count`` the current raw count [-].
    """

    def __init__(self, params: BeltParams) -> None:
        self.params = params
        self.reset(0.0)

    def reset(self, position: float = 0.0, speed: float = 0.0) -> None:
        """Reset history; the estimate starts at ``speed`` [m/s] (quantized)."""
        p = self.params
        self.count = int(math.floor(position / p.distance_per_count))
        self._hist: Deque[Tuple[int, float]] = deque([(self.count, 0.0)],
                                                     maxlen=p.window_samples + 1)
        q = p.distance_per_count
        self._out: Deque[float] = deque([speed] * (p.delay_samples + 1),
                                        maxlen=p.delay_samples + 1)
        self._time = 0.0
        self._q = q

    def update(self, position: float, dt: float) -> None:
        """Register the belt travel [m] at the end of a step of length ``dt`` [s]."""
        self._time += dt
        self.count = int(math.floor(position / self._q + 1e-12))
        self._hist.append((self.count, self._time))
        c0, t0 = self._hist[0]
        c1, t1 = self._hist[-1]
        est = (c1 - c0) * self._q / (t1 - t0) if t1 > t0 else self._out[-1]
        self._out.append(est)

    @property
    def speed(self) -> float:
        """Delayed, quantized speed estimate [m/s]."""
        return self._out[0]


class TreadmillBelt:
    """Fixed-step, deterministic treadmill belt (see module docstring for the equations).

    Since ``a > c`` the two drive-on branches switch at ``V_sw = (b u + c k)/(a - c)``: above
    ``V_sw`` the belt coasts, below it follows the linear drive. Each branch is linear with
    constant input, so every step is integrated *exactly* (piecewise exponential with the
    analytic switching, stopping and clamping instants); ``position`` is the exact integral of
    ``V``. The drive range ``u_max = 12.7 V`` is assumed (the paper gives none): Eq. 2 reaches
    ``v_top = 6.7056 m/s`` at ``v_top a/b = 12.68 V``.

    The paper reports a delay in the treadmill controller without a value; ``T_d = 0.05 s`` is
    assumed. The delay line stores the zero-order-held input segments, so the delayed input over
    one step may be piecewise constant and is still integrated exactly, for any step sizes
    (deterministic, no interpolation).

    Parameters
    ----------
    params : BeltParams
    """

    def __init__(self, params: BeltParams | None = None) -> None:
        self.params = params if params is not None else BeltParams()
        self.encoder = BeltEncoder(self.params)
        self.reset(0.0)

    # ------------------------------------------------------------------ state
    def reset(self, speed: float = 0.0, voltage: float | None = None) -> None:
        """Reset to belt speed ``speed`` [m/s], travel 0 m.

        The delay line is filled with ``voltage`` [V]; by default the voltage that holds
        ``speed`` in steady state (``speed / dc_gain``), so a reset belt is in equilibrium.
        """
        p = self.params
        if not math.isfinite(speed) or speed < 0.0 or speed > p.v_top:
            raise ValueError(f'reset speed must be in [0, {p.v_top}] m/s, got {speed!r}.')
        self._v = float(speed)
        self._s = 0.0
        self._t = 0.0
        u0 = speed / p.dc_gain if voltage is None else float(voltage)
        self._line: Deque[List[float]] = deque()
        if p.delay > 0.0:
            self._line.append([p.delay, self._clamp_u(u0)])
        self._u_applied = self._clamp_u(u0)
        self.encoder.reset(0.0, speed)

    @property
    def speed(self) -> float:
        """True belt surface speed V [m/s] (>= 0; surface moves in -x)."""
        return self._v

    @property
    def position(self) -> float:
        """Belt surface travel since reset [m] (integral of V)."""
        return self._s

    @property
    def time(self) -> float:
        """Simulated time since reset [s]."""
        return self._t

    @property
    def applied_voltage(self) -> float:
        """Delayed, clamped drive voltage that acted at the end of the last step [V]."""
        return self._u_applied

    @property
    def measured_speed(self) -> float:
        """Encoder speed estimate [m/s] (quantized, windowed, delayed)."""
        return self.encoder.speed

    def _clamp_u(self, u: float) -> float:
        return min(self.params.u_max, max(0.0, float(u)))

    # ------------------------------------------------------------------ dynamics
    def step(self, voltage: float, dt: float) -> None:
        """Advance by exactly ``dt`` [s] with ``voltage`` [V] held over the step.

        NaN voltage is rejected (``ValueError``); finite values are clamped to ``[0, u_max]``.
        """
        if not math.isfinite(dt) or dt <= 0.0:
            raise ValueError(f'dt must be a finite time > 0 s, got {dt!r}.')
        if math.isnan(voltage):
            raise ValueError('voltage must be a number in volts, got NaN.')
        u = self._clamp_u(voltage)
        segments: List[Tuple[float, float]] = []
        if self.params.delay > 0.0:
            self._line.append([dt, u])
            need = dt
            while need > 1e-15 and self._line:
                seg = self._line[0]
                take = min(seg[0], need)
                segments.append((take, seg[1]))
                seg[0] -= take
                need -= take
                if seg[0] <= 1e-15:
                    self._line.popleft()
        else:
            segments.append((dt, u))
        for dur, uu in segments:
            self._propagate(uu, dur)
            self._u_applied = uu
        self._t += dt
        self.encoder.update(self._s, dt)

    def _propagate(self, u: float, T: float) -> None:
        """Exact solution over ``T`` [s] for constant delayed voltage ``u`` [V]."""
        p = self.params
        a, b, c, k = p.pole, p.gain, p.b_over_j, p.f_over_b
        v, s, t_left = self._v, self._s, T
        drive_on = u > 0.0
        # Coast branch (drive off, or drive on with V above the switching speed).
        v_sw = (b * u + c * k) / (a - c) if drive_on else -math.inf
        if v > v_sw and v > 0.0:
            v_end_coast = max(v_sw, 0.0)
            t_c = math.log((v + k) / (v_end_coast + k)) / c
            tau = min(t_c, t_left)
            e = math.exp(-c * tau)
            s += (v + k) * (1.0 - e) / c - k * tau
            v = (v + k) * e - k
            if tau >= t_c:
                v = v_end_coast
            t_left -= tau
        if t_left > 0.0 and drive_on:
            # Linear drive branch towards v_eq = b u / a, clamped at v_top.
            v_eq = b * u / a
            tau = t_left
            if v_eq > p.v_top and v < p.v_top:
                t_cl = math.log((v_eq - v) / (v_eq - p.v_top)) / a
                tau = min(tau, t_cl)
            if v < p.v_top or v_eq < p.v_top:
                e = math.exp(-a * tau)
                s += v_eq * tau + (v - v_eq) * (1.0 - e) / a
                v = v_eq + (v - v_eq) * e
                t_left -= tau
            if t_left > 0.0:  # held at the top-speed clamp
                v = p.v_top
                s += v * t_left
                t_left = 0.0
        self._v = min(p.v_top, max(0.0, v))
        self._s = s
