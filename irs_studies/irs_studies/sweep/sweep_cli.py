"""``sweep``: a scenario's offline closed loop over whole parameter spaces, on Dask.

    ./irs run irs_studies sweep <sweep.yaml|name> [--out DIR] [--workers N | --scheduler ADDR |
                                                   --serial] [--limit N] [--no-plots] [--force]
    ./irs run irs_studies sweep list                          installed sweep files
    ./irs run irs_studies sweep similitude [--out DIR]        1:10 car vs full-size presets

A sweep file (format: :mod:`irs_studies.sweep.sweep_file`) names the scenario (an experiment
file, run offline through :class:`irs_bringup.offline_twin.lateral_loop.ClosedLoop`), the axes, the
seeds and the metrics. The points run on a local Dask cluster (every core, one worker process
each) unless ``--scheduler tcp://host:8786`` names a distributed one, or ``--serial`` runs them
in this process. Results go to ``DIR`` (default ``runs/sweeps/<name>``): Parquet parts as points
complete, ``results.parquet``, ``summary.md`` and the plots. Running the same command again
skips the points already in ``DIR`` (an interrupted sweep resumes). Before anything runs, one
line gives the sweep's size (points x duration); above the limits of
:func:`.runner.check_size` the sweep is refused unless ``--force``. A bad sweep file or argument
gives one line on stderr and exit code 2; exit codes: docs/cli.md.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import sys

from irs_common.cli import InputError, describe, run_cli

COMMANDS = ('run', 'list', 'similitude')


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='sweep', description=describe(__doc__))
    sub = parser.add_subparsers(dest='cmd', required=True)
    p = sub.add_parser('run', help='run a sweep file (the default command)')
    p.add_argument('sweep', help='sweep file path, or the name of an installed one')
    p.add_argument('--out', type=Path, help='results directory (default runs/sweeps/<name>)')
    g = p.add_mutually_exclusive_group()
    g.add_argument('--workers', type=int, help='local Dask worker processes (default: all cores)')
    g.add_argument('--scheduler', help='address of a Dask scheduler (tcp://host:8786)')
    g.add_argument('--serial', action='store_true', help='run the points in this process')
    p.add_argument('--limit', type=int, help='run at most N of the missing points')
    p.add_argument('--no-plots', action='store_true', help='no PNGs (summary and Parquet only)')
    p.add_argument('--force', action='store_true',
                   help='run a sweep above the size limit (points x duration; docs/sweeps.md)')
    sub.add_parser('list', help='installed sweep files')
    from . import similitude_cli
    similitude_cli.add_arguments(sub.add_parser('similitude', help=similitude_cli.HELP))
    return parser


def _check_out(out: Path, text: str) -> None:
    """Refuse a results directory of another sweep file (resuming it would mix results)."""
    from .sweep_file import SweepError
    stored = out / 'sweep.yaml'
    if stored.is_file() and stored.read_text() != text:
        raise SweepError(f'{out} holds results of a different sweep file; give another --out '
                         'or delete it')


def inside(out: Path, name: str) -> Path:
    """``out / name``, refused (:class:`InputError`) unless it stays inside ``out``."""
    path = (Path(out) / name).resolve()
    if not path.is_relative_to(Path(out).resolve()):
        raise InputError(f'{name}: an output file must stay inside the results directory {out}')
    return path


def write_outputs(rows, sweep, out: Path, plots: bool = True, log=print) -> list[Path]:
    """``summary.md`` and the sweep's plots into ``out``; returns the written paths."""
    from .metrics import METRICS
    from .plots import heatmap, summary_markdown
    written = [out / 'summary.md']
    written[0].write_text(summary_markdown(rows, sweep, METRICS))
    if plots and rows:
        units = {a.name: a.unit for a in sweep.axes}
        for plot in sweep.plots:
            name = plot.file or f'sweep_{sweep.name}_{plot.metric}.png'
            seeds = len(sweep.seed_list)
            title = f'{sweep.name}: {plot.metric} (mean of {seeds} seed{"s" * (seeds > 1)})'
            written.append(heatmap(rows, plot, METRICS, inside(out, name), title, units))
    for p in written:
        log(f'[sweep] wrote {p}')
    return written


def run(args) -> int:
    from .runner import check_size, prepare, run_sweep
    from .sweep_file import load_sweep
    if args.workers is not None and args.workers < 1:
        raise InputError(f'--workers must be at least 1, got {args.workers}')
    if args.limit is not None and args.limit < 0:
        raise InputError(f'--limit must be >= 0, got {args.limit}')
    sweep, path = load_sweep(args.sweep)
    out = args.out or Path('runs') / 'sweeps' / sweep.name
    text = path.read_text()
    _check_out(out, text)
    prep = prepare(sweep, path)
    print(f'[sweep] {sweep.name}: {prep.size_line()}, scenario {sweep.scenario} offline -> {out}',
          flush=True)
    check_size(prep, force=args.force, limit=args.limit)
    out.mkdir(parents=True, exist_ok=True)
    (out / 'sweep.yaml').write_text(text)
    rows = run_sweep(prep, out, workers=args.workers, scheduler=args.scheduler,
                     serial=args.serial, limit=args.limit)
    write_outputs(rows, sweep, out, plots=not args.no_plots)
    missing = prep.count - len(rows)
    if missing:
        print(f'[sweep] {missing} point(s) not run yet (--limit); run again to continue')
    return 0


def list_sweeps() -> int:
    from irs_common import yaml_io
    from .sweep_file import sweeps_dir
    for f in sorted(sweeps_dir().glob('*.yaml')):
        desc = (yaml_io.safe_load(f.read_text()) or {}).get('description', '')
        print(f'{f.stem:24s} {desc}')
    return 0


def _main(argv) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] not in COMMANDS and not argv[0].startswith('-'):
        argv.insert(0, 'run')       # `sweep <file>` = `sweep run <file>`
    args = build_parser().parse_args(argv)
    if args.cmd == 'list':
        return list_sweeps()
    if args.cmd == 'similitude':
        from . import similitude_cli
        return similitude_cli.run(args)
    return run(args)


def main(argv=None) -> int:
    """The ``sweep`` command. Run as the console script (``argv`` None), an interrupted sweep
    leaves with ``os._exit`` once its points are written and its cluster closed or killed: what
    Dask and multiprocessing register to run at the interpreter's exit (closing clusters, joining
    worker processes) could otherwise wait on a cluster whose closing the signal cut, beyond
    the bound of docs/cli.md.
    """
    code = run_cli('sweep', _main, argv)
    if argv is None and code > 128:          # 128 + signal: interrupted
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


if __name__ == '__main__':
    sys.exit(main())
