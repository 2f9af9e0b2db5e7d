"""``bag plots <bag> --out DIR``: PNG plots of an IRS run from its bag (matplotlib, Agg).

Every figure is titled ``<run> | <controller>`` (:mod:`irs_bag.run_info`). Ground truth is a
dark solid line drawn over the sensed one (thin, light, translucent), so both stay visible where
they agree; commands are wide pale lines under what the actuator did. Each plot is written only
if one of its topics is in the bag (topics matched with or without a namespace):

- ``lateral.png``: y_s ground truth (``ground_truth/sensor_point``), sensed
  (``lateral_position``), reference (``lateral/reference``), reference model (``reference_model``)
  [m]; below, sensed - ground truth [m] with its RMS;
- ``steering.png``: ``steering/command`` front_angle, the servo's input and achieved angle
  (``steering/state``) [deg];
- ``belt.png``: belt speed from the encoder (``belt/speed``; raw, and a 0.1 s centred moving
  average that hides the one-count steps), the driver's speed command (``driver/command``)
  [m/s]; the car's x and the regulator's set point (``treadmill/state``) [m]; the drive voltage
  (``treadmill/drive``, else ``treadmill/state``) [V];
- ``car_position.png``: top view of the c.g. (``ground_truth/odom``, ``pose``) zoomed to the
  path with equal axes; x(t) and y(t) on their own axes [m].

Time axis: seconds from the first message, from ``header.stamp`` (sim time in lock-step runs).
Lines of more than 4000 samples are drawn from a min/max envelope of 2000 bins, which keeps
every extreme a pixel column can show. Works on unfinished or damaged bags too (their readable
part, one warning line on stderr). Exit codes: 0 ok, 1 no plottable topic, 2 unreadable bag /
write error / usage error (one line on stderr).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Dict, List, Optional

import numpy as np

from irs_common.cli import EXIT_FAILED, InputError, error, run_cli
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .columns import Columns, columns_of, read_columns
from .reader import BagError, open_bag, reading
from .run_info import RunInfo, run_info

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ['BELT_LENGTH', 'BELT_WIDTH', 'NoPlottableTopics', 'PLOT_LABELS', 'PLOT_SPEC',
           'STYLES', 'main', 'make_figures', 'make_plots', 'min_max_envelope', 'moving_average',
           'plot_series']

BELT_LENGTH = 2 * BELT_HALF_LENGTH    # [m] 8 ft
BELT_WIDTH = 2 * BELT_HALF_WIDTH      # [m] 4 ft

#: Bag columns the plots use (suffix -> {column: field path or alternatives}).
PLOT_SPEC = {
    'ground_truth/sensor_point': {'y': 'point.y'},
    'lateral_position': {'y': 'point.y'},
    'lateral/reference': {'y': 'lateral_position'},
    'reference_model': {'y': ('data', 'point.y', 'lateral_position')},
    'steering/command': {'front': 'front_angle'},
    'steering/state': {'commanded': 'front_commanded', 'achieved': 'front_achieved'},
    'belt/speed': {'speed': 'speed'},
    'treadmill/state': {'belt_speed': 'belt_speed', 'voltage': 'drive_voltage',
                        'x': 'position', 'x_set': 'position_setpoint'},
    'treadmill/drive': {'voltage': 'voltage'},
    'driver/command': {'speed': 'speed'},
    'ground_truth/odom': {'x': 'pose.pose.position.x', 'y': 'pose.pose.position.y'},
    'pose': {'x': 'pose.position.x', 'y': 'pose.position.y'},
}

#: Series label (offline twin, :func:`plot_series`) -> (suffix, column) of :data:`PLOT_SPEC`.
PLOT_LABELS = {
    'y_s ground truth': ('ground_truth/sensor_point', 'y'),
    'y_s sensed': ('lateral_position', 'y'),
    'reference': ('lateral/reference', 'y'),
    'reference model': ('reference_model', 'y'),
    'command front': ('steering/command', 'front'),
    'servo commanded front': ('steering/state', 'commanded'),
    'servo achieved front': ('steering/state', 'achieved'),
    'belt speed (encoder)': ('belt/speed', 'speed'),
    'belt speed (regulator)': ('treadmill/state', 'belt_speed'),
    'drive voltage': ('treadmill/drive', 'voltage'),
    'x ground truth': ('ground_truth/odom', 'x'),
    'y ground truth': ('ground_truth/odom', 'y'),
}

#: Line styles by role (matplotlib keyword arguments).
STYLES = {
    'truth': dict(color='#1f497d', lw=1.6, zorder=3),
    'sensed': dict(color='#f0963c', lw=0.7, alpha=0.75, zorder=2),
    'reference': dict(color='0.15', lw=1.2, ls='--', zorder=4),
    'model': dict(color='tab:green', lw=1.2, ls=':', zorder=4),
    'command': dict(color='#78aae6', lw=3.0, alpha=0.6, zorder=2),
    'input': dict(color='#1f497d', lw=0.9, ls='--', zorder=3),
    'achieved': dict(color='#c83228', lw=1.3, zorder=4),
    'raw': dict(color='0.6', lw=0.6, zorder=1),
    'filtered': dict(color='#1f497d', lw=1.6, zorder=3),
    'setpoint': dict(color='0.15', lw=1.2, ls='--', zorder=4),
    'voltage': dict(color='#c83228', lw=1.0, zorder=3),
}

#: The plots, in the order they are made (each a method of :class:`_Figures`).
PLOTS = ('lateral', 'steering', 'belt', 'car_position')
ENVELOPE_BINS = 2000       # bins of the min/max envelope (a figure is about 1000 px wide)
BELT_AVERAGE = 0.1         # [s] window of the belt speed's moving average


class NoPlottableTopics(BagError):
    """The bag has none of the topics the plots use."""


def min_max_envelope(t: np.ndarray, y: np.ndarray, bins: int = ENVELOPE_BINS):
    """``(t, y)`` reduced to the minimum and maximum of each of ``bins`` equal index bins, in
    time order (unchanged if it has at most ``2 bins`` samples or any NaN).
    """
    n = len(y)
    if n <= 2 * bins or not np.isfinite(y).all():
        return t, y
    k = -(-n // bins)
    pad = k * bins - n
    yy = np.concatenate([y, np.full(pad, y[-1])]).reshape(bins, k)
    base = np.arange(bins) * k
    idx = np.unique(np.minimum(np.concatenate([base + yy.argmin(axis=1),
                                               base + yy.argmax(axis=1)]), n - 1))
    return t[idx], y[idx]


def moving_average(t: np.ndarray, y: np.ndarray, window: float) -> np.ndarray:
    """Centred moving average of ``y`` over ``[t - window/2, t + window/2]`` (any sampling)."""
    c = np.concatenate([[0.0], np.cumsum(y)])
    lo = np.searchsorted(t, t - window / 2, side='left')
    hi = np.searchsorted(t, t + window / 2, side='right')
    return (c[hi] - c[lo]) / np.maximum(hi - lo, 1)


class _Figures:
    """The figures of one run: its columns, time origin and title."""

    def __init__(self, columns: Columns, info: RunInfo):
        self.c = columns
        self.info = info
        self.t0 = min(float(v['t'][0]) for v in columns.values() if len(v['t']))

    def get(self, suffix, *names):
        """``(t - t0, *values)`` or None (see :func:`~irs_bag.columns.columns_of`)."""
        got = columns_of(self.c, suffix, *names)
        return None if got is None else (got[0] - self.t0, *got[1:])

    def line(self, ax, t, y, role, label, scale=1.0):
        tt, yy = min_max_envelope(t, y * scale)
        ax.plot(tt, yy, label=label, **STYLES[role])

    def figure(self, rows, height, heights=None):
        from matplotlib.figure import Figure
        fig = Figure(figsize=(10, height), layout='constrained')
        axes = fig.subplots(rows, 1, sharex=True, squeeze=False,
                            gridspec_kw={'height_ratios': heights} if heights else None)[:, 0]
        fig.suptitle(self.info.title, fontsize=11, fontweight='bold')
        for ax in axes:
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel('time [s]')
        return fig, axes

    def lateral(self):
        truth, sensed = self.get('ground_truth/sensor_point', 'y'), self.get('lateral_position',
                                                                              'y')
        ref, model = self.get('lateral/reference', 'y'), self.get('reference_model', 'y')
        if not (truth or sensed or ref or model):
            return None
        both = truth is not None and sensed is not None
        fig, axes = self.figure(2 if both else 1, 6.0 if both else 4.5,
                                [3, 1] if both else None)
        ax = axes[0]
        for got, role, label in ((sensed, 'sensed', 'y_s sensed (arm)'),
                                 (truth, 'truth', 'y_s ground truth'),
                                 (ref, 'reference', 'reference'),
                                 (model, 'model', 'reference model')):
            if got is not None:
                self.line(ax, *got, role, label)
        ax.set(ylabel='lateral displacement y_s [m]', title='Lateral displacement of the '
               'sensor point')
        ax.legend(loc='best', fontsize=9)
        if both:
            err = sensed[1] - np.interp(sensed[0], truth[0], truth[1])
            rms = float(np.sqrt(np.nanmean(err ** 2)))
            self.line(axes[1], sensed[0], err, 'sensed',
                      f'sensed - ground truth (RMS {rms:.2g} m)')
            axes[1].axhline(0.0, color='0.3', lw=0.8)
            axes[1].set_ylabel('sensing error [m]')
            axes[1].legend(loc='upper right', fontsize=9)
        return fig

    def steering(self):
        cmd = self.get('steering/command', 'front')
        inp = self.get('steering/state', 'commanded')
        ach = self.get('steering/state', 'achieved')
        if not (cmd or inp or ach):
            return None
        fig, (ax,) = self.figure(1, 4.5)
        for got, role, label in ((cmd, 'command', 'command (controller)'),
                                 (inp, 'input', 'servo input'),
                                 (ach, 'achieved', 'servo achieved')):
            if got is not None:
                self.line(ax, *got, role, label, scale=180.0 / np.pi)
        drawn = [name for got, name in ((cmd, 'command'), (inp, 'servo input'),
                                        (ach, 'achieved angle')) if got is not None]
        ax.set(ylabel='front steer angle [deg]', title='Front steer: ' + ', '.join(drawn))
        ax.legend(loc='best', fontsize=9)
        return fig

    def belt(self):
        enc = self.get('belt/speed', 'speed')
        reg = self.get('treadmill/state', 'belt_speed')
        driver = self.get('driver/command', 'speed')
        x = self.get('ground_truth/odom', 'x')
        x_set = self.get('treadmill/state', 'x_set')
        volts = self.get('treadmill/drive', 'voltage') or self.get('treadmill/state', 'voltage')
        speed = enc or reg
        panels = [p for p, ok in (('speed', speed or driver), ('x', x_set),
                                  ('volts', volts)) if ok]
        if not panels:
            return None
        fig, axes = self.figure(len(panels), 2.6 * len(panels) + 0.8,
                                [2] + [1] * (len(panels) - 1))
        ax = dict(zip(panels, axes))
        if 'speed' in ax:
            if speed is not None:
                src = 'encoder' if enc else 'regulator'
                self.line(ax['speed'], *speed, 'raw', f'belt speed, {src} (raw)')
                avg = moving_average(speed[0], speed[1], BELT_AVERAGE)
                self.line(ax['speed'], speed[0], avg, 'filtered',
                          f'belt speed, {BELT_AVERAGE:g} s moving average')
            if driver is not None:
                self.line(ax['speed'], *driver, 'reference', "driver's command (car over belt)")
            ax['speed'].set(ylabel='speed [m/s]', title='Treadmill: belt speed' + (
                " and the driver's speed command" if driver is not None else ''))
            ax['speed'].legend(loc='best', fontsize=9)
        if 'x' in ax:
            if x is not None:
                self.line(ax['x'], *x, 'truth', 'car x (ground truth)')
            self.line(ax['x'], *x_set, 'setpoint', 'set point')
            ax['x'].set_ylabel('car x [m]')
            ax['x'].legend(loc='best', fontsize=9)
        if 'volts' in ax:
            self.line(ax['volts'], *volts, 'voltage', 'drive voltage')
            ax['volts'].set_ylabel('drive [V]')
        return fig

    def car_position(self):
        truth = self.get('ground_truth/odom', 'x', 'y')
        sensed = self.get('pose', 'x', 'y')
        if not (truth or sensed):
            return None
        from matplotlib.figure import Figure
        fig = Figure(figsize=(11, 6.0), layout='constrained')
        fig.suptitle(self.info.title, fontsize=11, fontweight='bold')
        gs = fig.add_gridspec(2, 2, width_ratios=[1, 1.5])
        top = fig.add_subplot(gs[:, 0])
        ax_x = fig.add_subplot(gs[0, 1])
        ax_y = fig.add_subplot(gs[1, 1], sharex=ax_x)
        pts = []
        for got, role, label in ((sensed, 'sensed', 'sensed (pose)'),
                                 (truth, 'truth', 'ground truth (odom)')):
            if got is None:
                continue
            t, x, y = got
            pts.append((x, y))
            style = {k: v for k, v in STYLES[role].items()}
            top.plot(x, y, label=label, **style)
            self.line(ax_x, t, x, role, label)
            self.line(ax_y, t, y, role, label)
        x_set = self.get('treadmill/state', 'x_set')
        if x_set is not None:
            self.line(ax_x, *x_set, 'setpoint', 'set point (regulator)')
        x0, y0 = (truth or sensed)[1][0], (truth or sensed)[2][0]
        top.plot([x0], [y0], 'o', color='k', ms=5, label='start', zorder=5)
        hl, hw = BELT_LENGTH / 2, BELT_WIDTH / 2
        top.plot([-hl, hl, hl, -hl, -hl], [-hw, -hw, hw, hw, -hw], color='k', lw=1.5)
        _zoom(top, np.concatenate([p[0] for p in pts]), np.concatenate([p[1] for p in pts]))
        top.set(xlabel='x [m] (treadmill frame)', ylabel='y [m]',
                title=f'Top view, zoomed to the path\n(belt {BELT_LENGTH:.2f} m x '
                      f'{BELT_WIDTH:.2f} m)')
        top.grid(True, alpha=0.3)
        top.legend(loc='best', fontsize=8)
        ax_x.set(ylabel='x [m]', title='Position against time')
        ax_y.set(ylabel='y [m]', xlabel='time [s]')
        for ax in (ax_x, ax_y):
            ax.grid(True, alpha=0.3)
        ax_x.legend(loc='best', fontsize=8)
        return fig


def _zoom(ax, x: np.ndarray, y: np.ndarray, margin: float = 0.15, least: float = 0.01):
    """Equal axes around the points: a square of their larger span (at least ``least`` m)
    plus ``margin`` of it on each side.
    """
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    cx, cy = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
    half = max(np.ptp(x), np.ptp(y), least) * (0.5 + margin)
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect('equal', adjustable='box')


def load_columns(bag_path) -> Columns:
    """The columns of :data:`PLOT_SPEC` of ``bag_path`` (path or open reader)."""
    return read_columns(bag_path, PLOT_SPEC)


def make_figures(bag_path, *, columns: Optional[Columns] = None,
                 info: Optional[RunInfo] = None) -> Dict[str, 'Figure']:
    """The figures of ``bag_path`` (path or open reader) by plot name (``'lateral'``, ...),
    those whose topics are in the bag. ``columns``: the bag's columns of :data:`PLOT_SPEC`
    when already read.

    Raises
    ------
    BagError
        Unreadable bag (one-line message).
    NoPlottableTopics
        None of the plotted topics is in the bag.
    """
    with reading(bag_path) as r:
        info = info or run_info(r)
        if columns is None:
            columns = read_columns(r, PLOT_SPEC)
        path = r.path
    return _figures(columns, info, path)


def _figures(columns: Columns, info: RunInfo, where) -> Dict[str, 'Figure']:
    columns = {s: c for s, c in columns.items() if s in PLOT_SPEC and len(c['t'])}
    if not columns:
        raise NoPlottableTopics(f'{where}: none of the plotted topics is in the bag (looked for '
                                f'{", ".join(sorted(PLOT_SPEC))})')
    figs = _Figures(columns, info)
    made = {name: getattr(figs, name)() for name in PLOTS}
    return {name: fig for name, fig in made.items() if fig is not None}


def plot_series(data, out_dir, info: Optional[RunInfo] = None) -> List[Path]:
    """The plots of :func:`make_plots` from ``{label: (t [s], values)}`` with the labels of
    :data:`PLOT_LABELS` (the offline twin's runs); ``info`` default: the run named after
    ``out_dir``'s parent (``<run>/plots``).
    """
    columns: Columns = {}
    for label, (t, v) in data.items():
        suffix, col = PLOT_LABELS[label]
        got = columns.setdefault(suffix, {'t': np.asarray(t, dtype=float)})
        v = np.asarray(v, dtype=float)
        n = len(got['t'])
        got[col] = v[:n] if len(v) >= n else np.r_[v, np.full(n - len(v), np.nan)]
    info = info or RunInfo(Path(out_dir).resolve().parent.name)
    return _write(_figures(columns, info, out_dir), out_dir)


def make_plots(bag_path, out_dir, *, columns: Optional[Columns] = None,
               info: Optional[RunInfo] = None) -> List[Path]:
    """Write the PNG plots of ``bag_path`` (:func:`make_figures`) into ``out_dir``; return
    their paths. Raises as :func:`make_figures`.
    """
    return _write(make_figures(bag_path, columns=columns, info=info), out_dir)


def _write(figures: Dict[str, 'Figure'], out_dir) -> List[Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: List[Path] = []
    for name, fig in figures.items():
        dest = out / f'{name}.png'
        fig.savefig(dest, dpi=100)
        written.append(dest)
    return written


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag plots``; returns the exit code (docs/cli.md)."""
    return run_cli('bag plots', _main, argv)


def _main(argv: Optional[List[str]]) -> int:
    p = argparse.ArgumentParser(
        prog='bag plots', description='PNG plots of an IRS run from its bag.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--out', required=True, help='output directory for the PNG files')
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'bag plots') as r:
            paths = make_plots(r, args.out)
    except NoPlottableTopics as exc:
        error('bag plots', exc)
        return EXIT_FAILED
    except BagError as exc:
        raise InputError(str(exc)) from None
    for path in paths:
        print(path)
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
