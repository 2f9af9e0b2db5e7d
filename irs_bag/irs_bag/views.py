"""A run's plots and ``run.rrd`` from one read of its bag (what ``experiment run`` writes).

The bag's columns for both (:data:`irs_bag.plots.PLOT_SPEC` and
:data:`irs_bag.rerun_entities.SPEC`) are read in one pass, then the PNGs
(:func:`irs_bag.plots.make_plots`) and the recording (:func:`irs_bag.rerun_export.export_rrd`)
are made from them. A failure of either is reported through ``log`` and never hides the other.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, List

from .columns import merge_specs, read_columns
from .reader import BagError, reading
from .run_info import run_info

__all__ = ['write_views']


def write_views(bag_dir, run_dir, log: Callable[[str], None] = print) -> List[Path]:
    """Write ``<run_dir>/plots/*.png`` and ``<run_dir>/run.rrd``; return the written paths."""
    from .plots import PLOT_SPEC, make_plots
    from .rerun_entities import SPEC
    from .rerun_export import export_rrd
    run_dir = Path(run_dir)
    try:
        with reading(bag_dir) as r:        # one open, one pass over the messages
            info = run_info(r)
            columns = read_columns(r, merge_specs(PLOT_SPEC, SPEC))
            written: List[Path] = []
            try:
                written += make_plots(r, run_dir / 'plots', columns=columns, info=info)
            except Exception as exc:  # plots must never hide the run's result
                log(f'[experiment] plots failed: {exc}')
            try:
                export_rrd(r, run_dir / 'run.rrd', columns=columns, info=info)
                written.append(run_dir / 'run.rrd')
            except Exception as exc:
                log(f'[experiment] rerun export failed: {exc}')
    except BagError as exc:
        log(f'[experiment] plots and run.rrd not written: {exc}')
        return []
    return written
