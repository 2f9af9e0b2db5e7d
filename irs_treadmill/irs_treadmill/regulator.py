"""Belt-speed regulator that keeps the car at a longitudinal set point on the treadmill.

Plant (``docs/conventions.md``, paper Sec. 3.1)
----------------------------------------------
Car on the belt (heading ~ 0): ``dx/dt = u_car - V_b``.  Belt: ``V_b/U = b/(s + a)``,
``a = 4.5 1/s``, ``b = 2.38 m/s^2/V`` (DC gain ``g = b/a = 0.5289 m/s/V``), transport delay
~0.05 s, and the drive cannot brake: when the commanded speed is below the belt speed the belt
only coasts down by friction (``dV/dt = -(B/J)(V + F/B)``, 0.14..1.1 m/s^2).

Control law (cascade, all quantities per sample ``dt``)
-------------------------------------------------------
Position error ``e = x - x_ref`` [m] (car ahead of the set point -> belt must run faster).

Outer loop, belt speed set point [m/s]::

    u_car_hat = V_meas + xdot_hat                  (car speed over the belt surface)
    V*        = clip(u_car_hat + k_x e + k_i I, 0, v_top),   I = integral of e

Inner loop, drive voltage [V]::

    U = V*/g + (k_v/g) (V* - V_meas)               (inverse-DC-gain feed-forward + P)
    U = rate_limit(clip(U, 0, u_max), slew_rate)

``xdot_hat`` is supplied (e.g. the pose estimator's ``xdot``) or, if not, computed internally by
a backward difference + first-order low pass with cut-off ``xdot_cutoff_hz``.

Because ``V*`` contains ``V_meas``, the feed-forward ``V*/g`` cancels the belt pole and the
belt behaves as an integrator, ``dV_b/dt = a (1 + k_v)(xdot + k_x e + k_i I)`` (unsaturated,
delay-free).  With ``xdot = u_car - V_b`` the error obeys, for ``k_i = 0``::

    e'' + a (1 + k_v) e' + a (1 + k_v) k_x e = du_car/dt

i.e. zero steady-state error for any constant car speed without an integrator, and
``e_ss = A / (a (1 + k_v) k_x)`` for a constant car acceleration ``A``.  The optional ``k_i``
removes residual bias from feed-forward errors (belt-gain mismatch, encoder bias).

Anti wind-up: ``I`` is integrated only when the voltage is not saturated (or the error would
drive it out of saturation): frozen while ``U`` is clipped at ``0`` (including the coasting
case ``V_meas > V*``, voltage 0) and ``e < 0``, while clipped at ``u_max`` or ``V*`` at
``v_top`` and ``e > 0``, and while the slew limiter is active in the direction of ``e``.  ``I``
is also clamped to ``|k_i I| <= integral_limit`` [m/s].

Default tuning: ``k_x = 2.0 1/s``, ``k_v = 1.0`` -> characteristic ``s^2 + 9 s + 18`` (poles
-3 and -6 1/s; dominant time constant 0.33 s), well separated from the 0.05 s drive delay;
``k_i = 0.3 1/s^2`` (slow bias removal, zero at 0.15 1/s).  ``x_ref = 0.3 m`` ahead of the
belt centre because the car can only be pushed *back* quickly (the belt can accelerate at
> 10 m/s^2 but decelerate only at the friction rate), so deceleration transients are much
larger than acceleration ones; see ``docs/treadmill.md`` for the closed-loop results.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

__all__ = ["RegulatorParams", "RegulatorOutput", "BeltSpeedRegulator"]


def dataclass_from_mapping(cls, d):
    """``cls(**d)`` for a parameter dataclass; unknown keys raise ``ValueError`` naming them."""
    import dataclasses
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(d) - names
    if unknown:
        raise ValueError(f"{cls.__name__}: unknown parameters {sorted(unknown)}; expected a "
                         f"subset of {sorted(names)}.")
    return cls(**dict(d))


@dataclass(frozen=True)
class RegulatorParams:
    """Parameters of :class:`BeltSpeedRegulator` (units in brackets).

    x_ref [m] longitudinal set point; k_x [1/s] position gain; k_i [1/s^2] integral gain;
    integral_limit [m/s] bound on ``k_i I``; k_v [-] inner proportional gain (relative);
    belt_gain [m/s/V] belt DC gain ``b/a``; u_max [V] voltage limit; slew_rate [V/s]
    voltage slew limit; v_top [m/s] belt top speed; xdot_cutoff_hz [Hz] internal
    car-velocity filter cut-off.
    """

    x_ref: float = 0.3
    k_x: float = 2.0
    k_i: float = 0.3
    integral_limit: float = 0.5
    k_v: float = 1.0
    belt_gain: float = 2.38 / 4.5
    u_max: float = 10.0
    slew_rate: float = 40.0
    v_top: float = 6.7056
    xdot_cutoff_hz: float = 5.0

    def __post_init__(self) -> None:
        for n in ("x_ref", "k_i", "integral_limit", "k_v"):
            v = getattr(self, n)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"RegulatorParams.{n} must be a finite number, got {v!r}.")
        for n in ("k_i", "integral_limit", "k_v"):
            if getattr(self, n) < 0:
                raise ValueError(f"RegulatorParams.{n} must be >= 0, got {getattr(self, n)}.")
        for n in ("k_x", "belt_gain", "u_max", "slew_rate", "v_top", "xdot_cutoff_hz"):
            v = getattr(self, n)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"RegulatorParams.{n} must be a finite number > 0, got {v!r}.")

    @classmethod
    def from_dict(cls, d):
        """Build from a parameter mapping (e.g. the YAML ``ros__parameters`` sub-tree); unknown
        keys raise ``ValueError``."""
        return dataclass_from_mapping(cls, d)


@dataclass(frozen=True)
class RegulatorOutput:
    """One regulator step: voltage [V], belt speed set point [m/s], estimates and flags."""

    voltage: float
    speed_setpoint: float
    error: float
    car_speed_estimate: float
    saturated: bool
    integrating: bool


class BeltSpeedRegulator:
    """Cascade belt-speed regulator (see module docstring)."""

    def __init__(self, params: Optional[RegulatorParams] = None) -> None:
        self.params = params if params is not None else RegulatorParams()
        self.reset()

    def reset(self) -> None:
        """Zero the integral, the voltage memory (slew limiter) and the velocity filter."""
        self.integral = 0.0
        self.voltage = 0.0
        self._x_prev: Optional[float] = None
        self._xdot_f = 0.0

    def _xdot_internal(self, x: float, dt: float) -> float:
        if self._x_prev is None:
            self._x_prev = x
            return 0.0
        alpha = math.exp(-2.0 * math.pi * self.params.xdot_cutoff_hz * dt)
        raw = (x - self._x_prev) / dt
        self._x_prev = x
        self._xdot_f = alpha * self._xdot_f + (1.0 - alpha) * raw
        return self._xdot_f

    def update(self, x: float, belt_speed: float, dt: float,
               xdot: Optional[float] = None, enabled: bool = True) -> RegulatorOutput:
        """Compute the drive voltage for this sample.

        Parameters
        ----------
        x : float
            Measured car c.g. position along the belt [m].
        belt_speed : float
            Measured belt speed [m/s] (encoder).
        dt : float
            Sample period [s].
        xdot : float, optional
            Car velocity in the treadmill frame [m/s]; internal filter used if None/NaN.
        enabled : bool
            False (e.g. safety fault) -> output 0 V and reset the controller state.
        """
        p = self.params
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite sample period > 0 s, got {dt!r}.")
        if not enabled or not math.isfinite(x) or not math.isfinite(belt_speed):
            self.reset()
            return RegulatorOutput(0.0, 0.0, math.nan, math.nan, False, False)
        xd_int = self._xdot_internal(x, dt)
        xd = xdot if (xdot is not None and math.isfinite(xdot)) else xd_int
        e = x - p.x_ref
        u_car = belt_speed + xd
        v_star_raw = u_car + p.k_x * e + p.k_i * self.integral
        v_star = min(p.v_top, max(0.0, v_star_raw))
        g = p.belt_gain
        u_raw = v_star / g + p.k_v / g * (v_star - belt_speed)
        u_clip = min(p.u_max, max(0.0, u_raw))
        du_max = p.slew_rate * dt
        u = min(self.voltage + du_max, max(self.voltage - du_max, u_clip))
        sat_low = u_raw <= 0.0 or v_star_raw <= 0.0
        sat_high = u_raw >= p.u_max or v_star_raw >= p.v_top
        slew_up = u < u_clip - 1e-12
        slew_down = u > u_clip + 1e-12
        # conditional integration (anti-wind-up)
        integrating = False
        if p.k_i > 0:
            blocked = ((sat_low or slew_down) and e < 0) or ((sat_high or slew_up) and e > 0)
            if not blocked:
                self.integral += e * dt
                lim = p.integral_limit / p.k_i
                self.integral = min(lim, max(-lim, self.integral))
                integrating = True
        self.voltage = u
        return RegulatorOutput(voltage=u, speed_setpoint=v_star, error=e,
                               car_speed_estimate=u_car,
                               saturated=bool(sat_low or sat_high or slew_up or slew_down),
                               integrating=integrating)
