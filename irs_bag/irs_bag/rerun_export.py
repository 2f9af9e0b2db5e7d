"""``bag rerun <bag> --out file.rrd``: a rerun recording of an IRS run (rerun-sdk 0.41).

The entities are those of :mod:`irs_bag.rerun_entities`: the belt,
the arm and the car in a 3-D top view (treadmill frame, z up), and the lateral, steering and belt
time series, on the timeline ``time`` (seconds from the first message, from ``header.stamp``: sim
time in lock-step runs). The bag's columns are read once (:func:`irs_bag.columns.read_columns`)
and sent with rerun's columnar ``send_columns``, one call per entity; the 3-D entities are
decimated to ``--view-rate`` Hz (default 50), the series to ``--series-rate`` Hz (default 200;
0 = every message). Arm geometry and car size come from the run's metadata (the rig's
parameters), else the defaults of docs/conventions.md; the options override them. The
recording is named after the run and carries a default layout (3-D view beside the series).

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 1 nothing to export, 2 unreadable bag / write error / usage error (one line
on stderr).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Dict, List, Optional

from irs_common.cli import EXIT_FAILED, InputError, error, run_cli

from .columns import Columns, read_columns
from .reader import BagError, open_bag, reading
from .rerun_entities import ENTITY_PATHS, SPEC, blueprint, log_static, send
from .run_info import RunInfo, run_info

__all__ = ['export_rrd', 'main', 'ENTITY_PATHS', 'NothingToExport', 'SPEC']


class NothingToExport(BagError):
    """The bag has none of the topics (or no usable message) the export uses."""


def export_rrd(bag_path, rrd_path, *, view_rate: float = 50.0, series_rate: float = 200.0,
               geometry=None, car_length: Optional[float] = None,
               car_width: Optional[float] = None, application_id: str = 'irs',
               columns: Optional[Columns] = None, info: Optional[RunInfo] = None
               ) -> Dict[str, int]:
    """Write ``rrd_path`` from ``bag_path`` (a path, opened strictly, or an open
    :class:`BagReader`); return the number of rows logged per entity.

    ``geometry`` (:class:`irs_models.arm_kinematics.ArmGeometry`), ``car_length`` and
    ``car_width`` [m] override the run's own; ``columns``: the bag's columns of :data:`SPEC`
    when already read (the experiment runner reads them once for the plots and the export).

    Raises
    ------
    BagError
        Unreadable bag, or none of the used topics is in it.
    """
    import numpy as np
    import rerun as rr

    with reading(bag_path) as r:
        info = info or run_info(r)
        if columns is None:
            columns = read_columns(r, SPEC)
        path = r.path
    columns = {s: c for s, c in columns.items() if s in SPEC and len(c['t'])}
    if not columns:
        raise NothingToExport(
            f'{path}: none of the topics used by the rerun export is in the bag '
            f'({", ".join(SPEC)})')
    changes = {k: v for k, v in (('car_length', car_length), ('car_width', car_width),
                                 ('geometry', geometry)) if v is not None}
    info = dataclasses.replace(info, **changes)
    t0 = float(min(np.min(c['t']) for c in columns.values()))

    rec = rr.RecordingStream(application_id)
    try:
        Path(rrd_path).parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(rrd_path), default_blueprint=blueprint())
    except (OSError, RuntimeError) as exc:
        raise BagError(f'cannot write {rrd_path} ({exc})') from None
    log_static(rec, info)
    rows = {'world/belt': 1, 'world/arm/base': 1}
    rows.update(send(rec, columns, t0, info, view_rate=view_rate, series_rate=series_rate))
    rec.flush()
    rec.disconnect()
    if len(rows) == 2:
        raise NothingToExport(f'{path}: no usable messages for the rerun export')
    if not Path(rrd_path).is_file() or Path(rrd_path).stat().st_size == 0:
        raise BagError(f'rerun did not write {rrd_path}')
    return rows


def rrd_entity_paths(rrd_path) -> set:
    """Entity paths found in an ``.rrd`` file (read back with ``rerun.chunk.RrdReader``)."""
    from rerun.chunk import RrdReader
    return {c.entity_path.lstrip('/') for c in RrdReader(str(rrd_path)).stream().to_chunks()}


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag rerun``; returns the exit code (docs/cli.md)."""
    return run_cli('bag rerun', _main, argv)


def _main(argv: Optional[List[str]]) -> int:
    p = argparse.ArgumentParser(
        prog='bag rerun', description='Export an IRS bag to a rerun .rrd recording.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--out', required=True, help='output .rrd file')
    p.add_argument('--view-rate', type=float, default=50.0,
                   help='rate of the 3-D entities [Hz] (0 = every message)')
    p.add_argument('--series-rate', type=float, default=200.0,
                   help='time series rate [Hz] (0 = every message)')
    arm = ('l1', 'l2', 'base_x', 'base_y', 'attach_offset')
    for name, what in zip(arm, ('arm link 1 length', 'arm link 2 length', 'arm base x',
                                'arm base y', 'arm tip offset')):
        p.add_argument('--' + name.replace('_', '-'), type=float,
                       help=f"{what} [m] (default: the run's, else docs/conventions.md)")
    p.add_argument('--car-length', type=float, help="car box length [m] (default: the run's)")
    p.add_argument('--car-width', type=float, help="car box width [m] (default: the run's)")
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'bag rerun') as r:
            info = run_info(r)
            given = {k: getattr(args, k) for k in arm if getattr(args, k) is not None}
            try:
                geom = dataclasses.replace(info.geometry, **given)
            except ValueError as exc:
                raise InputError(f'arm geometry: {exc}') from None
            rows = export_rrd(r, args.out, view_rate=args.view_rate,
                              series_rate=args.series_rate, geometry=geom,
                              car_length=args.car_length, car_width=args.car_width, info=info)
    except NothingToExport as exc:
        error('bag rerun', exc)
        return EXIT_FAILED
    except BagError as exc:
        raise InputError(str(exc)) from None
    print(f'{args.out}: ' + ', '.join(f'{k} ({v})' for k, v in sorted(rows.items())))
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
