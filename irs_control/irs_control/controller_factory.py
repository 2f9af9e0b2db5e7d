"""Build a lateral controller from a flat parameter mapping (no rclpy).

The lateral-controller node and the offline closed-loop simulation both call
:func:`make_controller`, so the design the node computes at start-up is the one the offline
simulation uses.

The mapping names the controller (MRC/RST or PI), the design plant (steer [rad] -> sensor-point
lateral displacement y_s [m]: the paper's Eq. 6, a preset's bicycle model or a custom
polynomial pair; :func:`plant_polynomials`), the reference model, the observer and the
anti-windup; :func:`make_controller` designs and discretises it.
"""
from dataclasses import dataclass

import numpy as np

from irs_models.bicycle import transfer_function
from irs_models.constants import (IDENTIFICATION_SPEED, PAPER_ACTUATOR_POLE, PAPER_PLANT_GAIN,
                                  SENSOR_DISTANCE, STEER_LIMIT)
from irs_models.identified import identified_plant
from irs_models.presets import get_preset

from .discrete_pi import DiscretePiController
from .discrete_rst import DEFAULT_INPUT_LIMIT, DiscreteRstController, anti_windup_mode
from .paper_design import reference_model
from .polynomials import require_polynomial
from .rst_design import RstDesign, design_rst

_BM, _AM = reference_model()

#: Defaults of every controller parameter (also the node's parameter defaults).
CONTROLLER_DEFAULTS = {
    'mode': 'mrc',
    'dt': 0.001,
    'plant': 'identified',
    'speed': IDENTIFICATION_SPEED,
    'ds': SENSOR_DISTANCE,
    'plant_gain': 0.0,
    'plant_num': [0.0],
    'plant_den': [0.0],
    'include_actuator': True,
    'actuator_pole': PAPER_ACTUATOR_POLE,
    'reference_model_num': [float(c) for c in _BM],
    'reference_model_den': [float(c) for c in _AM],
    'observer': [0.0],
    'cancel_zeros': 'stable',
    'kp': 5.0,
    'ki': 3.0,
    'steer_limit': STEER_LIMIT,
    'anti_windup': 'back_calculation',
    'check_plant': 'identified',
    'allow_unstable_design': False,
}


#: Optional keys of :func:`make_controller`: the bad-input rule's bounds [m] (see the module
#: docstring); not in :data:`CONTROLLER_DEFAULTS` so that a node need not declare them.
INPUT_CHECK_DEFAULTS = {
    'measurement_limit': DEFAULT_INPUT_LIMIT,
    'reference_limit': DEFAULT_INPUT_LIMIT,
    'initial_reference': 0.0,
}


@dataclass
class LateralControllerSpec:
    """What :func:`make_controller` built: the controller, and the design for an MRC."""

    controller: object
    design: RstDesign | None
    summary: str


def plant_polynomials(cfg: dict):
    """``(B, A)`` of the design plant described by ``cfg``.

    Plant used for an MRC design (steer [rad] -> sensor-point lateral displacement y_s [m]):

    - ``plant = 'identified'``: the paper's Eq. 6 plant with the reconstructed gain
      (:mod:`.paper_design`), with or without the actuator lag ``p/(s+p)``.
    - ``plant = <preset name>``: the physical bicycle model of that preset at ``speed`` and ``ds``
      (:func:`irs_models.bicycle.transfer_function`), with or without the actuator lag.
    - ``plant = 'custom'``: the vehicle ``plant_num / plant_den`` (coefficient lists, highest power
      first, ``plant_den`` monic; e.g. a model identified by ``sysid vehicle``), with or without
      the actuator lag. Used by ``sysid cycle`` (identify, design, run).

    The reference model (``reference_model_num``/``_den``) and observer polynomial (``observer``;
    ``[0.0]`` = the paper's choice: ``(s+12)^2`` with the actuator, ``s+12`` without) are
    coefficient lists, highest power first.
    """
    include = bool(cfg['include_actuator'])
    pole = float(cfg['actuator_pole'])
    if cfg['plant'] == 'identified':
        gain = float(cfg['plant_gain']) or PAPER_PLANT_GAIN
        return identified_plant(include, pole, gain)
    if cfg['plant'] == 'custom':
        num = require_polynomial('plant_num', cfg['plant_num'])
        den = require_polynomial('plant_den', cfg['plant_den'], monic=True)
        if num.size > den.size:
            raise ValueError('plant_num/plant_den must be proper (deg num <= deg den)')
        if include:
            num, den = pole * num, np.polymul(den, [1.0, pole])
        return num, den
    try:
        preset = get_preset(cfg['plant'])
    except KeyError as exc:
        raise ValueError(f'plant: {exc.args[0]}') from None
    num, den = transfer_function(preset.params, float(cfg['speed']), float(cfg['ds']),
                                 actuator_pole=pole if include else None, as_control=False)
    return np.trim_zeros(np.asarray(num, float), 'f'), np.asarray(den, float)


def observer_polynomial(cfg: dict) -> np.ndarray:
    """The observer polynomial Ao; ``[0.0]`` selects the paper's choice for the plant."""
    try:
        ao = [float(c) for c in cfg['observer']]
    except (TypeError, ValueError):
        ao = None
    if ao == [0.0]:
        return np.array([1.0, 24.0, 144.0]) if cfg['include_actuator'] else np.array([1.0, 12.0])
    if not ao or ao[0] == 0.0 or not all(np.isfinite(ao)):
        raise ValueError(
            f'observer must be finite polynomial coefficients with a non-zero '
            f'leading coefficient, or [0.0] for the paper choice; got {cfg["observer"]!r}'
        )
    return np.array(ao)


def _finite_number(cfg: dict, key: str, positive: bool = False) -> float:
    v = cfg[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) \
            or (positive and not v > 0):
        kind = 'a positive finite number' if positive else 'a finite number'
        raise ValueError(f'{key} must be {kind}; got {v!r}')
    return float(v)


def check_controller_params(cfg: dict) -> None:
    """Validate the numbers and polynomials of a complete controller mapping, before any design
    arithmetic; raises ``ValueError`` with one sentence naming the parameter.

    Numbers: ``dt``, ``steer_limit``, ``actuator_pole``, ``speed`` positive and finite;
    ``ds``, ``plant_gain`` (>= 0), ``kp``, ``ki`` (>= 0), the input bounds (> 0, inf allowed) and
    ``initial_reference`` finite; ``anti_windup`` one of ``'back_calculation'``, ``'clip'`` (or a
    bool, an alias). Reference model (MRC only): ``reference_model_num`` a non-empty
    list of finite coefficients, not all zero; ``reference_model_den`` the same, monic and
    stable (Hurwitz), of higher degree than the numerator (a strictly proper model).
    """
    for key in ('dt', 'steer_limit', 'actuator_pole', 'speed'):
        _finite_number(cfg, key, positive=True)
    for key in ('ds', 'plant_gain', 'kp', 'ki', 'initial_reference'):
        _finite_number(cfg, key)
    for key in ('plant_gain', 'kp', 'ki'):
        if cfg[key] < 0:
            raise ValueError(f'{key} must be >= 0; got {cfg[key]!r}')
    for key in ('measurement_limit', 'reference_limit'):
        v = cfg[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
            raise ValueError(f'{key} must be a positive bound in m (inf allowed); got {v!r}')
    anti_windup_mode(cfg['anti_windup'])
    if cfg['mode'] != 'mrc':
        return
    bm = require_polynomial('reference_model_num', cfg['reference_model_num'])
    am = require_polynomial('reference_model_den', cfg['reference_model_den'], monic=True,
                            hurwitz=True)
    if bm.size >= am.size:
        raise ValueError(f'the reference model reference_model_num/reference_model_den must be '
                         f'strictly proper (deg num < deg den); got degrees {bm.size - 1} and '
                         f'{am.size - 1}')


def make_controller(params: dict | None = None) -> LateralControllerSpec:
    """Design and discretise the controller that ``params`` describe (missing keys: defaults).

    Raises
    ------
    ValueError
        Unknown keys, or a bad number/polynomial (:func:`check_controller_params`, checked
        before any arithmetic), or an impossible design (:class:`.rst_design.RstDesignError`).

    Notes
    -----
    Anti-windup (``anti_windup``, the paper describes none): ``'back_calculation'`` (default; RST:
    the Astrom-Wittenmark polynomial form, PI: tracking time ``kp/ki``) or ``'clip'`` (the linear
    law runs on, only the output is clipped); see :mod:`.discrete_rst`.

    Design check (``check_plant``, ``allow_unstable_design``): not used here; the node closes the
    loop of the built controller with that plant at start-up (:mod:`.design_check`).

    Bad-input bounds (:data:`INPUT_CHECK_DEFAULTS`, optional keys of :func:`make_controller`, not
    required from the node): ``measurement_limit`` and ``reference_limit`` [m] bound ``|y|`` and
    ``|u_c|`` (see :mod:`.discrete_rst`, bad-input rule), ``initial_reference`` [m] is held until a
    valid reference arrives.
    """
    cfg = {**CONTROLLER_DEFAULTS, **INPUT_CHECK_DEFAULTS, **(params or {})}
    unknown = set(cfg) - set(CONTROLLER_DEFAULTS) - set(INPUT_CHECK_DEFAULTS)
    if unknown:
        raise ValueError(f'unknown controller parameter(s) {sorted(unknown)}')
    check_controller_params(cfg)
    guard = {k: float(cfg[k]) for k in INPUT_CHECK_DEFAULTS}
    limit = float(cfg['steer_limit'])
    dt = float(cfg['dt'])
    if cfg['mode'] == 'pi':
        ctl = DiscretePiController(kp=float(cfg['kp']), ki=float(cfg['ki']), dt=dt,
                                   limits=(-limit, limit), anti_windup=cfg['anti_windup'],
                                   **guard)
        return LateralControllerSpec(
            ctl, None, f'PI: Kp = {cfg["kp"]} rad/m, Ki = {cfg["ki"]} rad/(m s)'
        )
    if cfg['mode'] != 'mrc':
        raise ValueError(f"mode must be 'mrc' or 'pi', got {cfg['mode']!r}")
    B, A = plant_polynomials(cfg)
    design = design_rst(B, A, np.asarray(cfg['reference_model_num'], float),
                        np.asarray(cfg['reference_model_den'], float), observer_polynomial(cfg),
                        cancel=cfg['cancel_zeros'])
    ctl = DiscreteRstController(design, dt=dt, u_min=-limit, u_max=limit,
                                anti_windup=cfg['anti_windup'], **guard)
    fmt = lambda p: '[' + ', '.join(f'{c:.6g}' for c in p) + ']'  # noqa: E731
    summary = (
        f"MRC on plant '{cfg['plant']}' ({'with' if cfg['include_actuator'] else 'without'} "
        f'actuator): R = {fmt(design.R)}, S = {fmt(design.S)}, T = {fmt(design.T)}'
    )
    return LateralControllerSpec(ctl, design, summary)
