"""``bag rerun <bag> --out file.rrd``: a rerun recording of an IRS run (rerun-sdk 0.41).

Entities (treadmill frame, metres; the view is 3-D with z up and everything at z = 0, so the
viewer's top-down camera shows x forward and y to the left as in docs/conventions.md):

- ``world/belt`` (static): the belt outline, 2.4384 m x 1.2192 m centred at the origin;
- ``world/arm/base`` (static): joint 1 at (base_x, base_y);
- ``world/car``: a box ``car_length`` x ``car_width`` at the car's c.g. with its heading, from
  ``ground_truth/odom`` (else ``pose``, PoseStamped); ``world/car/heading``: an arrow;
- ``world/arm``: the arm as two segments base -> elbow -> tip from ``arm/joint_states``
  (theta1, theta2, theta3 through :func:`irs_models.arm_kinematics.forward_kinematics`;
  elbow = base + l1 (cos theta1, sin theta1));
- ``series/lateral/{ground_truth,sensed,reference}`` [m], ``series/steer/{command,commanded,
  achieved}`` [rad], ``series/belt/{speed,regulator_speed}`` [m/s]: scalar time series.

Timeline ``time``: seconds from the first message, from ``header.stamp`` (sim time in lock-step
runs), else log time. The 2-D view is decimated to ``--view-rate`` Hz (default 50), the series
to ``--series-rate`` Hz (default 200; 0 = every message).

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 1 nothing to export, 2 unreadable bag / write error / usage error (one line
on stderr).
"""
from __future__ import annotations

import argparse
import math
import sys
from operator import attrgetter
from pathlib import Path
from typing import Dict, List, Optional

from irs_common.orientation import quaternion_from_yaw, yaw_from_quaternion

from .plots import BELT_LENGTH, BELT_WIDTH, _find, _stamp_s
from .reader import BagError, open_bag, reading

__all__ = ['export_rrd', 'main', 'ENTITY_PATHS', 'NothingToExport']

ENTITY_PATHS = ['world/belt', 'world/arm/base', 'world/car', 'world/car/heading', 'world/arm',
                'series/lateral/ground_truth', 'series/lateral/sensed',
                'series/lateral/reference', 'series/steer/command', 'series/steer/commanded',
                'series/steer/achieved', 'series/belt/speed', 'series/belt/regulator_speed']

# entity -> (topic suffix, field path)
SERIES = {
    'series/lateral/ground_truth': ('ground_truth/sensor_point', 'point.y'),
    'series/lateral/sensed': ('lateral_position', 'point.y'),
    'series/lateral/reference': ('lateral/reference', 'lateral_position'),
    'series/steer/command': ('steering/command', 'front_angle'),
    'series/steer/commanded': ('steering/state', 'front_commanded'),
    'series/steer/achieved': ('steering/state', 'front_achieved'),
    'series/belt/speed': ('belt/speed', 'speed'),
    'series/belt/regulator_speed': ('treadmill/state', 'belt_speed'),
}


class NothingToExport(BagError):
    """The bag has none of the topics (or no usable message) the export uses."""


def _yaw(q) -> float:
    return yaw_from_quaternion(q.x, q.y, q.z, q.w)


class _Decimator:
    def __init__(self, rate_hz: float):
        self.period = 0.0 if rate_hz <= 0 else 1.0 / rate_hz
        self.next = -math.inf

    def keep(self, t: float) -> bool:
        if t + 1e-12 < self.next:
            return False
        self.next = t + self.period
        return True


def export_rrd(bag_path, rrd_path, *, view_rate: float = 50.0, series_rate: float = 200.0,
               geometry=None, car_length: float = 0.40, car_width: float = 0.20,
               application_id: str = 'irs') -> Dict[str, int]:
    """Write ``rrd_path`` from ``bag_path`` (a path, opened strictly, or an open
    :class:`BagReader`); return the number of rows logged per entity.

    ``geometry`` is an :class:`irs_models.arm_kinematics.ArmGeometry` (default: defaults of
    docs/conventions.md, l1 = l2 = 1 m, base (0, 0.85) m).

    Raises
    ------
    BagError
        Unreadable bag, or none of the used topics is in it.
    """
    import numpy as np
    import rerun as rr

    from irs_models.arm_kinematics import ArmGeometry, forward_kinematics

    g = geometry or ArmGeometry()
    series: Dict[str, tuple] = {}
    cars: List[tuple] = []
    arms: List[tuple] = []
    with reading(bag_path) as r:
        topics = r.topics
        plan: Dict[str, List[tuple]] = {}
        for ent, (suffix, path) in SERIES.items():
            t = _find(topics, suffix)
            if t is not None:
                plan.setdefault(t, []).append(('series', ent, path, _Decimator(series_rate)))
        car_topic = _find(topics, 'ground_truth/odom') or _find(topics, 'pose')
        if car_topic is not None:
            plan.setdefault(car_topic, []).append(('car', None, None, _Decimator(view_rate)))
        arm_topic = _find(topics, 'arm/joint_states')
        if arm_topic is not None:
            plan.setdefault(arm_topic, []).append(('arm', None, None, _Decimator(view_rate)))
        if not plan:
            raise NothingToExport(
                f'{r.path}: none of the topics used by the rerun export is in the bag '
                '(arm/joint_states, ground_truth/odom, pose, '
                + ', '.join(s for s, _ in SERIES.values()) + ')')
        for m, msg in r.decoded(list(plan)):
            ts = _stamp_s(msg, m.log_time_ns)
            for kind, ent, path, dec in plan[m.topic]:
                if not dec.keep(ts):
                    continue
                try:
                    if kind == 'series':
                        xs, ys = series.setdefault(ent, ([], []))
                        ys.append(float(attrgetter(path)(msg)))
                        xs.append(ts)
                    elif kind == 'car':
                        pose = msg.pose.pose if hasattr(msg.pose, 'pose') else msg.pose
                        cars.append((ts, pose.position.x, pose.position.y,
                                     _yaw(pose.orientation)))
                    else:
                        th = list(msg.position)
                        if len(th) < 3:
                            continue
                        fk = forward_kinematics(th[0], th[1], th[2], g)
                        arms.append((ts, th[0], fk.x_tip, fk.y_tip))
                except (AttributeError, TypeError, ValueError):
                    continue
    starts = [xs[0] for xs, _ in series.values() if xs] + [c[0] for c in cars[:1]] + \
        [a[0] for a in arms[:1]]
    if not starts:
        raise NothingToExport(f'{getattr(bag_path, "path", bag_path)}: no usable messages for '
                              'the rerun export')
    t0 = min(starts)

    rec = rr.RecordingStream(application_id)
    try:
        Path(rrd_path).parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(rrd_path))
    except (OSError, RuntimeError) as exc:
        raise BagError(f'cannot write {rrd_path} ({exc})') from None
    rows: Dict[str, int] = {}
    rec.log('world', rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    hl, hw = BELT_LENGTH / 2, BELT_WIDTH / 2
    rec.log('world/belt', rr.LineStrips3D(
        [[[-hl, -hw, 0], [hl, -hw, 0], [hl, hw, 0], [-hl, hw, 0], [-hl, -hw, 0]]],
        colors=[[60, 60, 60]], labels=['belt']), static=True)
    rec.log('world/arm/base', rr.Points3D([[g.base_x, g.base_y, 0.0]], radii=0.02,
                                          labels=['arm base']), static=True)
    rows['world/belt'] = rows['world/arm/base'] = 1
    for ts, x, y, psi in cars:
        rec.set_time('time', duration=ts - t0)
        rec.log('world/car', rr.Boxes3D(centers=[[x, y, 0.0]],
                                        half_sizes=[[car_length / 2, car_width / 2, 0.01]],
                                        quaternions=[rr.Quaternion(xyzw=quaternion_from_yaw(psi))],
                                        colors=[[30, 120, 220]]))
        rec.log('world/car/heading', rr.Arrows3D(
            origins=[[x, y, 0.0]],
            vectors=[[car_length * math.cos(psi), car_length * math.sin(psi), 0.0]]))
    if cars:
        rows['world/car'] = rows['world/car/heading'] = len(cars)
    for ts, th1, xt, yt in arms:
        rec.set_time('time', duration=ts - t0)
        ex, ey = g.base_x + g.l1 * math.cos(th1), g.base_y + g.l1 * math.sin(th1)
        rec.log('world/arm', rr.LineStrips3D([[[g.base_x, g.base_y, 0.0], [ex, ey, 0.0],
                                              [xt, yt, 0.0]]],
                                             colors=[[220, 120, 30]], radii=0.01))
    if arms:
        rows['world/arm'] = len(arms)
    for ent, (xs, ys) in series.items():
        rec.send_columns(ent, indexes=[rr.TimeColumn('time', duration=np.asarray(xs) - t0)],
                         columns=rr.Scalars.columns(scalars=np.asarray(ys, dtype=float)))
        rows[ent] = len(xs)
    rec.flush()
    rec.disconnect()
    if not Path(rrd_path).is_file() or Path(rrd_path).stat().st_size == 0:
        raise BagError(f'rerun did not write {rrd_path}')
    return rows


def rrd_entity_paths(rrd_path) -> set:
    """Entity paths found in an ``.rrd`` file (read back with ``rerun.chunk.RrdReader``)."""
    from rerun.chunk import RrdReader
    return {c.entity_path.lstrip('/') for c in RrdReader(str(rrd_path)).stream().to_chunks()}


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag rerun``; returns the exit code."""
    p = argparse.ArgumentParser(
        prog='bag rerun', description='Export an IRS bag to a rerun .rrd recording.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--out', required=True, help='output .rrd file')
    p.add_argument('--view-rate', type=float, default=50.0, help='2-D view rate [Hz]')
    p.add_argument('--series-rate', type=float, default=200.0,
                   help='time series rate [Hz] (0 = every message)')
    p.add_argument('--l1', type=float, default=1.0, help='arm link 1 length [m]')
    p.add_argument('--l2', type=float, default=1.0, help='arm link 2 length [m]')
    p.add_argument('--base-x', type=float, default=0.0, help='arm base x [m]')
    p.add_argument('--base-y', type=float, default=0.85, help='arm base y [m]')
    p.add_argument('--attach-offset', type=float, default=0.0, help='arm tip offset [m]')
    p.add_argument('--car-length', type=float, default=0.40, help='car box length [m]')
    p.add_argument('--car-width', type=float, default=0.20, help='car box width [m]')
    args = p.parse_args(argv)
    try:
        from irs_models.arm_kinematics import ArmGeometry
        geom = ArmGeometry(l1=args.l1, l2=args.l2, base_x=args.base_x, base_y=args.base_y,
                           attach_offset=args.attach_offset)
    except ValueError as exc:
        print(f'bag rerun: error: {exc}', file=sys.stderr)
        return 2
    try:
        with open_bag(args.bag, 'bag rerun') as r:
            rows = export_rrd(r, args.out, view_rate=args.view_rate,
                              series_rate=args.series_rate, geometry=geom,
                              car_length=args.car_length, car_width=args.car_width)
    except NothingToExport as exc:
        print(f'bag rerun: error: {exc}', file=sys.stderr)
        return 1
    except (BagError, OSError) as exc:
        print(f'bag rerun: error: {exc}', file=sys.stderr)
        return 2
    print(f'{args.out}: ' + ', '.join(f'{k} ({v})' for k, v in sorted(rows.items())))
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
