"""Sweep summary table and plots (matplotlib, Agg; no rclpy).

* :func:`grid` -- the mean over seeds (and over any axis not named) of a metric on an ``x`` by
  ``y`` grid of axis values; NaN where no point ran or every one was refused.
* :func:`heatmap` -- one panel per ``facet`` value, the metric coloured (optionally log10; the
  scale clipped at a percentile of the points that did not diverge, 0/1 metrics in two
  colours), diverged points crossed out, the values written in the cells; ``boundary`` plots
  add the contour where the metric crosses the threshold (``matplotlib.contour`` on the grid:
  the metric linearly interpolated between grid points) and hatch the cells below it.
* :func:`summary_markdown` -- per metric and facet, the x-by-y table of :func:`grid`: a cell
  with no point run yet is empty, one whose points were all refused by the cores says
  ``refused``.
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


def _cell_text(rows, x, y, xs, ys, Z, where=None):
    """``T[j][i]``: the value of ``Z[j, i]``, ``'refused'`` where every point at ``(xs[i],
    ys[j])`` was refused by the cores, ``''`` where none has run.
    """
    sel = [r for r in rows if not where or all(r[k] == v for k, v in where.items())]
    text = []
    for j, yv in enumerate(ys):
        row = []
        for i, xv in enumerate(xs):
            here = [r for r in sel if r[x] == xv and r[y] == yv]
            if not here:
                row.append('')
            elif all(r['error'] for r in here):
                row.append('refused')
            else:
                row.append(_fmt(Z[j, i]))
        text.append(row)
    return text


def summary_markdown(rows, sweep, units) -> str:
    """Markdown: the sweep's description, then per plotted metric and facet the x-by-y table
    (an empty cell: not run yet; ``refused``: refused by the cores, the reasons at the end).
    """
    lines = [f'# Sweep {sweep.name}', '', sweep.description, '',
             f'{len(rows)} points, {sum(bool(r["error"]) for r in rows)} refused by the cores. '
             'In the tables an empty cell has not run yet.', '']
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
            where = {facet: f} if facet else None
            xs, ys, Z = grid(rows, x, y, metric, where)
            text = _cell_text(rows, x, y, xs, ys, Z, where)
            title = f'{metric} [{units.get(metric, "")}]' + (f', {facet} = {f}' if facet else '')
            lines += [f'## {title}', '', f'| {y} \\ {x} | ' + ' | '.join(_fmt(v) if isinstance(
                v, float) else str(v) for v in xs) + ' |',
                '|' + '---|' * (len(xs) + 1)]
            for j, yv in enumerate(ys):
                lines.append(f'| {_fmt(yv) if isinstance(yv, float) else yv} | '
                             + ' | '.join(text[j]) + ' |')
            lines.append('')
    errors = sorted({r['error'] for r in rows if r['error']})
    if errors:
        lines += ['## Refused points', ''] + [f'- {e}' for e in errors[:10]] + ['']
    return '\n'.join(lines)


def _label(units, name):
    return f'{name} [{units[name]}]' if units.get(name) else name


#: Colour-scale clip of a heat map: this percentile of the points that did not diverge.
CLIP_PERCENTILE = 95.0
#: The two colours of a 0/1 metric (0, 1) and the colour of cells beyond the clip.
BINARY_COLOURS = ('#c0504d', '#4f81bd')
OVER_COLOUR = '#e377c2'


def diverged(rows, x, y, where=None):
    """``D[j, i]`` True where any run at ``(xs[i], ys[j])`` diverged: ``off_belt`` = 1 or
    ``stable`` = 0 (the metrics the rows carry; False where they carry neither).
    """
    def bad(r):
        off, st = r.get('off_belt'), r.get('stable')
        return (off is not None and off == off and off >= 0.5) or \
            (st is not None and st == st and st < 0.5)
    marked = [dict(r, _diverged=float(bad(r))) for r in rows]
    _, _, D = grid(marked, x, y, '_diverged', where)
    return np.nan_to_num(D) > 0


def is_binary(metric, units, values) -> bool:
    """A 0/1 metric: its unit says so, or every value is 0 or 1."""
    finite = values[np.isfinite(values)]
    return units.get(metric) == '0/1' or (finite.size > 0 and np.isin(finite, (0.0, 1.0)).all())


def _clip_top(v: np.ndarray) -> float:
    """The top of the colour scale for values ``v``: their maximum, unless it lies further
    above the :data:`CLIP_PERCENTILE` th percentile p_hi than the width p_hi - p_lo of the
    percentile band (p_lo: 100 - :data:`CLIP_PERCENTILE`), an outlier: then p_hi.
    """
    lo, hi = np.percentile(v, [100 - CLIP_PERCENTILE, CLIP_PERCENTILE])
    return float(hi) if v.max() - hi > max(hi - lo, 1e-12) else float(v.max())


def colour_scale(plot, values, diverged_mask, units):
    """``(cmap, norm, extend)`` of ``plot`` for ``values`` (every panel's cells): two colours
    for a 0/1 metric; else viridis over the points that did not diverge, from their minimum to
    :func:`_clip_top` of them (or ``plot.vmax``), linear or log10, cells above in
    :data:`OVER_COLOUR`.
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize
    import matplotlib
    if is_binary(plot.metric, units, values):
        cmap = ListedColormap(BINARY_COLOURS).with_extremes(bad='0.85')
        return cmap, BoundaryNorm([-0.5, 0.5, 1.5], 2), 'neither'
    ok = np.isfinite(values) & (~diverged_mask if diverged_mask.any() else True)
    if plot.log:
        ok &= values > 0
    pool = values[ok] if ok.any() else values[np.isfinite(values)]
    if pool.size == 0:
        pool = np.array([0.0, 1.0])
    top = _clip_top(np.log10(pool) if plot.log and (pool > 0).all() else pool)
    top = 10 ** top if plot.log and (pool > 0).all() else top
    vmax = plot.vmax if plot.vmax is not None else top
    vmin = float(pool.min())
    if plot.log and vmin > 0:
        norm = LogNorm(vmin=vmin, vmax=max(vmax, vmin * 10))
    else:
        norm = Normalize(vmin=vmin, vmax=vmax if vmax > vmin else vmin + 1.0)
    cmap = matplotlib.colormaps['viridis'].with_extremes(bad='0.85', over=OVER_COLOUR)
    finite = values[np.isfinite(values)]
    return cmap, norm, 'max' if finite.size and finite.max() > norm.vmax else 'neither'


def _cross(ax, D) -> None:
    """A cross over every cell where ``D`` is true (a diverged run)."""
    for j, i in zip(*np.nonzero(D)):
        ax.plot([i - 0.45, i + 0.45], [j - 0.45, j + 0.45], color='k', lw=0.8)
        ax.plot([i - 0.45, i + 0.45], [j + 0.45, j - 0.45], color='k', lw=0.8)


def _values(ax, Z, D, cmap, norm, fontsize: int) -> None:
    """Each cell's value written in it, light on dark colours; on a white box where crossed."""
    ny, nx = Z.shape
    for j in range(ny):
        for i in range(nx):
            v = Z[j, i]
            rgb = cmap(norm(v))[:3] if np.isfinite(v) else (0.85,) * 3
            ax.text(i, j, _fmt(v), ha='center', va='center', fontsize=fontsize,
                    color='w' if np.mean(rgb) < 0.5 else 'k',
                    bbox=dict(boxstyle='round,pad=0.1', fc='w', ec='none', alpha=0.6)
                    if D[j, i] else None)


def _boundary(ax, Z, threshold: float) -> None:
    """Cells below ``threshold`` hatched, and the contour ``Z = threshold`` between the cells'
    centres (where at least 4 cells have a value on a grid of at least 2 x 2).
    """
    from matplotlib.patches import Rectangle
    ny, nx = Z.shape
    for j in range(ny):
        for i in range(nx):
            if Z[j, i] < threshold:
                ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch='//',
                                       edgecolor='0.2', lw=0))
    if np.isfinite(Z).sum() >= 4 and nx > 1 and ny > 1:
        try:
            ax.contour(np.arange(nx), np.arange(ny), np.ma.masked_invalid(Z),
                       levels=[threshold], colors='k', linewidths=2)
        except ValueError:
            pass


def heatmap(rows, plot, units, path: Path, title: str = '', sweep_units=None) -> Path:
    """Write the heat map (or boundary) ``plot`` (a :class:`.sweep_file.PlotModel`) to ``path``.

    ``units``: metric -> unit; ``sweep_units``: axis name -> unit (axis labels). Cells are
    evenly spaced, one per axis value (ticks name the values: sweeps are often log-spaced or
    uneven); colours as :func:`colour_scale`; cells where a run diverged (:func:`diverged`)
    are crossed out; ``title`` is one line; a caption under the panels says what grey, the
    cross and the boundary mean. The boundary contour is interpolated between cell centres.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    sweep_units = sweep_units or {}
    facets = _axis_order(rows, plot.facet) if plot.facet else [None]
    wheres = [{plot.facet: f} if plot.facet else None for f in facets]
    grids = [grid(rows, plot.x, plot.y, plot.metric, w) for w in wheres]
    gone = [diverged(rows, plot.x, plot.y, w) for w in wheres]
    cmap, norm, extend = colour_scale(plot, np.concatenate([g[2].ravel() for g in grids]),
                                      np.concatenate([d.ravel() for d in gone]), units)
    binary = hasattr(norm, 'boundaries')
    if binary:      # two colours already tell stable / off the belt apart: no crosses
        gone = [np.zeros_like(d) for d in gone]
    width = max(4.3 * len(facets) + 1.6, 7.0)
    fig, axes = plt.subplots(1, len(facets), figsize=(width, 4.6),
                             squeeze=False, sharey=True, constrained_layout=True)
    mesh = None
    for ax, f, (xs, ys, Z), D in zip(axes[0], facets, grids, gone):
        nx, ny = len(xs), len(ys)
        mesh = ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5,
                             np.ma.masked_invalid(Z), norm=norm, cmap=cmap, shading='flat')
        _cross(ax, D)
        if nx * ny <= 100:
            _values(ax, Z, D, cmap, norm, 7 if nx * len(facets) <= 12 else 6)
        if plot.kind == 'boundary':
            _boundary(ax, Z, plot.threshold)
        ax.set_xticks(np.arange(nx), [_fmt(v) if isinstance(v, float) else str(v) for v in xs],
                      fontsize=8)
        ax.set_yticks(np.arange(ny), [_fmt(v) if isinstance(v, float) else str(v) for v in ys],
                      fontsize=8)
        ax.set_xlabel(_label(sweep_units, plot.x))
        if ax is axes[0][0]:
            ax.set_ylabel(_label(sweep_units, plot.y))
        if plot.facet:
            ax.set_title(f'{plot.facet} = {f}', fontsize=9)
    label = f'{plot.metric} [{units.get(plot.metric, "")}]' + (' (log scale)' if plot.log else '')
    bar = fig.colorbar(mesh, ax=axes[0].tolist(), label=label, shrink=0.9, extend=extend)
    if binary:
        bar.set_ticks([0, 1], labels=['0 (no)', '1 (yes)'])
    notes = ['grey: no result (refused point)']
    if any(d.any() for d in gone):
        notes.insert(0, 'crossed: diverged (off the belt or unstable)')
    if extend == 'max':
        notes.insert(0, f'pink: above {norm.vmax:.3g} (the colour scale spans the points that '
                        'did not diverge, clipped at an outlier)'
                     if plot.vmax is None else f'pink: above {plot.vmax:g}')
    if plot.kind == 'boundary':
        notes.insert(0, f'black line: {plot.metric} = {plot.threshold:g}, hatched: below')
    fig.suptitle(title or plot.metric, fontsize=10, fontweight='bold')
    fig.supxlabel(textwrap.fill('; '.join(notes), int(width * 17)), fontsize=7, color='0.3')
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
