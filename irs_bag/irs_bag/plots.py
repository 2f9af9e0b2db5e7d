"""``bag plots <bag> --out DIR``: PNG plots of an IRS run from its bag (matplotlib, Agg).

Plots (each only if at least one of its topics is in the bag; topics are matched with or
without a namespace, i.e. any topic whose name ends with the given suffix):

- ``lateral.png``: lateral displacement of the sensor point vs. the reference:
  ``ground_truth/sensor_point`` point.y, ``lateral_position`` point.y,
  ``lateral/reference`` lateral_position, ``reference_model`` (std_msgs/Float64 data or any
  message with ``point.y`` / ``lateral_position``) [m];
- ``steering.png``: ``steering/command`` front_angle vs. ``steering/state`` front_commanded /
  front_achieved [deg in the plot, rad in the bag];
- ``belt.png``: ``belt/speed`` speed, ``treadmill/state`` belt_speed [m/s] and drive_voltage
  [V] (second axis);
- ``car_position.png``: the car on the belt (top view, belt outline): ``ground_truth/odom``
  pose x, y and ``pose`` (PoseStamped) x, y; plus x(t) and y(t).

Time axis: seconds from the first message of the bag, from the message's ``header.stamp`` when
it has one (sim time for lock-step runs), else the log time.

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 1 no plottable topic, 2 unreadable bag / write error / usage error (one
line on stderr).
"""
from __future__ import annotations

import argparse
import math
import sys
from operator import attrgetter
from pathlib import Path
from typing import Callable, Dict, List, Optional, Tuple

from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .reader import BagError, open_bag, reading

__all__ = ['make_plots', 'plot_series', 'load_series', 'main', 'NoPlottableTopics', 'BELT_LENGTH',
           'BELT_WIDTH']

BELT_LENGTH = 2 * BELT_HALF_LENGTH    # [m] 8 ft
BELT_WIDTH = 2 * BELT_HALF_WIDTH      # [m] 4 ft


class NoPlottableTopics(BagError):
    """The bag has none of the topics the plots use."""


def _stamp_s(msg, log_time_ns: int) -> float:
    h = getattr(msg, 'header', None)
    st = getattr(h, 'stamp', None)
    if st is not None:
        return st.sec + st.nanosec * 1e-9
    return log_time_ns * 1e-9


def _find(topics, suffix: str) -> Optional[str]:
    suffix = suffix.strip('/')
    for t in sorted(topics, key=len):
        if t.strip('/') == suffix or t.endswith('/' + suffix):
            return t
    return None


# plot name -> list of (topic suffix, label, field getter, axis)
def _reference_model_value(msg):
    for path in ('data', 'point.y', 'lateral_position'):
        try:
            return float(attrgetter(path)(msg))
        except AttributeError:
            continue
    raise AttributeError('no known field')


SERIES = {
    'lateral': [
        ('ground_truth/sensor_point', 'y_s ground truth', attrgetter('point.y')),
        ('lateral_position', 'y_s sensed', attrgetter('point.y')),
        ('lateral/reference', 'reference', attrgetter('lateral_position')),
        ('reference_model', 'reference model', _reference_model_value),
    ],
    'steering': [
        ('steering/command', 'command front', attrgetter('front_angle')),
        ('steering/state', 'servo commanded front', attrgetter('front_commanded')),
        ('steering/state', 'servo achieved front', attrgetter('front_achieved')),
    ],
    'belt': [
        ('belt/speed', 'belt speed (encoder)', attrgetter('speed')),
        ('treadmill/state', 'belt speed (regulator)', attrgetter('belt_speed')),
        ('treadmill/state', 'drive voltage', attrgetter('drive_voltage')),
    ],
    'car_position': [
        ('ground_truth/odom', 'x ground truth', attrgetter('pose.pose.position.x')),
        ('ground_truth/odom', 'y ground truth', attrgetter('pose.pose.position.y')),
        ('pose', 'x sensed', attrgetter('pose.position.x')),
        ('pose', 'y sensed', attrgetter('pose.position.y')),
    ],
}


def load_series(bag_path, wanted=None) -> Dict[str, Tuple[List[float], List[float]]]:
    """label -> (t [s], values) for every series of :data:`SERIES` whose topic is in the bag.

    ``bag_path`` is a path (opened strictly) or an open :class:`BagReader`.

    Raises
    ------
    BagError
        Unreadable bag.
    """
    groups = SERIES if wanted is None else {k: SERIES[k] for k in wanted}
    with reading(bag_path) as r:
        topics = r.topics
        plan: Dict[str, List[Tuple[str, Callable]]] = {}
        for series in groups.values():
            for suffix, label, get in series:
                t = _find(topics, suffix)
                if t is not None:
                    plan.setdefault(t, []).append((label, get))
        out: Dict[str, Tuple[List[float], List[float]]] = {}
        if not plan:
            return out
        for m, msg in r.decoded(list(plan)):
            ts = _stamp_s(msg, m.log_time_ns)
            for label, get in plan[m.topic]:
                try:
                    v = float(get(msg))
                except (AttributeError, TypeError, ValueError):
                    continue
                xs, ys = out.setdefault(label, ([], []))
                xs.append(ts)
                ys.append(v)
    return out


def make_plots(bag_path, out_dir) -> List[Path]:
    """Write the PNG plots of ``bag_path`` (path or open reader) into ``out_dir``; return
    their paths.

    Raises
    ------
    BagError
        Unreadable bag (one-line message).
    NoPlottableTopics
        None of the plotted topics is in the bag.
    """
    data = load_series(bag_path)
    if not data:
        raise NoPlottableTopics(
            f'{getattr(bag_path, "path", bag_path)}: none of the plotted topics is in the bag '
            f'(looked for '
            + ', '.join(sorted({s for v in SERIES.values() for s, _, _ in v}))
            + ')'
        )
    return plot_series(data, out_dir)


def plot_series(data, out_dir) -> List[Path]:
    """The plots of :func:`make_plots` from ``{label: (t [s], values)}`` (the labels of
    :data:`SERIES`, as :func:`load_series` returns them; the offline twin's runs give the same).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    t0 = min(xs[0] for xs, _ in data.values() if len(xs))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: List[Path] = []

    def rel(label):
        xs, ys = data[label]
        return [x - t0 for x in xs], ys

    def save(fig, name):
        fig.tight_layout()
        path = out / name
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)

    labels = [lab for _, lab, _ in SERIES['lateral'] if lab in data]
    if labels:
        fig, ax = plt.subplots(figsize=(10, 4.5))
        for lab in labels:
            ax.plot(*rel(lab), label=lab, lw=1.0,
                    ls='--' if 'reference' in lab else '-')
        ax.set(xlabel='time [s]', ylabel='lateral displacement y_s [m]',
               title='Lateral displacement vs. reference')
        ax.grid(True, alpha=0.3)
        ax.legend(loc='best')
        save(fig, 'lateral.png')

    labels = [lab for _, lab, _ in SERIES['steering'] if lab in data]
    if labels:
        fig, ax = plt.subplots(figsize=(10, 4.5))
        for lab in labels:
            xs, ys = rel(lab)
            ax.plot(xs, [math.degrees(y) for y in ys], label=lab, lw=1.0)
        ax.set(xlabel='time [s]', ylabel='front steer angle [deg]',
               title='Steering: command vs. achieved')
        ax.grid(True, alpha=0.3)
        ax.legend(loc='best')
        save(fig, 'steering.png')

    speeds = [lab for lab in ('belt speed (encoder)', 'belt speed (regulator)') if lab in data]
    if speeds or 'drive voltage' in data:
        fig, ax = plt.subplots(figsize=(10, 4.5))
        for lab in speeds:
            ax.plot(*rel(lab), label=lab, lw=1.0)
        ax.set(xlabel='time [s]', ylabel='belt speed [m/s]', title='Belt speed')
        ax.grid(True, alpha=0.3)
        handles, names = ax.get_legend_handles_labels()
        if 'drive voltage' in data:
            ax2 = ax.twinx()
            ln, = ax2.plot(*rel('drive voltage'), color='tab:red', lw=0.8, label='drive voltage')
            ax2.set_ylabel('drive voltage [V]')
            handles.append(ln)
            names.append('drive voltage')
        ax.legend(handles, names, loc='best')
        save(fig, 'belt.png')

    pairs = [(f'x {k}', f'y {k}') for k in ('ground truth', 'sensed')
             if f'x {k}' in data and f'y {k}' in data]
    if pairs:
        fig, (top, ax_t) = plt.subplots(2, 1, figsize=(10, 8),
                                        gridspec_kw={'height_ratios': [1.1, 1]})
        hl, hw = BELT_LENGTH / 2, BELT_WIDTH / 2
        top.plot([-hl, hl, hl, -hl, -hl], [-hw, -hw, hw, hw, -hw], color='k', lw=1.5,
                 label='belt')
        for xl, yl in pairs:
            top.plot(data[xl][1], data[yl][1], lw=1.0, label=xl[2:])
            ax_t.plot(*rel(xl), lw=1.0, label=xl)
            ax_t.plot(*rel(yl), lw=1.0, label=yl)
        top.set(xlabel='x [m] (treadmill frame)', ylabel='y [m]',
                title='Car c.g. on the belt (top view)')
        top.set_aspect('equal')
        top.grid(True, alpha=0.3)
        top.legend(loc='upper right')
        ax_t.set(xlabel='time [s]', ylabel='position [m]')
        ax_t.grid(True, alpha=0.3)
        ax_t.legend(loc='best')
        save(fig, 'car_position.png')
    return written


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag plots``; returns the exit code."""
    p = argparse.ArgumentParser(
        prog='bag plots', description='PNG plots of an IRS run from its bag.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--out', required=True, help='output directory for the PNG files')
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'bag plots') as r:
            paths = make_plots(r, args.out)
    except NoPlottableTopics as exc:
        print(f'bag plots: error: {exc}', file=sys.stderr)
        return 1
    except (BagError, OSError) as exc:
        print(f'bag plots: error: {exc}', file=sys.stderr)
        return 2
    for path in paths:
        print(path)
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
