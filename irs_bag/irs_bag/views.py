"""A run's plots and ``run.rrd`` from one read of its bag (what ``experiment run`` writes).

The bag's columns for both (:data:`irs_bag.plots.PLOT_SPEC` and
:data:`irs_bag.rerun_entities.SPEC`) are read in one pass, then the PNGs
(:func:`irs_bag.plots.make_plots`) and the recording (:func:`irs_bag.rerun_export.export_rrd`)
are made from them. A failure of either is reported through ``log`` and never hides the other.

:func:`start_views` makes them in a detached background process (``python -m irs_bag.views``,
its own session, ``nice`` 10), so that the runner returns at once: the process logs to
``<run>/logs/views.log``. Either way, :func:`make_views` ends by writing ``<run>/views.done``
(one line per written file, ``failed: ...`` per failure) by an atomic rename, so that
``views.done`` existing means the plots and ``run.rrd`` are complete. :func:`finish_views`
waits for such a process and names what it wrote, as the foreground :func:`make_views` does.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path
from typing import Callable, List, Optional

from irs_common.cli import describe

from .columns import merge_specs, read_columns
from .reader import BagError, reading
from .run_info import run_info

__all__ = ['DONE_FILE', 'LOG_FILE', 'finish_views', 'make_views', 'start_views',
           'write_views']

#: Written into the run folder when the background views are complete.
DONE_FILE = 'views.done'
#: The background process's log, in the run folder.
LOG_FILE = 'logs/views.log'
#: ``nice`` increment of the background process: it never competes with a following run.
NICE = 10


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


def start_views(bag_dir, run_dir) -> subprocess.Popen:
    """Start :func:`make_views` in a detached process (module docstring); its ``Popen``.
    ``<run_dir>/views.done`` appears when it has finished.
    """
    run_dir = Path(run_dir)
    log_path = run_dir / LOG_FILE
    log_path.parent.mkdir(parents=True, exist_ok=True)
    (run_dir / DONE_FILE).unlink(missing_ok=True)
    with open(log_path, 'ab') as out:
        return subprocess.Popen(
            [sys.executable, '-m', 'irs_bag.views', str(bag_dir), str(run_dir),
             '--nice', str(NICE)],
            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
            start_new_session=True, close_fds=True)


def finish_views(proc: subprocess.Popen, run_dir, log: Callable[[str], None] = print
                 ) -> List[Path]:
    """Wait for ``proc`` (:func:`start_views` of ``run_dir``); log ``[experiment] wrote <file>``
    per file of ``<run_dir>/views.done`` and each failure it lists; return the written files.
    """
    run_dir = Path(run_dir)
    proc.wait()
    done = run_dir / DONE_FILE
    if not done.exists():
        log(f'[experiment] plots and run.rrd failed: their process ended with exit code '
            f'{proc.returncode} before writing {done} (log {run_dir / LOG_FILE})')
        return []
    written: List[Path] = []
    for line in done.read_text().splitlines():
        if line.startswith('failed: '):
            log(line[len('failed: '):])
        elif line:
            written.append(Path(line))
            log(f'[experiment] wrote {line}')
    return written


def make_views(bag_dir, run_dir, log: Callable[[str], None] = print) -> List[Path]:
    """:func:`write_views`, then ``<run_dir>/views.done`` (atomically): one line per written
    file, ``failed: <what>`` per failure, whatever happened. Returns the written paths.
    """
    run_dir = Path(run_dir)
    lines: List[str] = []

    def failed(text):
        log(text)
        lines.append('failed: ' + ' '.join(str(text).split()))
    written: List[Path] = []
    try:
        written = write_views(bag_dir, run_dir, failed)
    except Exception as exc:        # the marker is written whatever happens
        failed(f'[experiment] plots and run.rrd failed: {type(exc).__name__}: {exc}')
    done = run_dir / DONE_FILE
    tmp = done.with_name(DONE_FILE + '.tmp')
    tmp.write_text(''.join(f'{line}\n' for line in [*map(str, written), *lines]))
    os.replace(tmp, done)
    return written


def main(argv: Optional[List[str]] = None) -> int:
    """``python -m irs_bag.views BAG RUN_DIR``: :func:`make_views`; exit 1 if a part failed."""
    import resource
    p = argparse.ArgumentParser(prog='irs_bag.views', description=describe(__doc__))
    p.add_argument('bag', help='bag directory')
    p.add_argument('run_dir', help='run folder: plots/, run.rrd and views.done go there')
    p.add_argument('--nice', type=int, default=0, help='lower the priority by this much first')
    args = p.parse_args(argv)
    if args.nice:
        os.nice(args.nice)
    failures = []

    def log(text):
        print(text, flush=True)
        failures.append(text)
    for path in make_views(args.bag, args.run_dir, log):
        print(f'[experiment] wrote {path}', flush=True)
    use = resource.getrusage(resource.RUSAGE_SELF)
    print(f'[experiment] views done: {use.ru_utime + use.ru_stime:.1f} s CPU', flush=True)
    return 1 if failures else 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
