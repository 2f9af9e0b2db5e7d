"""The rerun entities of an IRS run, built from bag columns (rerun-sdk 0.41).

What ``run.rrd`` (:mod:`irs_bag.rerun_export`) holds, apart from reading the bag: the columns
of :data:`SPEC` are sent with :func:`send` (rerun's columnar ``send_columns``, one call per
entity), to any recording stream (a file, a viewer). Entities (treadmill frame,
metres; the view is 3-D with z up and everything at z = 0, so the top-down camera shows x forward
and y to the left as in docs/conventions.md):

- ``world/belt``, ``world/arm/base`` (static): the belt outline, joint 1 of the arm;
- ``world/car``: a box ``car.length`` x ``car.width`` at the c.g. with the pose's orientation,
  from ``ground_truth/odom`` (else ``pose``); ``world/car/heading``: an arrow along the heading
  psi = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2));
- ``world/arm``: base -> elbow -> tip, elbow = base + l1 (cos theta1, sin theta1), tip by
  :func:`irs_models.arm_kinematics.forward_kinematics` of ``arm/joint_states``;
- ``series/...`` (:data:`SERIES`): scalar time series [m, rad, m/s].

Timeline ``time``: seconds from ``t0`` (the first message), stamps from ``header.stamp``.
"""
from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .columns import Columns
from .run_info import RunInfo

__all__ = ['ENTITY_PATHS', 'SERIES', 'SPEC', 'blueprint', 'decimate', 'log_static', 'send']

_POSE = {'x': 'position.x', 'y': 'position.y', 'qx': 'orientation.x', 'qy': 'orientation.y',
         'qz': 'orientation.z', 'qw': 'orientation.w'}

#: Bag columns the entities are made of (suffix -> {column: field path}).
SPEC = {
    'ground_truth/odom': {k: f'pose.pose.{v}' for k, v in _POSE.items()},
    'pose': {k: f'pose.{v}' for k, v in _POSE.items()},
    'arm/joint_states': {'th1': 'position[0]', 'th2': 'position[1]', 'th3': 'position[2]'},
    'ground_truth/sensor_point': {'y': 'point.y'},
    'lateral_position': {'y': 'point.y'},
    'lateral/reference': {'y': 'lateral_position'},
    'steering/command': {'front': 'front_angle'},
    'steering/state': {'commanded': 'front_commanded', 'achieved': 'front_achieved'},
    'belt/speed': {'speed': 'speed'},
    'treadmill/state': {'belt_speed': 'belt_speed'},
}

#: Scalar entity -> (suffix, column, line colour, line width [px]).
SERIES = {
    'series/lateral/ground_truth': ('ground_truth/sensor_point', 'y', (31, 73, 125), 2.0),
    'series/lateral/sensed': ('lateral_position', 'y', (240, 150, 60), 1.0),
    'series/lateral/reference': ('lateral/reference', 'y', (40, 40, 40), 1.5),
    'series/steer/command': ('steering/command', 'front', (120, 170, 230), 2.5),
    'series/steer/commanded': ('steering/state', 'commanded', (31, 73, 125), 1.0),
    'series/steer/achieved': ('steering/state', 'achieved', (200, 50, 40), 1.5),
    'series/belt/speed': ('belt/speed', 'speed', (31, 73, 125), 1.0),
    'series/belt/regulator_speed': ('treadmill/state', 'belt_speed', (240, 150, 60), 1.0),
}

ENTITY_PATHS = ['world/belt', 'world/arm/base', 'world/car', 'world/car/heading', 'world/arm',
                *SERIES]

_CAR_COLOUR = (30, 120, 220)
_ARM_COLOUR = (220, 120, 30)


def decimate(t: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices keeping the first sample of every ``1/rate_hz`` s bin (all for rate <= 0)."""
    if rate_hz <= 0 or len(t) == 0:
        return np.arange(len(t))
    bins = np.floor((t - t[0]) * rate_hz + 1e-9)
    return np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])


def blueprint():
    """The default layout: the 3-D scene left, lateral / steering / belt series right."""
    import rerun.blueprint as rrb
    return rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial3DView(origin='world', name='top view'),
        rrb.Vertical(rrb.TimeSeriesView(origin='series/lateral', name='lateral y_s [m]'),
                     rrb.TimeSeriesView(origin='series/steer', name='front steer [rad]'),
                     rrb.TimeSeriesView(origin='series/belt', name='belt speed [m/s]')),
        column_shares=[1, 1]))


def log_static(rec, info: RunInfo) -> None:
    """The belt, the arm base, the car's size and colour, the series' names and styles."""
    import rerun as rr
    g = info.geometry
    rec.send_recording_name(info.name)
    rec.log('world', rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    hl, hw = BELT_HALF_LENGTH, BELT_HALF_WIDTH
    rec.log('world/belt', rr.LineStrips3D(
        [[[-hl, -hw, 0], [hl, -hw, 0], [hl, hw, 0], [-hl, hw, 0], [-hl, -hw, 0]]],
        colors=[[60, 60, 60]], labels=['belt']), static=True)
    rec.log('world/arm/base', rr.Points3D([[g.base_x, g.base_y, 0.0]], radii=0.02,
                                          labels=['arm base']), static=True)
    rec.log('world/car', rr.Boxes3D.from_fields(
        half_sizes=[[info.car_length / 2, info.car_width / 2, 0.01]], colors=[_CAR_COLOUR]),
        static=True)
    rec.log('world/arm', rr.LineStrips3D.from_fields(colors=[_ARM_COLOUR], radii=[0.01]),
            static=True)
    for ent, (_, _, colour, width) in SERIES.items():
        rec.log(ent, rr.SeriesLines(colors=[colour], widths=[width],
                                    names=[ent.rsplit('/', 1)[1].replace('_', ' ')]),
                static=True)


def _car(columns: Columns):
    for suffix in ('ground_truth/odom', 'pose'):
        c = columns.get(suffix)
        if c is not None and len(c['t']):
            ok = np.isfinite(c['x']) & np.isfinite(c['y'])
            return c, ok
    return None, None


def send(rec, columns: Columns, t0: float, info: RunInfo, *, view_rate: float = 0.0,
         series_rate: float = 0.0) -> Dict[str, int]:
    """Send ``columns`` (those of :data:`SPEC`) as the entities; return rows per entity.

    ``view_rate`` / ``series_rate`` [Hz] decimate the 3-D entities and the series
    (:func:`decimate`; 0 = every row).
    """
    import rerun as rr
    rows: Dict[str, int] = {}

    def time_of(t):
        return [rr.TimeColumn('time', duration=np.asarray(t, dtype=float) - t0)]

    car, ok = _car(columns)
    if car is not None:
        keep = decimate(car['t'], view_rate)
        keep = keep[ok[keep]]
        if len(keep):
            x, y = car['x'][keep], car['y'][keep]
            q = np.column_stack([np.nan_to_num(car[k][keep], nan=n)
                                 for k, n in (('qx', 0), ('qy', 0), ('qz', 0), ('qw', 1))])
            psi = np.arctan2(2 * (q[:, 3] * q[:, 2] + q[:, 0] * q[:, 1]),
                             1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2))
            centers = np.column_stack([x, y, np.zeros_like(x)])
            rec.send_columns('world/car', indexes=time_of(car['t'][keep]),
                             columns=rr.Boxes3D.columns(centers=centers, quaternions=q))
            vec = info.car_length * np.column_stack([np.cos(psi), np.sin(psi),
                                                     np.zeros_like(psi)])
            rec.send_columns('world/car/heading', indexes=time_of(car['t'][keep]),
                             columns=rr.Arrows3D.columns(origins=centers, vectors=vec))
            rows['world/car'] = rows['world/car/heading'] = len(keep)
    arm = _arm_strips(columns.get('arm/joint_states'), info, view_rate)
    if arm is not None:
        t, strips = arm
        rec.send_columns('world/arm', indexes=time_of(t),
                         columns=rr.LineStrips3D.columns(strips=strips))
        rows['world/arm'] = len(t)
    for ent, (suffix, col, _, _) in SERIES.items():
        c = columns.get(suffix)
        if c is None or col not in c:
            continue
        keep = decimate(c['t'], series_rate)
        keep = keep[np.isfinite(c[col][keep])]
        if len(keep):
            rec.send_columns(ent, indexes=time_of(c['t'][keep]),
                             columns=rr.Scalars.columns(scalars=c[col][keep]))
            rows[ent] = len(keep)
    return rows


def _arm_strips(c: Optional[dict], info: RunInfo, rate: float):
    """``(t, strips N x 3 x 3)`` of the arm, or None (no joint states with three angles)."""
    from irs_models.arm_kinematics import forward_kinematics
    if c is None or not len(c['t']):
        return None
    keep = decimate(c['t'], rate)
    th = np.column_stack([c['th1'][keep], c['th2'][keep], c['th3'][keep]])
    good = np.isfinite(th).all(axis=1)
    keep, th = keep[good], th[good]
    if not len(keep):
        return None
    g = info.geometry
    strips = np.zeros((len(keep), 3, 3))
    strips[:, 0, 0], strips[:, 0, 1] = g.base_x, g.base_y
    strips[:, 1, 0] = g.base_x + g.l1 * np.cos(th[:, 0])
    strips[:, 1, 1] = g.base_y + g.l1 * np.sin(th[:, 0])
    for i, (a, b, c3) in enumerate(th):
        fk = forward_kinematics(a, b, c3, g)
        strips[i, 2, 0], strips[i, 2, 1] = fk.x_tip, fk.y_tip
    return c['t'][keep], strips
