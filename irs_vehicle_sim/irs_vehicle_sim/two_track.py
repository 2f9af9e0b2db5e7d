"""Planar two-track model of the independent-wheel-torque, four-wheel-steer car (ROS-free).

Velocities ``u``, ``v`` [m/s] and yaw rate ``r`` [rad/s] are the car's motion **over the belt
surface** (body frame); the pose ``(x, y, psi)`` is in the treadmill frame, whose surface moves
in -x at ``V_b`` (docs/conventions.md); ``x_belt`` is the travel over the belt (the stopping
distance). States (15): ``u, v, r, psi, x, y, x_belt``, wheel spins ``omega_i`` [rad/s], slips
``kappa_i`` [-], wheels ``[FL, FR, RL, RR]`` at ``(px_i, py_i)``. Inputs: wheel torques ``T_i``
[N m], achieved steer ``delta_f``, ``delta_r`` [rad] (one per axle, no Ackermann), ``V_b``
[m/s], its rate ``a_b`` [m/s^2] and a per-wheel ``locked`` flag (Rajamani 2012 secs. 2.3, 13;
Pacejka 2012 sec. 1.3)::

    V_cx = (u - r py_i) cos(d_i) + (v + r px_i) sin(d_i)      (contact velocity, wheel frame)
    V_cy = -(u - r py_i) sin(d_i) + (v + r px_i) cos(d_i)
    (F_xw, F_yw) = tyre_forces(kappa_F,i, V_cy / max(|V_cx|, v_low), F_z,i, mu_i)   (tyre.py)
    F_x,i = F_xw cos(d_i) - F_yw sin(d_i),   F_y,i = F_xw sin(d_i) + F_yw cos(d_i)
    m (du/dt - v r) = sum F_x,i + m a_b cos(psi)       (belt frame accelerates at -a_b along x)
    m (dv/dt + u r) = sum F_y,i - m a_b sin(psi)
    I_z dr/dt       = sum (px_i F_y,i - py_i F_x,i)
    J domega_i/dt   = T_i - R F_xw,i - f_r F_z,i R tanh(omega_i R / v_rr)     (0 if locked)
    sigma_eff,i dkappa_i/dt = (omega_i R - V_cx) - max(|V_cx|, v_low) kappa_i
    dpsi/dt = r,  dx/dt = u cos(psi) - v sin(psi) - V_b,  dy/dt = u sin(psi) + v cos(psi)

It exists to study braking and steering of the torque car on the rig with the load transfer and
wheel spin a bicycle model lacks; at small slip it reduces to
``irs_models.torque_car.torque_car_bicycle()`` (tested). Load transfer: :meth:`TwoTrack.loads`;
integration (RK4, 1 ms): :class:`TwoTrack`; parameters: :class:`TwoTrackParams`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from irs_common.field_checks import check_numbers
from irs_models.torque_car import torque_car_bicycle

from .surface import SurfaceSpec
from .tyre import TyreParams, characteristic, contact, lateral_slip, slip_rate

__all__ = ['TwoTrackParams', 'TwoTrack', 'TwoTrackOutputs', 'WHEELS', 'N_STATES']

#: Wheel order of every 4-vector.
WHEELS = ('FL', 'FR', 'RL', 'RR')
#: Length of the state vector ``[u, v, r, psi, x, y, x_belt, omega x4, kappa x4]``.
N_STATES = 15
_G = 9.81


@dataclass
class TwoTrackParams:
    """Parameters of the two-track car (defaults: the ``irs_iwt`` preset's car on rubber tyres).

    Mass, yaw inertia, axle distances, track and wheel radius are the ``irs_iwt`` preset's
    (irs_models/config/presets.yaml); the axle cornering stiffnesses are the rubber 1:10 tyres'
    (irs_models.torque_car: 69.4 and 80.3 N/rad, not the preset's Eq. 6 fit); the tyre's
    cornering stiffness per unit load is set per axle to ``c_f / (2 F_z,f0)``,
    ``c_r / (2 F_z,r0)``. The rest is assumed (below). Aerodynamic drag is left out: at 1.2 m/s
    on a 1:10 body it is about 5 mN (``0.5 rho c_d A V^2`` with ``c_d A = 0.005 m^2``), against
    0.56 N of rolling resistance.

    Attributes
    ----------
    mass : float
        Mass m [kg] (irs_iwt preset: 2.86).
    yaw_inertia : float
        I_z [kg m^2] (irs_iwt: 0.07113).
    lf, lr : float
        c.g. to front / rear axle [m] (irs_iwt: 0.15 / 0.15).
    track : float
        Track width t [m] (irs_iwt: 0.17).
    wheel_radius : float
        Effective rolling radius R [m] (irs_iwt: 0.033).
    c_f, c_r : float
        Axle cornering stiffness at the static load [N/rad] (69.42 / 80.28: the rubber 1:10
        tyres' 4.95 / 5.72 /rad per unit load, irs_models.torque_car).
    cg_height : float
        c.g. height h [m] (0.04: assumed, a 1:10 touring chassis with hub motors carries its
        mass low, 30-45 mm above the ground).
    wheel_inertia : float
        Spin inertia of wheel, tyre and hub-motor rotor J [kg m^2] (5e-5: assumed, because a
        40 g wheel of 33 mm radius has 0.5 m R^2 = 2.2e-5 and a hub motor's rotor adds about as
        much again).
    rolling_resistance : float
        Rolling resistance coefficient f_r [-] (0.02: assumed, because car tyres on hard roads
        have 0.01-0.015 (Rajamani 2012 sec. 4.2; Wong, Theory of Ground Vehicles) and a small
        rubber tyre on a compliant belt rolls worse).
    rr_speed : float
        Speed v_rr [m/s] over which rolling resistance builds up through tanh (0.02: assumed,
        a regularisation so a wheel at rest feels no torque).
    tyre : TyreParams
        Tyre parameters (irs_vehicle_sim.tyre); its ``c_alpha`` is overridden per axle.
    """

    mass: float = 2.86
    yaw_inertia: float = 0.07113
    lf: float = 0.15
    lr: float = 0.15
    track: float = 0.17
    wheel_radius: float = 0.033
    c_f: float = field(default_factory=lambda: torque_car_bicycle().c_f)
    c_r: float = field(default_factory=lambda: torque_car_bicycle().c_r)
    cg_height: float = 0.04
    wheel_inertia: float = 5e-5
    rolling_resistance: float = 0.02
    rr_speed: float = 0.02
    tyre: TyreParams = field(default_factory=TyreParams)

    def __post_init__(self):
        check_numbers(self, ('mass', 'yaw_inertia', 'lf', 'lr', 'track', 'wheel_radius', 'c_f',
                             'c_r', 'wheel_inertia', 'rr_speed'), above=0.0)
        check_numbers(self, ('cg_height', 'rolling_resistance'), at_least=0.0)
        if not isinstance(self.tyre, TyreParams):
            raise ValueError(f'TwoTrackParams.tyre must be a TyreParams, got {self.tyre!r}.')

    @property
    def wheelbase(self) -> float:
        """L = lf + lr [m]."""
        return self.lf + self.lr

    def static_loads(self) -> tuple:
        """Static normal load per front and per rear wheel ``(F_z,f0, F_z,r0)`` [N]."""
        w = self.mass * _G / (2.0 * self.wheelbase)
        return w * self.lr, w * self.lf

    def axle_c_alpha(self) -> tuple:
        """Cornering stiffness per unit load, front and rear [1/rad]: ``c / (2 F_z0)``."""
        fzf, fzr = self.static_loads()
        return self.c_f / (2.0 * fzf), self.c_r / (2.0 * fzr)

    @classmethod
    def from_preset(cls, name: str = 'irs_iwt', **overrides) -> 'TwoTrackParams':
        """Geometry, mass, inertia and cornering stiffnesses from an irs_models preset."""
        from irs_models.presets import get_preset

        p = get_preset(name).params
        base = dict(mass=p.mass, yaw_inertia=p.yaw_inertia, lf=p.lf, lr=p.lr, track=p.track,
                    wheel_radius=p.wheel_radius, c_f=p.c_f, c_r=p.c_r)
        base.update(overrides)
        return cls(**base)

    @classmethod
    def from_dict(cls, d: dict) -> 'TwoTrackParams':
        """Build from a plain dict (``tyre`` may be a dict); unknown keys are refused."""
        if not isinstance(d, dict):
            raise ValueError(f'two-track parameters must be a mapping, got {type(d).__name__}.')
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f'unknown two-track parameter(s) {unknown}; known: {sorted(known)}.')
        d = dict(d)
        if isinstance(d.get('tyre'), dict):
            d['tyre'] = TyreParams.from_dict(d['tyre'])
        return cls(**d)


@dataclass
class TwoTrackOutputs:
    """Ground truth after a step (per wheel arrays in the order FL, FR, RL, RR).

    Attributes
    ----------
    kappa : ndarray
        Longitudinal slip [-].
    slip_angle : ndarray
        Slip angle ``atan(V_cy / max(|V_cx|, v_low))`` [rad] (positive: contact point slides
        left; the lateral force then points right).
    fx, fy : ndarray
        Tyre forces in the wheel frame [N].
    fz : ndarray
        Normal loads [N].
    mu : ndarray
        Surface friction under each wheel [-].
    """

    kappa: np.ndarray
    slip_angle: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    fz: np.ndarray
    mu: np.ndarray


class TwoTrack:
    """The two-track car on the belt (module docstring), stepped by RK4.

    Classic fourth-order Runge-Kutta with the step ``dt`` (1 ms at 1 kHz), inputs, loads and
    frictions held over the step (zero-order hold, docs/conventions.md): explicit, fixed-step and
    bit-deterministic, with an error at 1 kHz far below the model's uncertainty. The fastest mode
    (wheel spin against the relaxed slip, ~sqrt(R^2 F_z C_k / (J sigma)) = 280 rad/s with the
    defaults, and 523 1/s for the regularised lateral slip at standstill) has ``|lambda dt| <
    0.3``, well inside RK4's stability region (2.8). Below ``V_low,d`` = 0.3 m/s the low-speed
    damping ``kappa_F,i = kappa_i + (k_d(V_cx) / C_k) (omega_i R - V_cx)`` (tyre.py) adds
    ``R^2 k_d F_z / J`` = 1500 1/s to a free wheel's spin at rest (with rolling resistance:
    eigenvalue -1720 1/s at 7 N, -2220 at the 9 N a hard-braked front wheel carries; RK4's limit
    -2785 1/s is reached at 11.3 N per wheel, so a heavier car or a larger ``k_d`` needs a
    smaller step), and the saturated relaxation length ``sigma_eff,i = max(sigma_min,
    sigma f(p_i) / p_i)`` at most 150 1/s to the slip. ``solve_ivp`` per step would add
    adaptive-step machinery and Python overhead for nothing.

    Parameters
    ----------
    params : TwoTrackParams, optional
    surface : SurfaceSpec, optional
        Friction map (default uniform 0.8).
    x0, y0, psi0 : float
        Initial pose in the treadmill frame [m, m, rad].
    u0 : float
        Initial forward speed over the belt [m/s]; the wheels start rolling at ``u0 / R``.
    """

    def __init__(self, params: TwoTrackParams | None = None, surface: SurfaceSpec | None = None,
                 x0: float = 0.0, y0: float = 0.0, psi0: float = 0.0, u0: float = 0.0):
        self.params = params if params is not None else TwoTrackParams()
        self.surface = surface if surface is not None else SurfaceSpec()
        self._init = (float(x0), float(y0), float(psi0), float(u0))
        p = self.params
        h = 0.5 * p.track
        self._px = (p.lf, p.lf, -p.lr, -p.lr)
        self._py = (h, -h, h, -h)
        self._ca = p.axle_c_alpha()
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, x0=None, y0=None, psi0=None, u0=None) -> None:
        """Back to the initial pose and speed (arguments replace the constructor's)."""
        x, y, psi, u = self._init
        x = x if x0 is None else float(x0)
        y = y if y0 is None else float(y0)
        psi = psi if psi0 is None else float(psi0)
        u = u if u0 is None else float(u0)
        self._init = (x, y, psi, u)
        w = u / self.params.wheel_radius
        self.state = np.array([u, 0.0, 0.0, psi, x, y, 0.0, w, w, w, w, 0.0, 0.0, 0.0, 0.0])
        self.t = 0.0
        self._acc = (0.0, 0.0)
        self.refresh_outputs()

    def refresh_outputs(self) -> TwoTrackOutputs:
        """``outputs`` of the present state at time ``t`` with the wheels straight (after a
        reset, or a move of the surface clock ``t``).
        """
        fz = self.loads()
        mu = self.frictions(self.state[4], self.state[5], self.state[3], self.t)
        self.outputs = self._outputs(self.state, fz, mu, self._wheel_forces(
            self.state.tolist(), 0.0, 0.0, fz, mu, self.characteristics(mu)))
        return self.outputs

    @property
    def u(self) -> float:
        return float(self.state[0])

    @property
    def v(self) -> float:
        return float(self.state[1])

    @property
    def r(self) -> float:
        return float(self.state[2])

    @property
    def psi(self) -> float:
        return float(self.state[3])

    @property
    def x(self) -> float:
        return float(self.state[4])

    @property
    def y(self) -> float:
        return float(self.state[5])

    @property
    def x_belt(self) -> float:
        return float(self.state[6])

    @property
    def omega(self) -> np.ndarray:
        return self.state[7:11].copy()

    @property
    def kappa(self) -> np.ndarray:
        return self.state[11:15].copy()

    # ------------------------------------------------------------------ model
    def loads(self, acc=None) -> tuple:
        """Normal loads ``F_z,i`` [N] for the inertial accelerations ``(a_x, a_y)`` [m/s^2].

        Quasi-static load transfer (no suspension dynamics; the lateral transfer is shared by the
        axles in proportion to their static loads, i.e. roll stiffness distributed like the
        weight: assumed, because the 1:10 chassis' roll stiffnesses are unknown)::

            F_z,i = m g l_other / (2 L)  -+  m a_x h / (2 L)  -+  m a_y h l_other / (t L)

        with ``a_x = sum F_x / m``, ``a_y = sum F_y / m`` from the tyre forces of the
        **previous step** (one step, 1 ms, of delay breaks the algebraic loop; the chassis'
        pitch and roll modes are far slower). The front loses load when accelerating, the outer
        (right for ``a_y > 0``) wheels gain it; loads are clipped at 0 (a lifted wheel).
        """
        p = self.params
        ax, ay = self._acc if acc is None else acc
        L = p.wheelbase
        m, h = p.mass, p.cg_height
        fzf, fzr = p.static_loads()
        dlong = m * ax * h / (2.0 * L)
        dlat_f = m * ay * h * p.lr / (p.track * L)
        dlat_r = m * ay * h * p.lf / (p.track * L)
        fz = (fzf - dlong - dlat_f, fzf - dlong + dlat_f, fzr + dlong - dlat_r,
              fzr + dlong + dlat_r)
        return tuple(max(0.0, f) for f in fz)

    def frictions(self, x: float, y: float, psi: float, t: float) -> tuple:
        """Surface friction under each wheel's contact point (treadmill frame) [-]."""
        c, s = math.cos(psi), math.sin(psi)
        return tuple(self.surface.mu_at(x + px * c - py * s, y + px * s + py * c, t)
                     for px, py in zip(self._px, self._py))

    def characteristics(self, mu) -> tuple:
        """Per wheel the tyre's slip-independent characteristic at friction ``mu[i]``
        (:func:`~.tyre.characteristic`; ``None`` where ``mu[i] <= 0``): held over a step.
        """
        return tuple(None if m <= 0.0 else characteristic(m, self.params.tyre, ca)
                     for m, ca in zip(mu, (self._ca[0], self._ca[0], self._ca[1], self._ca[1])))

    def _wheel_forces(self, s, delta_f, delta_r, fz, mu, chars):
        """Per wheel ``(F_xw, F_yw, V_cx, V_cy, cos delta, sin delta, sigma_eff)`` for state
        ``s`` (a sequence of Python floats: ``numpy`` scalars would cost several times as much)
        and the wheels' characteristics ``chars`` (:meth:`characteristics` of ``mu``).
        """
        p = self.params
        u, v, r = s[0], s[1], s[2]
        R = p.wheel_radius
        out = []
        for i in range(4):
            if i == 0 or i == 2:
                d = delta_f if i < 2 else delta_r
                cd, sd = math.cos(d), math.sin(d)
            vx = u - r * self._py[i]
            vy = v + r * self._px[i]
            vcx = vx * cd + vy * sd
            vcy = -vx * sd + vy * cd
            sy = lateral_slip(vcx, vcy, p.tyre)
            ca = self._ca[0] if i < 2 else self._ca[1]
            _kap, fxw, fyw, sig = contact(s[11 + i], s[7 + i] * R, vcx, sy, fz[i], mu[i], p.tyre,
                                          ca, chars[i])
            out.append((fxw, fyw, vcx, vcy, cd, sd, sig))
        return out

    def derivatives(self, s, torques, delta_f, delta_r, belt_speed, belt_accel, locked, fz, mu,
                    chars=None):
        """State derivative ``ds/dt`` (module docstring) with loads ``fz`` and frictions ``mu``
        held (``chars``: :meth:`characteristics` of ``mu``, computed when ``None``); also
        returns the total body force ``(sum F_x, sum F_y)`` [N].
        """
        p = self.params
        s = s.tolist()
        u, v, r, psi = s[0], s[1], s[2], s[3]
        R = p.wheel_radius
        sfx = sfy = mz = 0.0
        ds = np.empty(N_STATES)
        if chars is None:
            chars = self.characteristics(mu)
        for i, (fxw, fyw, vcx, _vcy, cd, sd, sig) in enumerate(
                self._wheel_forces(s, delta_f, delta_r, fz, mu, chars)):
            fx = fxw * cd - fyw * sd
            fy = fxw * sd + fyw * cd
            sfx += fx
            sfy += fy
            mz += self._px[i] * fy - self._py[i] * fx
            w = s[7 + i]
            if locked[i]:
                ds[7 + i] = 0.0
            else:
                t_rr = p.rolling_resistance * fz[i] * R * math.tanh(w * R / p.rr_speed)
                ds[7 + i] = (torques[i] - R * fxw - t_rr) / p.wheel_inertia
            ds[11 + i] = slip_rate(s[11 + i], w * R, vcx, p.tyre, sigma=sig)
        cp, sp = math.cos(psi), math.sin(psi)
        ds[0] = sfx / p.mass + belt_accel * cp + v * r
        ds[1] = sfy / p.mass - belt_accel * sp - u * r
        ds[2] = mz / p.yaw_inertia
        ds[3] = r
        ds[4] = u * cp - v * sp - belt_speed
        ds[5] = u * sp + v * cp
        ds[6] = u * cp - v * sp
        return ds, (sfx, sfy)

    def step(self, torques, delta_f: float, delta_r: float, dt: float, belt_speed: float = 0.0,
             belt_accel: float = 0.0, locked=(False, False, False, False)) -> TwoTrackOutputs:
        """Advance ``dt`` [s] by one RK4 step with the inputs held (module docstring).

        Parameters
        ----------
        torques : sequence of 4 float
            Wheel torques [N m], ``[FL, FR, RL, RR]``.
        delta_f, delta_r : float
            Achieved front / rear steer angles [rad].
        dt : float
            Step [s] (> 0).
        belt_speed, belt_accel : float
            Belt speed [m/s] (surface moving in -x) and its rate [m/s^2].
        locked : sequence of 4 bool
            Wheels held at zero spin by a friction brake (their torque is ignored).

        Returns
        -------
        TwoTrackOutputs
            Ground truth at the end of the step (also in ``self.outputs``).
        """
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive finite step in s, got {dt!r}.')
        tq = [float(t) for t in torques]
        if len(tq) != 4:
            raise ValueError(f'torques must be 4 values [N m] (FL, FR, RL, RR), got {len(tq)}.')
        inputs = tq + [float(delta_f), float(delta_r), float(belt_speed), float(belt_accel)]
        if not all(math.isfinite(x) for x in inputs):
            raise ValueError(f'two-track inputs must be finite, got torques {tq}, steer '
                             f'{delta_f!r}/{delta_r!r}, belt {belt_speed!r}/{belt_accel!r}.')
        lk = tuple(bool(b) for b in locked)
        s0 = self.state.copy()
        for i in range(4):
            if lk[i]:
                s0[7 + i] = 0.0
        fz = self.loads()
        mu = self.frictions(s0[4], s0[5], s0[3], self.t)
        chars = self.characteristics(mu)
        args = (tq, float(delta_f), float(delta_r), float(belt_speed), float(belt_accel), lk,
                fz, mu, chars)
        k1, _ = self.derivatives(s0, *args)
        k2, _ = self.derivatives(s0 + 0.5 * dt * k1, *args)
        k3, _ = self.derivatives(s0 + 0.5 * dt * k2, *args)
        k4, _ = self.derivatives(s0 + dt * k3, *args)
        s1 = s0 + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        self.state = s1
        self.t += dt
        # the forces at the end of the step: the next step's load transfer and the outputs
        wf = self._wheel_forces(s1.tolist(), args[1], args[2], fz, mu, chars)
        sfx = sfy = 0.0
        for fxw, fyw, _vcx, _vcy, cd, sd, _sig in wf:     # as in derivatives, in its order
            sfx += fxw * cd - fyw * sd
            sfy += fxw * sd + fyw * cd
        self._acc = (sfx / self.params.mass, sfy / self.params.mass)
        self.outputs = self._outputs(s1, fz, mu, wf)
        return self.outputs

    def _outputs(self, s, fz, mu, wf) -> TwoTrackOutputs:
        sa = [math.atan(lateral_slip(w[2], w[3], self.params.tyre)) for w in wf]
        return TwoTrackOutputs(kappa=s[11:15].copy(), slip_angle=np.array(sa),
                               fx=np.array([w[0] for w in wf]), fy=np.array([w[1] for w in wf]),
                               fz=np.array(fz), mu=np.array(mu))

    def with_params(self, **changes) -> 'TwoTrack':
        """A fresh model with some parameters replaced (same surface and initial state)."""
        x, y, psi, u = self._init
        return TwoTrack(replace(self.params, **changes), self.surface, x, y, psi, u)
