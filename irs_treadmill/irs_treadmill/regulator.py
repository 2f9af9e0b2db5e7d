"""Belt-speed regulator that keeps the car at a longitudinal set point on the treadmill.

Car on the belt (heading ~ 0): ``dx/dt = u_car - V_b``. Belt: ``V_b/U = b/(s + a)``, ``a = 4.5
1/s``, ``b = 2.38 m/s^2/V`` (DC gain ``g = b/a = 0.5289 m/s/V``), a drive delay of ~0.05 s, and
the drive cannot brake (below the belt speed the belt only coasts down by friction, 0.14..1.1
m/s^2). With the position error ``e = x - x_ref`` [m], a cascade per sample ``dt`` sets the belt
speed set point ``V*`` [m/s] and the drive voltage ``U`` [V]::

    u_car_hat = V_meas + xdot_hat                  (car speed over the belt surface)
    V*        = clip(u_car_hat + k_x e + k_i I, 0, v_top),   I = integral of e
    U = V*/g + (k_v/g) (V* - V_meas)               (inverse-DC-gain feed-forward + P)
    U = rate_limit(clip(U, 0, u_max), slew_rate)

The feed-forward cancels the belt pole, so ``e'' + a (1 + k_v) e' + a (1 + k_v) k_x e =
du_car/dt``: no steady-state error for a constant car speed. It exists to keep the car on the
treadmill, away from its ends. Derivation and anti-windup: :class:`BeltSpeedRegulator`; tuning:
:class:`RegulatorParams`; bad inputs: :meth:`BeltSpeedRegulator.update`; closed-loop results:
docs/treadmill.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

from irs_common.field_checks import check_numbers
from irs_common.input_checks import abs_limit_problem

__all__ = ['RegulatorParams', 'RegulatorOutput', 'BeltSpeedRegulator', 'DEFAULT_POSITION_LIMIT',
           'DEFAULT_SPEED_LIMIT']


def dataclass_from_mapping(cls, d):
    """``cls(**d)`` for a parameter dataclass; unknown keys raise ``ValueError`` naming them."""
    import dataclasses
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(d) - names
    if unknown:
        raise ValueError(f'{cls.__name__}: unknown parameters {sorted(unknown)}; expected a '
                         f'subset of {sorted(names)}.')
    return cls(**dict(d))


@dataclass(frozen=True)
class RegulatorParams:
    """Parameters of :class:`BeltSpeedRegulator` (units in brackets).

    x_ref [m] longitudinal set point; k_x [1/s] position gain; k_i [1/s^2] integral gain;
    integral_limit [m/s] bound on ``k_i I``; k_v [-] inner proportional gain (relative);
    belt_gain [m/s/V] belt DC gain ``b/a``; u_max [V] voltage limit; slew_rate [V/s]
    voltage slew limit; v_top [m/s] belt top speed; xdot_cutoff_hz [Hz] internal
    car-velocity filter cut-off.

    Default tuning: ``k_x = 2.0 1/s``, ``k_v = 1.0`` -> characteristic ``s^2 + 9 s + 18`` (poles -3
    and -6 1/s; dominant time constant 0.33 s), well separated from the 0.05 s drive delay; ``k_i =
    0.3 1/s^2`` (slow bias removal, zero at 0.15 1/s).  ``x_ref = 0.3 m`` ahead of the belt centre
    because the car can only be pushed *back* quickly (the belt can accelerate at > 10 m/s^2 but
    decelerate only at the friction rate), so deceleration transients are much larger than
    acceleration ones; see ``docs/treadmill.md`` for the closed-loop results.
    """

    x_ref: float = 0.3
    k_x: float = 2.0
    k_i: float = 0.3
    integral_limit: float = 0.5
    k_v: float = 1.0
    belt_gain: float = 2.38 / 4.5
    u_max: float = 12.7      # the belt's drive range: 15 mph needs 12.68 V with Eq. 2
    slew_rate: float = 40.0
    v_top: float = 6.7056
    xdot_cutoff_hz: float = 5.0

    def __post_init__(self) -> None:
        check_numbers(self, ('x_ref',))
        check_numbers(self, ('k_i', 'integral_limit', 'k_v'), at_least=0.0)
        check_numbers(self, ('k_x', 'belt_gain', 'u_max', 'slew_rate', 'v_top', 'xdot_cutoff_hz'),
                      above=0.0)

    @classmethod
    def from_dict(cls, d):
        """Build from a parameter mapping (e.g. the YAML ``ros__parameters`` sub-tree); unknown
        keys raise ``ValueError``.
        """
        return dataclass_from_mapping(cls, d)


@dataclass(init=False)
class RegulatorOutput:
    """One regulator step: voltage [V], belt speed set point [m/s], estimates and flags."""

    voltage: float
    speed_setpoint: float
    error: float
    car_speed_estimate: float
    saturated: bool
    integrating: bool
    reason: str = ''     # empty, or what was wrong with the inputs (module docstring rule)

    # Written out rather than generated: compiled, it is native code (tests/test_step_records.py
    # holds it to the fields; irs_common.native_cores).
    def __init__(self, voltage: float, speed_setpoint: float, error: float,
                       car_speed_estimate: float, saturated: bool, integrating: bool,
                       reason: str = '') -> None:
        self.voltage = voltage
        self.speed_setpoint = speed_setpoint
        self.error = error
        self.car_speed_estimate = car_speed_estimate
        self.saturated = saturated
        self.integrating = integrating
        self.reason = reason


#: Default bound on |x| [m] beyond which a position is not a measurement of the car.
DEFAULT_POSITION_LIMIT = 5.0
#: Default bound on |belt_speed| and |xdot| [m/s] beyond which a speed is not a measurement.
DEFAULT_SPEED_LIMIT = 20.0


class BeltSpeedRegulator:
    """Cascade belt-speed regulator (control law in the module docstring).

    ``position_limit`` [m] and ``speed_limit`` [m/s] bound the inputs it accepts (bad-input rule
    in :meth:`update`).

    ``xdot_hat`` is supplied (e.g. the pose estimator's ``xdot``) or, if not, computed internally
    by a backward difference + first-order low pass with cut-off ``xdot_cutoff_hz``.

    Because ``V*`` contains ``V_meas``, the feed-forward ``V*/g`` cancels the belt pole and the
    belt behaves as an integrator, ``dV_b/dt = a (1 + k_v)(xdot + k_x e + k_i I)`` (unsaturated,
    delay-free).  With ``xdot = u_car - V_b`` the error obeys, for ``k_i = 0``::

        e'' + a (1 + k_v) e' + a (1 + k_v) k_x e = du_car/dt

    i.e. zero steady-state error for any constant car speed without an integrator, and ``e_ss = A /
    (a (1 + k_v) k_x)`` for a constant car acceleration ``A``.  The optional ``k_i`` removes
    residual bias from feed-forward errors (belt-gain mismatch, encoder bias).

    Anti wind-up: ``I`` is integrated only when the voltage is not saturated (or the error would
    drive it out of saturation): frozen while ``U`` is clipped at ``0`` (including the coasting
    case ``V_meas > V*``, voltage 0) and ``e < 0``, while clipped at ``u_max`` or ``V*`` at
    ``v_top`` and ``e > 0``, and while the slew limiter is active in the direction of ``e``.  ``I``
    is also clamped to ``|k_i I| <= integral_limit`` [m/s].
    """

    def __init__(self, params: Optional[RegulatorParams] = None,
                 position_limit: float = DEFAULT_POSITION_LIMIT,
                 speed_limit: float = DEFAULT_SPEED_LIMIT) -> None:
        self.params = params if params is not None else RegulatorParams()
        for name, v in (('position_limit', position_limit), ('speed_limit', speed_limit)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
                raise ValueError(f'{name} must be a positive bound (inf allowed), got {v!r}.')
        self.position_limit = float(position_limit)
        self.speed_limit = float(speed_limit)
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

        Bad inputs: the voltage is always finite and within ``[0, u_max]``, and
        :attr:`RegulatorOutput.reason` says what was wrong.

        * ``x`` not a finite number or ``|x| > position_limit`` (default 5 m; the belt is 2.44 m
          long), or ``belt_speed`` not finite or ``|belt_speed| > speed_limit`` (default 20 m/s;
          top speed 6.7 m/s): no usable feedback -> 0 V and :meth:`~BeltSpeedRegulator.reset`
          (integral, slew memory, velocity filter), exactly as for ``enabled = False``. From the
          next valid sample on the regulator is a fresh one: its outputs equal a new regulator's
          fed the same inputs.
        * ``xdot`` None, not finite or ``|xdot| > speed_limit``: the internal estimate (filtered
          difference of ``x``) is used instead (reported unless ``xdot`` is None).
        * Should the internal velocity filter or the voltage ever come out non-finite (e.g. a
          subnormal ``dt``), the regulator resets and answers 0 V; nothing non-finite is stored.
        * ``dt`` not a finite positive period is a programming error: ``ValueError``.

        Parameters
        ----------
        x : float
            Measured car c.g. position along the belt [m].
        belt_speed : float
            Measured belt speed [m/s] (encoder).
        dt : float
            Sample period [s].
        xdot : float, optional
            Car velocity in the treadmill frame [m/s]; internal filter used if None, non-finite
            or beyond ``speed_limit``.
        enabled : bool
            False (e.g. safety fault) -> output 0 V and reset the controller state.

        Never raises for bad ``x``, ``belt_speed``, ``xdot`` (the rule above); the
        voltage is always finite and within ``[0, u_max]``.
        """
        p = self.params
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f'dt must be a finite sample period > 0 s, got {dt!r}.')
        problem = (abs_limit_problem('x', x, self.position_limit, 'm')
                   or abs_limit_problem('belt_speed', belt_speed, self.speed_limit, 'm/s'))
        if not enabled or problem is not None:
            self.reset()
            reason = '' if problem is None else f'{problem}: drive 0 V, regulator reset'
            return RegulatorOutput(0.0, 0.0, math.nan, math.nan, False, False, reason)
        reason = ''
        xd_int = self._xdot_internal(x, dt)
        if not math.isfinite(xd_int):
            return self._fail(f'internal velocity estimate became non-finite ({xd_int!r})')
        xd = xd_int
        if xdot is not None:
            xdot_problem = abs_limit_problem('xdot', xdot, self.speed_limit, 'm/s')
            if xdot_problem is None:
                xd = xdot
            else:
                reason = f'{xdot_problem}: internal velocity estimate used'
        e = x - p.x_ref
        u_car = belt_speed + xd
        v_star_raw = u_car + p.k_x * e + p.k_i * self.integral
        v_star = min(p.v_top, max(0.0, v_star_raw))
        g = p.belt_gain
        u_raw = v_star / g + p.k_v / g * (v_star - belt_speed)
        u_clip = min(p.u_max, max(0.0, u_raw))
        du_max = p.slew_rate * dt
        u = min(self.voltage + du_max, max(self.voltage - du_max, u_clip))
        if not (math.isfinite(u) and math.isfinite(v_star)):
            return self._fail(f'voltage became non-finite (u = {u!r}, V* = {v_star!r})')
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
        return RegulatorOutput(voltage=u, speed_setpoint=v_star, error=e, car_speed_estimate=u_car,
                               saturated=bool(sat_low or sat_high or slew_up or slew_down),
                               integrating=integrating, reason=reason)

    def _fail(self, what: str) -> RegulatorOutput:
        self.reset()
        return RegulatorOutput(0.0, 0.0, math.nan, math.nan, False, False,
                               f'{what}: drive 0 V, regulator reset')
