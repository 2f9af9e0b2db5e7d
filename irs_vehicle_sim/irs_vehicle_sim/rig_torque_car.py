"""The torque car in the rig: ``plant: two_track`` (ROS-free; docs/torque_car.md).

:class:`TorqueCarPlant` couples the cores the rig steps for the independent-wheel-torque car:
the two-track model (:mod:`.two_track`, RK4), the surface (:mod:`.surface`) and the four wheel
encoders (:mod:`.wheel_encoder`), fed per step with the achieved steer, the belt's mean speed
``V_b = (s_{k+1} - s_k) / dt`` [m/s] and acceleration ``a_b`` [m/s^2], and the sanitised wheel
torques ``T_i`` [N m] (:func:`sanitize_wheel_inputs`). It exists so that the rig steps the torque
car with the same belt, actuators and arm as the other plants; the per-step coupling is in
:class:`TorqueCarPlant`.

      V_b = (s_{k+1} - s_k) / dt    [m/s]    (the car's x moves back by the belt's travel)
      a_b = (V_{k+1} - V_k) / dt    [m/s^2]  (the inertial force m a_b of the belt frame)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from .surface import SurfaceSpec
from .two_track import TwoTrack, TwoTrackParams
from .tyre import TyreParams
from .wheel_encoder import EncoderParams, WheelEncoders

__all__ = ['TorqueCarPlant', 'TyreTruth', 'sanitize_wheel_inputs', 'two_track_defaults',
           'surface_defaults', 'encoder_defaults', 'make_two_track_params', 'make_surface',
           'make_encoder_params', 'ZERO_TORQUE', 'NOT_LOCKED']

#: Motor torque limit per wheel [N m] (assumed: enough to lock a wheel on mu 0.8, 0.19 N m).
DEFAULT_TORQUE_LIMIT = 0.3
ZERO_TORQUE = (0.0, 0.0, 0.0, 0.0)
NOT_LOCKED = (False, False, False, False)
#: Tyre parameters exposed in the ``two_track`` group (``c_alpha`` is set per axle from c_f, c_r).
_TYRE_KEYS = tuple(f.name for f in fields(TyreParams) if f.name != 'c_alpha')
_WHEEL = ('FL', 'FR', 'RL', 'RR')


def two_track_defaults() -> dict:
    """Flat ``two_track`` group: TwoTrackParams (irs_iwt preset car), the tyre's parameters
    except ``c_alpha``, and ``torque_limit`` [N m].
    """
    p = asdict(TwoTrackParams())
    tyre = p.pop('tyre')
    out = dict(p)
    out.update({k: tyre[k] for k in _TYRE_KEYS})
    out['torque_limit'] = DEFAULT_TORQUE_LIMIT
    return out


def surface_defaults() -> dict:
    """``surface`` group: every :class:`SurfaceSpec` field with its default."""
    return asdict(SurfaceSpec())


def encoder_defaults() -> dict:
    """``encoders`` group: counts per revolution and velocity window [samples]."""
    return asdict(EncoderParams())


def make_two_track_params(group: dict) -> TwoTrackParams:
    """TwoTrackParams from the flat group (``torque_limit`` left out); refuses bad values with
    one sentence naming the parameter (prefixed ``two_track.``).
    """
    d = dict(group)
    d.pop('torque_limit', None)
    tyre = {k: d.pop(k) for k in _TYRE_KEYS if k in d}
    try:
        return TwoTrackParams(**d, tyre=TyreParams(**tyre))
    except (TypeError, ValueError) as exc:
        raise ValueError(f'two_track: {exc}') from None


def check_torque_limit(value) -> float:
    """The motor torque limit [N m], a finite number > 0, else one sentence."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or value <= 0.0:
        raise ValueError(f'two_track.torque_limit must be a finite torque > 0 N m, got {value!r}.')
    return float(value)


def make_surface(group: dict) -> SurfaceSpec:
    """The SurfaceSpec of the ``surface`` group (all fields; the kind reads its own keys)."""
    return SurfaceSpec(**group)


def make_encoder_params(group: dict) -> EncoderParams:
    """EncoderParams of the ``encoders`` group, errors prefixed ``encoders.``."""
    try:
        return EncoderParams(**group)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'encoders: {exc}') from None


def sanitize_wheel_inputs(torque, locked, limit: float):
    """Safe wheel torques [N m], locked flags and the reasons (an empty list if all accepted).

    A torque that is not a finite number becomes 0 N m (the wheel coasts) with a reason naming
    the wheel; finite torques are clipped to ``[-limit, limit]`` silently (the motor saturates,
    as a servo does). ``torque`` or ``locked`` that is not 4 values -> all 0 N m / not locked,
    with a reason. Locked flags are taken as truth values.
    """
    reasons = []
    try:
        values = list(torque)
    except TypeError:
        values = None
    if values is None or len(values) != 4:
        reasons.append(f'wheel torque {torque!r} is not 4 values (FL, FR, RL, RR); using 0 N m')
        tq = ZERO_TORQUE
    else:
        out = []
        for name, value in zip(_WHEEL, values):
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = math.nan
            if not math.isfinite(v):
                reasons.append(f'wheel torque {name} {value!r} is not finite; using 0 N m')
                v = 0.0
            out.append(min(limit, max(-limit, v)))
        tq = tuple(out)
    try:
        lk = tuple(bool(b) for b in locked)
    except TypeError:
        lk = ()
    if len(lk) != 4:
        reasons.append(f'wheel locked flags {locked!r} are not 4 values; none locked')
        lk = NOT_LOCKED
    return tq, lk, reasons


@dataclass(frozen=True)
class TyreTruth:
    """Ground truth of the four tyres at one instant (wheels FL, FR, RL, RR; irs_msgs/TyreState).

    Attributes
    ----------
    slip : tuple
        Longitudinal slip kappa [-] (relaxed).
    slip_angle : tuple
        Slip angle [rad].
    fx, fy, fz : tuple
        Tyre forces in the wheel frame and normal loads [N].
    mu : tuple
        Surface friction at each contact point [-].
    omega : tuple
        True wheel spins [rad/s].
    x_belt : float
        Distance travelled over the belt surface since the start [m].
    u : float
        True forward speed over the belt surface [m/s].
    """

    slip: tuple
    slip_angle: tuple
    fx: tuple
    fy: tuple
    fz: tuple
    mu: tuple
    omega: tuple
    x_belt: float
    u: float


def _floats(a) -> tuple:
    return tuple(float(v) for v in a)


class TorqueCarPlant:
    """Two-track car, surface and wheel encoders, stepped by the rig.

    It couples the cores the rig steps for the independent-wheel-torque car:
    the two-track model (:mod:`.two_track`, RK4), the surface (:mod:`.surface`) and the four wheel
    encoders (:mod:`.wheel_encoder`). :class:`~irs_vehicle_sim.rig.RigSimulation` feeds it, per
    step ``t_k -> t_{k+1}`` with the inputs held:

    * the **achieved** front and rear steer at ``t_k`` of the rig's two actuator models;
    * the belt's mean speed and acceleration over the step, from the belt model stepped first::

    Parameters
    ----------
    params : TwoTrackParams
    surface : SurfaceSpec
    encoder : EncoderParams
    torque_limit : float
        Motor torque limit per wheel [N m].
    ds : float
        Sensor-point distance ahead of the c.g. [m] (for ``y_s``).
    """

    def __init__(self, params: TwoTrackParams, surface: SurfaceSpec, encoder: EncoderParams,
                 torque_limit: float, ds: float):
        self.car = TwoTrack(params, surface)
        self.encoders = WheelEncoders(encoder)
        self.torque_limit = float(torque_limit)
        self.ds = float(ds)

    def reset(self, x0: float, y0: float, u0: float, t: float, dt: float) -> None:
        """Car at ``(x0, y0)`` [m], heading 0, speed ``u0`` [m/s] with the wheels rolling; the
        surface clock at ``t`` [s]; encoder counts at 0 with the window primed at ``u0 / R``.
        """
        self.restart(x0, y0, u0, t)
        self.encoders.reset(self.car.omega, dt)

    def restart(self, x0: float, y0: float, u0: float, t: float) -> None:
        """Car back at its start (as :meth:`reset`) while the encoders keep counting."""
        car = self.car
        car.reset(x0, y0, 0.0, u0)
        car.t = float(t)
        car.refresh_outputs()   # mu at time t

    def step(self, torque, locked, delta_f: float, delta_r: float, belt_speed: float,
             belt_accel: float, dt: float) -> None:
        """Advance ``dt`` [s] with sanitised torques [N m] and flags, achieved steer [rad] and
        the belt's mean speed [m/s] and acceleration [m/s^2] over the step held.
        """
        w0 = self.car.omega
        for i, lk in enumerate(locked):
            if lk:
                w0[i] = 0.0
        self.car.step(torque, delta_f, delta_r, dt, belt_speed, belt_accel, locked)
        w1 = self.car.omega
        if np.all(np.isfinite(w1)):      # a diverged state (off-belt 'nonfinite') holds them
            self.encoders.step(0.5 * (w0 + w1), dt)

    @property
    def pose(self) -> tuple:
        """``(x, y, psi, u, v, r, y_s)`` [m, m, rad, m/s, m/s, rad/s, m] of the car."""
        s = self.car.state
        psi = float(s[3])
        y = float(s[5])
        return (float(s[4]), y, psi, float(s[0]), float(s[1]), float(s[2]),
                y + self.ds * math.sin(psi))

    def truth(self) -> TyreTruth:
        """Ground truth of the tyres now."""
        o = self.car.outputs
        return TyreTruth(slip=_floats(o.kappa), slip_angle=_floats(o.slip_angle),
                         fx=_floats(o.fx), fy=_floats(o.fy), fz=_floats(o.fz), mu=_floats(o.mu),
                         omega=_floats(self.car.omega), x_belt=self.car.x_belt, u=self.car.u)

    def encoder_readings(self) -> tuple:
        """``(counts, velocity)``: 4 ints and 4 floats [rad/s]."""
        e = self.encoders
        return tuple(int(c) for c in e.counts), _floats(np.asarray(e.velocity, dtype=float))
