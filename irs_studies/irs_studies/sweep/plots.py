"""Sweep summary table and plots (matplotlib, Agg; no rclpy).

* :func:`grid` -- the mean over seeds (and over any axis not named) of a metric on an ``x`` by
  ``y`` grid of axis values; NaN where no point ran or every one was refused.
* :func:`heatmap` -- one panel per ``facet`` value, the metric coloured (optionally log10), the
  values written in the cells; ``boundary`` plots add the contour where the metric crosses the
  threshold (``matplotlib.contour`` on the grid: the metric linearly interpolated between grid
  points) and hatch the cells beyond it.
* :func:`summary_markdown` -- per metric and facet, the x-by-y table of :func:`grid`.
"""
from __future__ import annotations

import math
from pathlib import Path
import textwrap

import numpy as np


def _axis_order(rows, name):
    seen = []
    for r in rows:
        if r[name] not in seen:
            seen.append(r[name])
    return sorted(seen) if all(isinstance(v, (int, float)) for v in seen) else seen


def grid(rows, x, y, metric, where=None):
    """``(xs, ys, Z)`` with ``Z[j, i]`` the mean of ``metric`` at ``(xs[i], ys[j])``."""
    sel = [r for r in rows if not where or all(r[k] == v for k, v in where.items())]
    xs, ys = _axis_order(rows, x), _axis_order(rows, y)
    Z = np.full((len(ys), len(xs)), np.nan)
    for j, yv in enumerate(ys):
        for i, xv in enumerate(xs):
            vals = [r[metric] for r in sel if r[x] == xv and r[y] == yv
                    and r[metric] is not None and not math.isnan(r[metric])]
            if vals:
                Z[j, i] = float(np.mean(vals))
    return xs, ys, Z


def _fmt(v):
    if not np.isfinite(v):
        return 'nan' if np.isnan(v) else ('inf' if v > 0 else '-inf')
    return f'{v:.3g}'


def summary_markdown(rows, sweep, units) -> str:
    """Markdown: the sweep's description, then per plotted metric and facet the x-by-y table."""
    lines = [f'# Sweep {sweep.name}', '', sweep.description, '',
             f'{len(rows)} points, {sum(bool(r["error"]) for r in rows)} refused by the cores.',
             '']
    tables = [(p.x, p.y, p.metric, p.facet) for p in sweep.plots] or []
    if not tables:
        names = [a.name for a in sweep.axes]
        tables = [(names[0], names[1] if len(names) > 1 else 'seed', m, None)
                  for m in sweep.metrics]
    seen = set()
    for x, y, metric, facet in tables:
        if (x, y, metric, facet) in seen:
            continue
        seen.add((x, y, metric, facet))
        facets = _axis_order(rows, facet) if facet else [None]
        for f in facets:
            xs, ys, Z = grid(rows, x, y, metric, {facet: f} if facet else None)
            title = f'{metric} [{units.get(metric, "")}]' + (f', {facet} = {f}' if facet else '')
            lines += [f'## {title}', '', f'| {y} \\ {x} | ' + ' | '.join(_fmt(v) if isinstance(
                v, float) else str(v) for v in xs) + ' |',
                '|' + '---|' * (len(xs) + 1)]
            for j, yv in enumerate(ys):
                lines.append(f'| {_fmt(yv) if isinstance(yv, float) else yv} | '
                             + ' | '.join(_fmt(v) for v in Z[j]) + ' |')
            lines.append('')
    errors = sorted({r['error'] for r in rows if r['error']})
    if errors:
        lines += ['## Refused points', ''] + [f'- {e}' for e in errors[:10]] + ['']
    return '\n'.join(lines)


def _label(units, name):
    return f'{name} [{units[name]}]' if units.get(name) else name


def heatmap(rows, plot, units, path: Path, title: str = '', sweep_units=None) -> Path:
    """Write the heat map (or boundary) ``plot`` (a :class:`.sweep_file.PlotModel`) to ``path``.

    ``units``: metric -> unit; ``sweep_units``: axis name -> unit (axis labels). Cells are
    evenly spaced, one per axis value (ticks name the values: sweeps are often log-spaced or
    uneven); the boundary contour is interpolated between cell centres.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm, Normalize
    from matplotlib.patches import Rectangle
    sweep_units = sweep_units or {}
    facets = _axis_order(rows, plot.facet) if plot.facet else [None]
    grids = [grid(rows, plot.x, plot.y, plot.metric, {plot.facet: f} if plot.facet else None)
             for f in facets]
    allz = np.concatenate([g[2].ravel() for g in grids])
    finite = allz[np.isfinite(allz)]
    vmax = plot.vmax if plot.vmax is not None else (float(finite.max()) if finite.size else 1.0)
    if plot.log and finite.size and (finite > 0).any():
        vmin = float(finite[finite > 0].min())
        norm = LogNorm(vmin=vmin, vmax=max(vmax, vmin * 10))
    else:
        norm = Normalize(vmin=float(finite.min()) if finite.size else 0.0, vmax=vmax)
    cmap = plt.get_cmap('viridis').with_extremes(bad='0.85')   # grey: no result
    width = max(4.3 * len(facets) + 1.6, 7.0)
    fig, axes = plt.subplots(1, len(facets), figsize=(width, 4.8),
                             squeeze=False, sharey=True, constrained_layout=True)
    mesh = None
    for ax, f, (xs, ys, Z) in zip(axes[0], facets, grids):
        nx, ny = len(xs), len(ys)
        Zc = np.ma.masked_invalid(np.clip(Z, None, vmax) if plot.vmax is not None else Z)
        mesh = ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, Zc, norm=norm,
                             cmap=cmap, shading='flat')
        if nx * ny <= 100:
            for j in range(ny):
                for i in range(nx):
                    v = Z[j, i]
                    dark = np.isfinite(v) and np.mean(cmap(norm(min(v, vmax)))[:3]) < 0.5
                    ax.text(i, j, _fmt(v), ha='center', va='center', fontsize=7,
                            color='w' if dark else 'k')
        if plot.kind == 'boundary':
            for j in range(ny):
                for i in range(nx):
                    if Z[j, i] < plot.threshold:
                        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False,
                                               hatch='//', edgecolor='r', lw=0))
            if np.isfinite(Z).sum() >= 4 and nx > 1 and ny > 1:
                try:
                    ax.contour(np.arange(nx), np.arange(ny), np.ma.masked_invalid(Z),
                               levels=[plot.threshold], colors='r', linewidths=2)
                except ValueError:
                    pass
        ax.set_xticks(np.arange(nx), [_fmt(v) if isinstance(v, float) else str(v) for v in xs],
                      fontsize=8)
        ax.set_yticks(np.arange(ny), [_fmt(v) if isinstance(v, float) else str(v) for v in ys],
                      fontsize=8)
        ax.set_xlabel(_label(sweep_units, plot.x))
        if ax is axes[0][0]:
            ax.set_ylabel(_label(sweep_units, plot.y))
        ax.set_title(f'{plot.facet} = {f}' if plot.facet else plot.metric, fontsize=9)
    label = f'{plot.metric} [{units.get(plot.metric, "")}]' + (' (log scale)' if plot.log else '')
    fig.colorbar(mesh, ax=axes[0].tolist(), label=label, shrink=0.9)
    extra = (f'\nred: boundary {plot.metric} = {plot.threshold:g}, hatched: {plot.metric} < '
             f'{plot.threshold:g}' if plot.kind == 'boundary' else '')
    text = (title or plot.metric) + extra + '; grey: no result (refused point)'
    fig.suptitle('\n'.join(textwrap.fill(line, int(width * 15)) for line in text.split('\n')),
                 fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
