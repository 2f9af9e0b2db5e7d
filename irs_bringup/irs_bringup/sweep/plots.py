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


def _edges(v, log):
    v = np.asarray(v, float)
    if v.size == 1:
        return np.array([v[0] * 0.9, v[0] * 1.1]) if log else np.array([v[0] - 0.5, v[0] + 0.5])
    w = np.log(v) if log else v
    mid = (w[1:] + w[:-1]) / 2
    e = np.concatenate([[w[0] - (mid[0] - w[0])], mid, [w[-1] + (w[-1] - mid[-1])]])
    return np.exp(e) if log else e


def _is_log_axis(vals):
    v = np.asarray(vals, float)
    return v.size > 2 and np.all(v > 0) and np.allclose(np.diff(np.log(v)),
                                                        np.log(v[1] / v[0]), rtol=1e-6)


def heatmap(rows, plot, units, path: Path, title: str = '', sweep_units=None) -> Path:
    """Write the heat map (or boundary) ``plot`` (a :class:`.sweep_file.PlotModel`) to ``path``.

    ``units``: metric -> unit; ``sweep_units``: axis name -> unit (axis labels).
    """
    sweep_units = sweep_units or {}
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm, Normalize
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
    fig, axes = plt.subplots(1, len(facets), figsize=(4.6 * len(facets) + 1.2, 4.4),
                             squeeze=False, sharey=True, constrained_layout=True)
    mesh = None
    for ax, f, (xs, ys, Z) in zip(axes[0], facets, grids):
        numx = all(isinstance(v, float) for v in xs)
        numy = all(isinstance(v, float) for v in ys)
        lx, ly = numx and _is_log_axis(xs), numy and _is_log_axis(ys)
        X = _edges(xs, lx) if numx else np.arange(len(xs) + 1) - 0.5
        Y = _edges(ys, ly) if numy else np.arange(len(ys) + 1) - 0.5
        Zc = np.ma.masked_invalid(np.clip(Z, None, vmax) if plot.vmax is not None else Z)
        mesh = ax.pcolormesh(X, Y, Zc, norm=norm, cmap='viridis', shading='flat')
        cx = np.asarray(xs, float) if numx else np.arange(len(xs))
        cy = np.asarray(ys, float) if numy else np.arange(len(ys))
        if len(xs) * len(ys) <= 80:
            for j in range(len(ys)):
                for i in range(len(xs)):
                    ax.text(cx[i], cy[j], _fmt(Z[j, i]), ha='center', va='center', fontsize=7,
                            color='w' if np.isfinite(Z[j, i]) else 'k')
        if plot.kind == 'boundary' and np.isfinite(Z).sum() >= 4 and len(xs) > 1 and len(ys) > 1:
            beyond = np.ma.masked_where(~(Z < plot.threshold), np.ones_like(Z))
            ax.pcolor(X, Y, beyond, hatch='//', alpha=0.0, shading='flat')
            try:
                cs = ax.contour(cx, cy, np.nan_to_num(Z, nan=plot.threshold - 1.0),
                                levels=[plot.threshold], colors='r', linewidths=2)
                ax.clabel(cs, fmt=f'{plot.metric} = {plot.threshold:g}', fontsize=7)
            except ValueError:
                pass
        if lx:
            ax.set_xscale('log')
        if ly:
            ax.set_yscale('log')
        if not numx:
            ax.set_xticks(cx, [str(v) for v in xs])
        if not numy:
            ax.set_yticks(cy, [str(v) for v in ys])
        ax.set_xlabel(_label(sweep_units, plot.x))
        if ax is axes[0][0]:
            ax.set_ylabel(_label(sweep_units, plot.y))
        ax.set_title(f'{plot.facet} = {f}' if plot.facet else plot.metric, fontsize=9)
    label = f'{plot.metric} [{units.get(plot.metric, "")}]' + (' (log)' if plot.log else '')
    fig.colorbar(mesh, ax=axes[0].tolist(), label=label, shrink=0.9)
    extra = (f'; hatched/red: {plot.metric} < {plot.threshold:g}'
             if plot.kind == 'boundary' else '')
    fig.suptitle((title or plot.metric) + extra, fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
