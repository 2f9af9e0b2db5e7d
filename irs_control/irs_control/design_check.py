r"""Start-up check of a lateral-controller design against a configured plant model (no rclpy).

The paper's designs (Sec. 4-5) are computed on the identified plant of Eq. 6. Run on another
plant -- e.g. the ``irs_2wd`` bicycle preset -- the same RST polynomials can give an unstable
loop, and nothing would say so until the car leaves the belt. :func:`check_design` closes the loop
of the controller the node built with the *check plant* and the rig's transport delay, and answers
whether it is stable, with the poles and the margins.

Loop (steer [rad] -> sensor-point lateral displacement y_s [m], unity negative feedback)::

    P(s) = B(s)/A(s)          check plant, always with the actuator lag  p/(s + p)
    C(s) = S(s)/R(s)          MRC/RST feedback part (R u = T u_c - S y);  PI: (kp s + ki)/s
    L(s) = P(s) C(s)          loop transfer function of the margins
    closed-loop poles         roots of  A R + B S = 0                    (continuous)
    delay margin              min over gain crossovers w_i of PM_i / w_i, less the delay T_d

Margins: ``control.stability_margins(L)`` (gain margin [-], phase margin [deg], crossovers
[rad/s]); every gain crossover for the delay margin (``returnall``). The node runs the controller
as its exact ZOH discretisation at ``dt`` (:mod:`.discrete_rst`; PI: forward-Euler integrator),
so the check also closes the *sampled* loop: the plant discretised by ZOH at ``dt``
(``control.c2d``), the transport delay as ``round(T_d / dt)`` samples (exact in the sampled loop),
with the controller's own discrete state space; its poles must lie inside the unit circle. A
design is *stable* when every continuous pole has ``Re s < 0``, the delay margin is positive and
every pole of the sampled loop with the delay has ``|z| < 1``. The delay ``T_d`` is
``check_delay`` (0.017 s: the paper's transmitter delay, the rig's mean); a design that is stable
without it but not with it is refused like an unstable one.

Not in the model: backlash, dead zone, slew limit and saturation (the paper's designs neglect
them too); a design passing this check can still oscillate on the rig (docs/figure10.md), but one
failing it cannot work at all.

Check plant (``check_plant``; the design plant is ``plant``): ``'identified'`` = Eq. 6 with
gain ``plant_gain`` (0 = the paper reconstruction b0 = 363.394, :mod:`irs_models.identified`) --
the rig's default plant; ``'custom'`` = the controller's ``plant_num``/``plant_den``; any other
value names a preset of ``irs_models/config/presets.yaml``, taken at the controller's ``speed``
and ``ds`` (:func:`irs_models.bicycle.transfer_function`). The actuator lag pole is the
controller's ``actuator_pole`` (29 rad/s, Eq. 6).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from irs_models.bicycle import transfer_function
from irs_models.constants import PAPER_PLANT_GAIN
from irs_models.identified import identified_plant
from irs_models.presets import get_preset

from . import design_check_cache

__all__ = ['DesignCheck', 'check_plant_polynomials', 'check_design', 'cached_check_design',
           'check_controller', 'require_stable', 'delay_margin']


@dataclass(frozen=True)
class DesignCheck:
    """Outcome of :func:`check_design`.

    Attributes
    ----------
    plant : str
        The check plant's name (``'identified'`` or a preset).
    poles : numpy.ndarray
        Continuous closed-loop poles [rad/s].
    discrete_poles : numpy.ndarray
        Closed-loop poles of the sampled loop (z-plane).
    gain_margin : float
        [-] (inf when the phase never crosses -180 deg).
    phase_margin : float
        [deg] (inf when |L| never crosses 1).
    wcg, wcp : float
        Phase and gain crossover frequencies [rad/s].
    delay : float
        The transport delay T_d the check includes [s].
    delay_margin : float
        Further delay the loop tolerates beyond ``delay`` [s]: ``min_i PM_i / w_i - T_d`` over
        the gain crossovers (inf without one; -inf when unstable without the delay). Negative:
        unstable with the delay.
    delayed_discrete_poles : numpy.ndarray
        Closed-loop poles of the sampled loop with ``round(delay / dt)`` samples of delay.
    """

    plant: str
    poles: np.ndarray
    discrete_poles: np.ndarray
    gain_margin: float
    phase_margin: float
    wcg: float
    wcp: float
    delay: float = 0.0
    delay_margin: float = math.inf
    delayed_discrete_poles: np.ndarray | None = None

    @property
    def max_real(self) -> float:
        """Largest real part of the continuous closed-loop poles [rad/s]."""
        return float(np.max(self.poles.real))

    @property
    def max_abs_z(self) -> float:
        """Spectral radius of the sampled closed loop [-]."""
        return float(np.max(np.abs(self.discrete_poles)))

    @property
    def max_abs_z_delayed(self) -> float:
        """Spectral radius of the sampled closed loop with the delay [-]."""
        if self.delayed_discrete_poles is None:
            return self.max_abs_z
        return float(np.max(np.abs(self.delayed_discrete_poles)))

    @property
    def stable_without_delay(self) -> bool:
        """Every continuous pole in the open left half plane, every discrete one inside |z| = 1
        (the loop without the transport delay).
        """
        return self.max_real < 0.0 and self.max_abs_z < 1.0

    @property
    def stable(self) -> bool:
        """Stable without the delay, and with it: a positive delay margin and the sampled loop
        with the delay inside |z| = 1.
        """
        return (self.stable_without_delay and self.delay_margin > 0.0
                and self.max_abs_z_delayed < 1.0)

    def unstable_poles(self) -> np.ndarray:
        """Continuous closed-loop poles with ``Re s >= 0`` (upper half plane and real ones)."""
        p = self.poles[self.poles.real >= 0.0]
        return p[p.imag >= -1e-9 * np.abs(p)]

    def summary(self) -> str:
        """One line: stable or not, the rightmost poles and the margins."""
        def fmt(z):
            if abs(z.imag) <= 1e-9 * max(abs(z), 1.0):
                return f'{z.real:+.3g}'
            return f'{z.real:+.3g} +- {abs(z.imag):.3g}j'
        p = self.unstable_poles() if not self.stable_without_delay else \
            self.poles[np.argsort(-self.poles.real)][:3]
        shown = ', '.join(fmt(z) for z in p if z.imag >= -1e-9 * abs(z)) or 'none'
        # A stable loop with a gain margin below 1 is conditionally stable: it loses
        # stability if its gain falls below that factor. An unstable loop's margin says no such
        # thing, so it is printed bare.
        gm = 'inf' if not math.isfinite(self.gain_margin) else f'{self.gain_margin:.3g}' + (
            ' (a lower margin: unstable below that factor of the gain)'
            if self.gain_margin < 1.0 and self.stable else '')
        pm = 'inf' if not math.isfinite(self.phase_margin) else f'{self.phase_margin:.3g} deg'
        td = f'{1000 * self.delay:.3g} ms'
        dm = ('inf' if math.isinf(self.delay_margin) and self.delay_margin > 0
              else f'{1000 * self.delay_margin:+.3g} ms')
        if self.stable:
            return (f"closed loop on plant '{self.plant}' stable with the {td} delay: rightmost "
                    f'poles {shown} rad/s (without the delay), gain margin {gm}, phase margin '
                    f'{pm}, delay margin {dm} (sampled loop with the delay |z| max '
                    f'{self.max_abs_z_delayed:.6f})')
        if self.stable_without_delay:
            return (f"closed loop on plant '{self.plant}' UNSTABLE with the {td} transport "
                    f'delay (stable without it: rightmost poles {shown} rad/s): delay margin '
                    f'{dm}, phase margin {pm} at {self.wcp:.3g} rad/s, gain margin {gm} '
                    f'(sampled loop with the delay |z| max {self.max_abs_z_delayed:.6f})')
        if not len(self.unstable_poles()):   # the continuous loop is stable, the sampled not
            rightmost = self.poles[np.argsort(-self.poles.real)][:3]
            shown = ', '.join(fmt(z) for z in rightmost if z.imag >= -1e-9 * abs(z))
            return (f"closed loop on plant '{self.plant}' UNSTABLE as sampled: |z| max "
                    f'{self.max_abs_z:.6f} (the continuous loop: rightmost poles {shown} rad/s), '
                    f'gain margin {gm}, phase margin {pm}')
        return (f"closed loop on plant '{self.plant}' UNSTABLE: poles {shown} rad/s "
                f'(largest real part {self.max_real:+.3g} rad/s; sampled loop |z| max '
                f'{self.max_abs_z:.6f}), gain margin {gm}, phase margin {pm}')


def check_plant_polynomials(plant: str, actuator_pole: float, plant_gain: float = 0.0,
                            speed: float = 1.2, ds: float = 0.33):
    """``(B, A)`` of the check plant with the actuator lag ``p/(s+p)``, highest power first.

    ``plant = 'identified'``: Eq. 6, ``b0 = plant_gain or PAPER_PLANT_GAIN`` [m/(rad s^3)];
    otherwise a preset name (``ValueError`` if unknown) at ``speed`` [m/s] and ``ds`` [m].
    """
    if plant == 'identified':
        return identified_plant(True, float(actuator_pole), float(plant_gain) or PAPER_PLANT_GAIN)
    try:
        preset = get_preset(plant)
    except KeyError as exc:
        raise ValueError(f'check_plant: {exc.args[0]}') from None
    num, den = transfer_function(preset.params, float(speed), float(ds),
                                 actuator_pole=float(actuator_pole), as_control=False)
    return np.trim_zeros(np.asarray(num, float), 'f'), np.asarray(den, float)


def delay_margin(loop, delay: float = 0.0) -> float:
    """Further delay [s] the stable loop ``loop`` tolerates beyond ``delay``: the smallest
    ``PM_i / w_i`` over its gain crossovers (phase margins in rad, in [0, 2 pi)), less ``delay``;
    inf when ``|L|`` never crosses 1.
    """
    import control

    _gm, pm, _sm, _wpc, wgc, _wms = control.stability_margins(loop, returnall=True)
    pm, wgc = np.atleast_1d(pm), np.atleast_1d(wgc)
    keep = np.isfinite(pm) & np.isfinite(wgc) & (wgc > 0.0)
    if not np.any(keep):
        return math.inf
    tolerated = np.mod(np.radians(pm[keep]), 2.0 * math.pi) / wgc[keep]
    return float(np.min(tolerated)) - float(delay)


def check_design(B, A, R, S, controller_ss, dt: float, plant: str = '',
                 delay: float = 0.0) -> DesignCheck:
    """Close the loop of plant ``B/A`` with feedback ``S/R`` (continuous) and, sampled at ``dt``
    [s], with the controller's discrete state space ``controller_ss = (Ad, Bd, Cd, Dd)`` from y
    to u (the sign included: ``u = -S/R y``); ``delay`` [s] is the transport delay of the steer
    (margins and the sampled loop with ``round(delay / dt)`` samples).
    """
    import control

    P = control.tf(np.asarray(B, float), np.asarray(A, float))
    C = control.tf(np.asarray(S, float), np.asarray(R, float))
    poles = np.asarray(control.poles(control.feedback(P, C)), complex)
    # python-control returns (gm, pm, sm, wpc, wgc, wms): wpc is the phase crossover (where the
    # gain margin is read), wgc the gain crossover (where the phase margin is read).
    with warnings.catch_warnings():   # python-control compares NaN responses (RuntimeWarning
        warnings.simplefilter('ignore', RuntimeWarning)     # on stderr); its results stand
        gm, pm, _sm, wcg, wcp, _wms = control.stability_margins(P * C)
    Pd = control.c2d(control.ss(P), dt, method='zoh')
    K = control.ss(*controller_ss, dt)
    # u = K y and y = P u: a positive-feedback interconnection (K already carries the minus).
    zpoles = np.asarray(control.poles(control.feedback(Pd, K, sign=+1)), complex)
    n = int(round(delay / dt))
    zdelayed = zpoles
    if n > 0:
        z_n = control.ss(control.tf([1.0], [1.0] + [0.0] * n, dt))   # z^-n
        zdelayed = np.asarray(control.poles(control.feedback(Pd * z_n, K, sign=+1)), complex)
    stable0 = np.max(poles.real) < 0.0 and np.max(np.abs(zpoles)) < 1.0
    dm = delay_margin(P * C, delay) if stable0 else -math.inf
    return DesignCheck(plant, poles, zpoles, float(gm), float(pm), float(wcg), float(wcp),
                       float(delay), dm, zdelayed)


def check_controller(cfg: dict, controller, design=None) -> DesignCheck:
    """:func:`check_design` of a controller built by ``controller_factory.make_controller``,
    through the on-disk cache of :mod:`.design_check_cache` (a design checked before answers
    without importing python-control).

    ``cfg`` holds the controller parameters (``mode``, ``kp``, ``ki``, ``dt``, ``actuator_pole``,
    ``plant_gain``, ``speed``, ``ds``, ``check_plant`` and ``check_delay``, 0 if absent);
    ``design`` is the MRC's RstDesign
    (``None`` for the PI); ``controller`` the discrete controller (its ``linear_state_space()``).
    """
    plant = str(cfg['check_plant'])
    if plant == 'custom':      # the vehicle plant_num/plant_den of the design (sysid cycle)
        from .controller_factory import plant_polynomials
        B, A = plant_polynomials({**cfg, 'plant': 'custom', 'include_actuator': True})
    else:
        B, A = check_plant_polynomials(plant, cfg['actuator_pole'], cfg['plant_gain'],
                                       cfg['speed'], cfg['ds'])
    if cfg['mode'] == 'pi' and float(cfg['ki']) == 0.0:      # P: no integrator, no pole at 0
        R, S = np.array([1.0]), np.array([float(cfg['kp'])])
    elif cfg['mode'] == 'pi':
        R, S = np.array([1.0, 0.0]), np.array([float(cfg['kp']), float(cfg['ki'])])
    else:
        R, S = np.asarray(design.R, float), np.asarray(design.S, float)
    return cached_check_design(B, A, R, S, controller.linear_state_space(), float(cfg['dt']),
                               plant, float(cfg.get('check_delay', 0.0)))


def cached_check_design(B, A, R, S, controller_ss, dt: float, plant: str = '',
                        delay: float = 0.0) -> DesignCheck:
    """:func:`check_design` of these inputs, read from the on-disk cache when an entry exists
    (:mod:`.design_check_cache`), computed and stored otherwise.
    """
    key = design_check_cache.cache_key(B, A, R, S, controller_ss, dt, plant, delay)
    check = design_check_cache.load(key, DesignCheck)
    if check is None:
        check = check_design(B, A, R, S, controller_ss, dt, plant, delay)
        design_check_cache.store(key, check)
    return check


def require_stable(cfg: dict, controller, design=None, label: str = 'design'):
    """Run :func:`check_controller`; refuse an unstable loop unless ``allow_unstable_design``.

    Unstable includes stable without the delay but not with it (a negative delay margin).
    Returns ``(check, message, ok)``: ``ok`` False means unstable but allowed (the caller warns
    with ``message``). Raises ``ValueError`` with one line (which poles or which delay margin,
    which plant, how to override) when the loop is unstable and ``cfg['allow_unstable_design']``
    is false.
    """
    check = check_controller(cfg, controller, design)
    msg = f'{label}: {check.summary()}'
    if check.stable:
        return check, msg, True
    if not cfg.get('allow_unstable_design', False):
        raise ValueError(f'{msg}; refusing to start (check_plant selects the plant model, '
                         'check_delay the delay; allow_unstable_design:=true runs it anyway)')
    return check, msg + ' -- running anyway (allow_unstable_design is true)', False
