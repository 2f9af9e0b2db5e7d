r"""Discrete PI lateral controller with back-calculation anti-windup (paper: Kp = 5, Ki = 3).

.. math::

    e_k = r_k - y_k, \quad u_k = K_p e_k + I_k, \quad v_k = \mathrm{sat}(u_k),

    I_{k+1} = I_k + dt \left( K_i e_k + \frac{v_k - u_k}{T_t} \right).

``anti_windup = 'back_calculation'`` (default; ``'clip'`` drops the ``(v - u)/T_t`` term).
**Back-calculation** (not conditional integration): while the steer is clipped the
integrator is bled towards the value that makes ``u = v`` with tracking time constant
``T_t`` [s] (default ``T_t = K_p / K_i``, the integral time, the usual choice for PI).
Units: ``e`` [m], ``u`` [rad], ``K_p`` [rad/m], ``K_i`` [rad/(m s)].

Bad inputs: the rule of :mod:`.discrete_rst` (:class:`~.discrete_rst.InputGuard`): an invalid
reference (NaN, inf, ``|r| > reference_limit``) is replaced by the last valid one, the integrator
untouched; an invalid measurement (NaN, inf, ``|y| > measurement_limit``) gives zero steer and
resets the integrator (INVALID); a non-finite integrator or output is never stored (reset,
INVALID). The steer is always finite and within the limits.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .discrete_rst import (DEFAULT_INPUT_LIMIT, STEER_LIMIT, ControlOutput, InputGuard,
                           anti_windup_mode)

__all__ = ['DiscretePiController']


class DiscretePiController(InputGuard):
    """PI controller, forward-Euler integral, back-calculation anti-windup.

    Parameters
    ----------
    kp : float
        Proportional gain [rad/m] (paper: 5).
    ki : float
        Integral gain [rad/(m s)] (paper: 3).
    dt : float
        Sample time [s].
    limits : tuple of float
        ``(u_min, u_max)`` steer limits [rad].
    tracking_time : float, optional
        Back-calculation time constant ``T_t`` [s]; default ``kp / ki``.
    anti_windup : str or bool
        ``'back_calculation'`` (default; ``True``) as above, or ``'clip'`` (``False``): a plain
        clipped PI whose integrator keeps integrating ``K_i e`` while the steer is at the limit.
    measurement_limit, reference_limit : float
        Bounds on ``|y|`` and ``|r|`` [m] beyond which an input is invalid; default 2 m.
    initial_reference : float
        Reference held [m] until a valid one arrives (default 0).
    """

    def __init__(self, kp: float = 5.0, ki: float = 3.0, dt: float = 1e-3,
                 limits=(-STEER_LIMIT, STEER_LIMIT), tracking_time: float | None = None,
                 anti_windup='back_calculation', measurement_limit: Any = DEFAULT_INPUT_LIMIT,
                 reference_limit: Any = DEFAULT_INPUT_LIMIT, initial_reference: Any = 0.0):
        if not dt > 0:
            raise ValueError(f'dt must be a positive sample time in seconds; got {dt}.')
        if kp < 0 or ki < 0:
            raise ValueError(f'Expected non-negative gains kp, ki; got {kp}, {ki}.')
        u_min, u_max = limits
        if not (math.isfinite(u_min) and math.isfinite(u_max) and u_min < u_max):
            raise ValueError(
                f'Expected finite limits (u_min, u_max) with u_min < u_max; got {limits}.'
            )
        if not (math.isfinite(kp) and math.isfinite(ki)):
            raise ValueError(f'Expected finite gains kp, ki; got {kp}, {ki}.')
        self._init_guard(measurement_limit, reference_limit, initial_reference)
        if tracking_time is None:
            tracking_time = kp / ki if ki > 0 and kp > 0 else 1.0
        if not tracking_time > 0:
            raise ValueError(f'tracking_time must be positive seconds; got {tracking_time}.')
        self.kp, self.ki, self.dt = float(kp), float(ki), float(dt)
        self.u_min, self.u_max = float(u_min), float(u_max)
        self.tracking_time = float(tracking_time)
        self.anti_windup_mode = anti_windup_mode(anti_windup)
        self.anti_windup = self.anti_windup_mode != 'clip'
        self.integral = 0.0

    def reset(self) -> None:
        """Zero the integrator."""
        self.integral = 0.0

    def linear_state_space(self):
        """``(Ad, Bd, Cd, Dd)`` of the linear law from y [m] to u [rad] (reference zero):
        ``I_{k+1} = I_k - dt K_i y_k``, ``u_k = I_k - K_p y_k`` (for :mod:`.design_check`);
        with ``K_i = 0`` the static gain ``u_k = -K_p y_k`` (no state).
        """
        if self.ki == 0.0:            # a P controller: no integrator state
            return (np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[-self.kp]]))
        return (np.array([[1.0]]), np.array([[-self.dt * self.ki]]), np.array([[1.0]]),
                np.array([[-self.kp]]))

    def step(self, reference: Any, measurement: Any) -> ControlOutput:
        """Advance one sample; ``reference``, ``measurement`` in m, steer in rad.

        Bad inputs: see the module docstring; never raises for bad data.
        """
        ref, ref_problem, meas_problem = self._screen(reference, measurement)
        if meas_problem is not None:
            return self._measurement_invalid(ref, ref_problem, meas_problem)
        e = ref - float(measurement)
        u = self.kp * e + self.integral
        v = min(max(u, self.u_min), self.u_max)
        # with ki = 0 (a P controller) the integral stays 0: back-calculation alone would
        # leave it at what the last saturation wound it to, a steer offset for good
        aw = (v - u) / self.tracking_time if self.anti_windup and self.ki > 0.0 else 0.0
        integral = self.integral + self.dt * (self.ki * e + aw)
        if not (math.isfinite(u) and math.isfinite(integral)):
            return self._invalid(ref, f'PI state became non-finite (u = {u!r}, integral = '
                                      f'{integral!r}): integrator reset, zero steer')
        self.integral = integral
        return ControlOutput(u_unsat=u, u_sat=v, saturated=(v != u), reason=ref_problem or '',
                             reference=ref)
