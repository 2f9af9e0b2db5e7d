r"""The metrics a sweep can compute per point (no rclpy).

Simulation metrics (:func:`simulation_metrics`, from the offline closed loop's record): the
Figure 10 step metrics of :func:`irs_studies.figure10.report.run_metrics` (rise time [s],
overshoot [%], settling time [s], ISE against the reference model [m^2 s], peak steer [deg],
...), ``off_belt`` and ``settled`` [0/1]. Linear metrics (:func:`linear_metrics`, python-control)
of the loop the point actually runs::

    L(s) = C(s) Pa(s) P(s) e^{-s tau}

with the point's controller, the rig's actuator lag, plant and delay: ``stable`` [0/1], gain
and phase margins [dB, deg] and the crossover [Hz]. They exist so that a sweep's table holds
both what the rig does and what the linear design promises, side by side.
"""
from __future__ import annotations

import math

import numpy as np

#: Metric name -> unit (the summary table's header).
FIGURE10_METRICS = {
    'rise_time': 's', 'overshoot_percent': '%', 'settling_time': 's',
    'oscillation_count': '-', 'crossings_2pct': '-', 'residual_oscillation': 'm',
    'ise_vs_model': 'm^2 s', 'ise_norm': 's', 'max_dev_rel': '-',
    'peak_steer_cmd_deg': 'deg', 'peak_steer_achieved_deg': 'deg', 'time_at_limit': 's',
}
LINEAR_METRICS = {'stable': '0/1', 'gain_margin_db': 'dB', 'phase_margin_deg': 'deg',
                  'crossover_hz': 'Hz'}
METRICS = {**FIGURE10_METRICS, 'off_belt': '0/1', 'settled': '0/1', **LINEAR_METRICS}

PADE_ORDER = 5
OMEGA = np.logspace(-2, 3, 2000)   # [rad/s] frequency grid of the margins


def simulation_metrics(run: dict) -> dict:
    """Figure 10 metrics, ``off_belt`` and ``settled`` of one ClosedLoop record.

    * the Figure 10 step metrics of :func:`irs_studies.figure10.report.run_metrics` (which calls
      :mod:`irs_control.metrics`): ``rise_time`` [s], ``overshoot_percent`` [%], ``settling_time``
      [s] (2 %, nan = not settled in the record), ``oscillation_count``, ``crossings_2pct``,
      ``residual_oscillation`` [m], ``ise_vs_model`` [m^2 s] (against the reference model Bm/Am of
      Eq. 21 driven by the same reference), ``ise_norm`` = ISE / step^2 [s], ``max_dev_rel`` [-],
      ``peak_steer_cmd_deg``, ``peak_steer_achieved_deg`` [deg], ``time_at_limit`` [s];
    * ``off_belt`` [0/1]: the rig raised a fault (car off the belt or beyond the arm's reach) at
      any sample;
    * ``settled`` [0/1]: the 2 % settling time is finite (the response came to rest near the step).
    """
    from ..figure10.report import run_metrics
    m = run_metrics(run)
    out = {k: float(m[k]) for k in FIGURE10_METRICS}
    out['off_belt'] = float(np.any(run['fault']))
    out['settled'] = float(math.isfinite(out['settling_time']))
    return out


def _controller_tf(ctl_params: dict):
    import control
    from irs_control.controller_factory import make_controller
    spec = make_controller(ctl_params)
    if spec.design is None:
        p = {'kp': 5.0, 'ki': 3.0, **ctl_params}
        return control.tf([float(p['kp']), float(p['ki'])], [1.0, 0.0])
    return control.tf(spec.design.S, spec.design.R)


def _plant_tf(rig):
    """Continuous steer -> y_s of the rig's plant (its own continuous matrices)."""
    import control
    p = rig.plant
    return control.ss2tf(control.ss(p.A, p.B[:, :1], p.C, p.D[:, :1]))


def linear_metrics(ctl_params: dict | None, rig) -> dict:
    """``stable``, margins and crossover of the point's loop; nan without a controller.

    Loop of the point::

        L(s) = C(s) Pa(s) P(s) e^{-s tau}
        C = S/R (MRC/RST design of the point; R u = T u_c - S y)  or  (kp s + ki)/s (PI)
        Pa = w_a/(s + w_a),  w_a = 2 pi lag_hz     (the rig's actuator lag, if enabled)
        P  = the rig's lateral plant, steer -> y_s (Eq. 6 with the rig's gain, or its preset)
        tau = the rig's actuator delay [s] (if enabled)

    * ``stable`` [0/1]: every closed-loop pole of ``L/(1+L)`` with the delay as a 5th-order Pade
      approximation (``control.pade``) has ``Re s < 0`` (continuous loop: the 1 kHz sampling,
      backlash, rate limit and saturation are not in it -- the simulation metrics have them);
    * ``gain_margin_db`` [dB], ``phase_margin_deg`` [deg], ``crossover_hz`` [Hz] (gain crossover):
      :func:`delayed_loop_margins` of ``L`` with the delay exact, crossings looked for on 2000
      frequencies from 0.01 to 1000 rad/s; inf when there is no crossing.
    """
    nan = {k: math.nan for k in LINEAR_METRICS}
    if ctl_params is None:
        return nan
    import control
    C = _controller_tf(ctl_params)
    P = _plant_tf(rig)
    act = rig.act_front.params
    G = C * P
    if act.enable_lag:
        wa = 2.0 * math.pi * act.lag_hz
        G = G * control.tf([wa], [1.0, wa])
    tau = float(act.delay) if act.enable_delay else 0.0
    Gd = G
    if tau > 0:
        num, den = control.pade(tau, PADE_ORDER)
        Gd = G * control.tf(num, den)
    poles = control.poles(control.feedback(Gd, 1))
    num, den = (np.asarray(c[0][0], float) for c in control.tfdata(G))
    gm, pm, wgc = delayed_loop_margins(num, den, tau, OMEGA)
    gm_db = 20.0 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf
    return {'stable': float(np.all(np.real(poles) < 0.0)),
            'gain_margin_db': float(gm_db),
            'phase_margin_deg': float(pm) if np.isfinite(pm) else math.inf,
            'crossover_hz': float(wgc) / (2.0 * math.pi) if np.isfinite(wgc) else math.nan}


def delayed_loop_margins(num, den, delay: float, omega) -> tuple:
    r"""Gain margin [-], phase margin [deg] and gain crossover [rad/s] of a loop with a delay.

    The loop is ``L(j w) = num(j w) / den(j w) e^{-j w delay}``. The margins follow the rules
    of ``control.stability_margins``: the gain margin ``1/|L|`` at the phase crossover (``L`` on
    the negative real axis) whose ``|log GM|`` is smallest; the phase margin
    ``angle(L) mod 360 - 180`` at the gain crossover (``|L| = 1``) whose ``|PM|`` is smallest;
    inf (crossover nan) when ``L`` has no such crossing. Crossings are bracketed by sign changes
    on the frequencies ``omega`` and located by ``scipy.optimize.brentq`` on the exact response.

    ``control.stability_margins`` handles a delay only as frequency-response data, which it
    interpolates by splines evaluated one frequency at a time (about 6,000 ``splev`` calls and
    80 ms per loop on 2000 frequencies); here the response is the polynomials' own, and a
    sweep point's margins take 0.6 ms. Without the delay the results are those of
    ``control.stability_margins`` on the transfer function (tested).
    """
    from scipy.optimize import brentq
    num, den = np.asarray(num, float), np.asarray(den, float)
    omega = np.asarray(omega, float)

    def loop(w):
        s = 1j * w
        return np.polyval(num, s) / np.polyval(den, s) * np.exp(-s * delay)

    def arg_neg(w):            # angle(-L): 0 where L is on the negative real axis
        return np.angle(-loop(w))

    def mag_less_one(w):
        return np.abs(loop(w)) - 1.0

    resp = loop(omega)
    i = np.flatnonzero(np.diff(np.sign(np.angle(-resp))))
    i = i[np.real(resp[i]) <= 0.0]     # a sign change of angle(-L) across its +-pi cut is none
    w180 = np.array([brentq(arg_neg, omega[k], omega[k + 1]) for k in i])
    j = np.flatnonzero(np.diff(np.sign(np.abs(resp) - 1.0)))
    wc = np.array([brentq(mag_less_one, omega[k], omega[k + 1]) for k in j])
    gm, pm, wgc = math.inf, math.inf, math.nan
    with np.errstate(divide='ignore'):
        gms = 1.0 / np.abs(loop(w180))
    if gms.size and not np.isinf(gms).all():
        with np.errstate(divide='ignore'):
            gm = float(gms[np.argmin(np.abs(np.log(gms)))])
    if wc.size:
        pms = np.remainder(np.angle(loop(wc), deg=True), 360.0) - 180.0
        k = int(np.argmin(np.abs(pms)))
        pm, wgc = float(pms[k]), float(wc[k])
    return gm, pm, wgc
