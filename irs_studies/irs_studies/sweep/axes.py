"""Axes -> points: the Cartesian product of the grid axes times the seeds (no rclpy).

* ``values`` / ``range`` (``numpy.linspace``) / ``log_range`` (``numpy.geomspace``): numbers;
  each parameter of ``set`` gets ``factor * value``.
* ``cases``: names; each case's overrides are applied as written.
* ``normal`` / ``uniform``: Monte Carlo axes; they do not multiply the points: each point draws
  one value per seed from ``numpy.random.default_rng(SeedSequence([seed, crc32(axis name)]))``,
  so a draw depends on the seed and the axis only (deterministic, the same in every process
  and on every worker, independent of the point's place in the sweep).

A point's key (``point`` column) is the JSON of its grid values and seed: what a resumed sweep
compares to skip points already in the results.
"""
from __future__ import annotations

import itertools
import json
import zlib

import numpy as np

from .sweep_file import SweepModel

GRID_KINDS = ('values', 'range', 'log_range', 'cases')


def axis_values(axis) -> list:
    """The values of a grid axis (floats, or case names)."""
    if axis.kind == 'values':
        return [float(v) for v in axis.values]
    if axis.kind == 'range':
        r = axis.range
        return [float(v) for v in np.linspace(r.start, r.stop, r.num)]
    if axis.kind == 'log_range':
        r = axis.log_range
        return [float(v) for v in np.geomspace(r.start, r.stop, r.num)]
    if axis.kind == 'cases':
        return list(axis.cases)
    raise ValueError(f"axis '{axis.name}' is a Monte Carlo axis: it has no grid values")


def monte_carlo_value(axis, seed: int) -> float:
    """The draw of a Monte Carlo axis for ``seed`` (module docstring)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(
        axis.name.encode())]))
    if axis.kind == 'normal':
        return float(rng.normal(axis.normal.mean, axis.normal.std))
    return float(rng.uniform(axis.uniform.low, axis.uniform.high))


def axis_overrides(axis, value) -> dict:
    """``{<node>.<parameter>: value}`` that ``axis`` at ``value`` sets."""
    if axis.kind == 'cases':
        return dict(axis.cases[value])
    return {path: factor * float(value) for path, factor in axis.set.items()}


def point_key(grid: dict, seed: int) -> str:
    """Stable identity of a point: sorted JSON of its grid values and seed."""
    return json.dumps({**grid, 'seed': int(seed)}, sort_keys=True)


def count_points(sweep: SweepModel) -> int:
    """How many points the sweep has (grid sizes times seeds), without generating them."""
    n = len(sweep.seed_list)
    for a in sweep.axes:
        if a.kind in GRID_KINDS:
            n *= _axis_len(a)
    return n


def _axis_len(axis) -> int:
    if axis.kind == 'values':
        return len(axis.values)
    if axis.kind in ('range', 'log_range'):
        return (axis.range or axis.log_range).num
    return len(axis.cases)


def override_paths(sweep: SweepModel) -> set:
    """Every ``<node>.<parameter>`` some point of the sweep sets (no point generated)."""
    paths = set(sweep.fixed) | {'rig.seed'}
    for a in sweep.axes:
        paths |= set(a.set)
        for case in (a.cases or {}).values():
            paths |= set(case)
    return paths


def iter_points(sweep: SweepModel):
    """The points of :func:`sweep_points`, one at a time (a sweep of any size in little memory).

    Overrides apply in order: ``fixed``, then the axes in file order, then ``rig.seed``.
    """
    grid_axes = [a for a in sweep.axes if a.kind in GRID_KINDS]
    mc_axes = [a for a in sweep.axes if a.kind not in GRID_KINDS]
    for combo in itertools.product(*(axis_values(a) for a in grid_axes)):
        grid = dict(zip((a.name for a in grid_axes), combo))
        for seed in sweep.seed_list:
            values = dict(grid)
            for a in mc_axes:
                values[a.name] = monte_carlo_value(a, seed)
            overrides = dict(sweep.fixed)
            for a in sweep.axes:
                overrides.update(axis_overrides(a, values[a.name]))
            overrides['rig.seed'] = int(seed)
            yield {'point': point_key(grid, seed), 'seed': int(seed), **values,
                   'overrides': overrides}


def sweep_points(sweep: SweepModel) -> list[dict]:
    """Every point: ``{'point', 'seed', <axis>: value, ..., 'overrides': {path: value}}``."""
    return list(iter_points(sweep))
