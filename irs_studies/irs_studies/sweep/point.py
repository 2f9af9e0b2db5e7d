"""One sweep point: the scenario's offline closed loop with the point's overrides, its metrics.

No rclpy. :func:`run_point` is what a Dask worker runs; it takes only plain data (the scenario's
:class:`~irs_bringup.offline_twin.lateral_loop.LoopConfig` as built once from the experiment file,
the duration, the point and the metric names) and returns one results row, so the same call gives
the same row in any process: the closed loop is deterministic for a given seed (``rig.seed``, the
arm sensor's noise generator), and nothing else in it draws random numbers.
"""
from __future__ import annotations

import copy
import dataclasses
import math

from .metrics import FIGURE10_METRICS, LINEAR_METRICS, METRICS, linear_metrics, \
    simulation_metrics
from .sweep_file import NODES


def apply_overrides(cfg, overrides: dict):
    """A copy of the LoopConfig ``cfg`` with ``{<node>.<param>: value}`` applied.

    ``ValueError`` when a path names a node the scenario does not run.
    """
    new = copy.deepcopy(cfg)
    for path, value in overrides.items():
        node, _, name = path.partition('.')
        section = getattr(new, NODES[node])
        if section is None:
            raise ValueError(f"'{path}': the scenario has no {node} node")
        section[name] = value
    if 'rig.default_drive_voltage' in overrides:
        new = dataclasses.replace(new, default_drive_voltage=float(
            overrides['rig.default_drive_voltage']))
    return new


def run_point(cfg, duration: float, point: dict, metrics: list) -> dict:
    """Simulate ``point`` (see :func:`irs_studies.sweep.axes.sweep_points`) and measure it.

    Returns the row ``{'point', 'seed', <axis values>, <metrics>, 'error'}``: a point whose
    parameters the cores refuse (an impossible design, an invalid value) gets NaN metrics and
    the refusal in ``error`` -- one bad point does not stop a sweep.
    """
    from irs_bringup.offline_twin.lateral_loop import ClosedLoop
    row = {k: v for k, v in point.items() if k != 'overrides'}
    row.update({m: math.nan for m in metrics})
    row['error'] = ''
    errors = []

    def attempt(compute):
        """``compute()``, or None with its refusal noted in ``errors``."""
        try:
            return compute()
        except REFUSALS as exc:
            msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
            errors.append(f'{type(exc).__name__}: {" ".join(str(msg).split())}')
            return None

    def keep(values):
        row.update({m: v for m, v in (values or {}).items() if m in metrics})

    # the simulated and the linear metrics apart: a sine reference has no step metrics, and
    # still its margins
    loop = attempt(lambda: ClosedLoop(apply_overrides(cfg, point['overrides'])))
    if loop is not None:
        if any(m in FIGURE10_METRICS or m in ('off_belt', 'settled') for m in metrics):
            run = attempt(lambda: loop.run(duration))
            if run is not None:
                keep({'off_belt': float(any(run['fault']))})
                keep(attempt(lambda: simulation_metrics(run)))
        if any(m in LINEAR_METRICS for m in metrics):
            ctl = loop.cfg.controller
            keep(attempt(lambda: linear_metrics(None if ctl is None else {
                k: v for k, v in ctl.items() if k in _controller_keys()}, loop.rig)))
    row['error'] = '; '.join(errors)[:300]
    assert set(metrics) <= set(METRICS)
    return row


#: What a point's cores may raise for parameters they refuse (the row keeps it in ``error``).
REFUSALS = (ValueError, TypeError, KeyError, ArithmeticError, ImportError)


def _controller_keys():
    from irs_control.controller_factory import CONTROLLER_DEFAULTS, INPUT_CHECK_DEFAULTS
    return set(CONTROLLER_DEFAULTS) | set(INPUT_CHECK_DEFAULTS)
