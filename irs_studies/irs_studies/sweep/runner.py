"""Run a sweep's points on Dask (a LocalCluster by default, or a scheduler's address), or serially.

No rclpy. :func:`prepare` loads the scenario once (the experiment file -> LoopConfig, exactly as
``experiment run --offline`` does) and checks every override path against it; :func:`run_sweep`
submits the points not yet in the results (``client.map`` of :func:`.point.run_point`, the
scenario scattered once to every worker), writes completed rows to Parquet parts every
``flush_s`` seconds or ``flush_rows`` rows (so an interrupted sweep resumes where it stopped),
shows a progress line, and merges the parts at the end.

A distributed cluster (``scheduler='tcp://host:8786'``) needs this workspace's environment on
every worker (the same venv and ``install/``, e.g. ``./irs exec dask worker tcp://host:8786``):
the workers import :mod:`irs_studies.sweep.point`, and the scenario travels as plain data.
"""
from __future__ import annotations

from dataclasses import dataclass
import os
from pathlib import Path
import sys
import time

from . import results
from .axes import sweep_points
from .point import run_point
from .sweep_file import NODES, SweepError, SweepModel


@dataclass
class Prepared:
    """What every point shares: the scenario's loop configuration and duration, the points."""

    sweep: SweepModel
    cfg: object
    duration: float
    points: list


def _scenario_path(sweep: SweepModel, sweep_path: Path | None) -> str:
    s = sweep.scenario
    if sweep_path is not None and (s.endswith(('.yaml', '.yml')) or '/' in s):
        cand = Path(sweep_path).parent / s
        if cand.is_file():
            return str(cand)
    return s


def prepare(sweep: SweepModel, sweep_path: Path | None = None) -> Prepared:
    """Load the scenario and the points; :class:`SweepError` (one line) if they do not fit."""
    from irs_bringup.experiment import ExperimentError, load_experiment
    from irs_bringup.offline_twin.from_experiment import loop_config_from_experiment
    where = sweep_path or sweep.name
    try:
        exp = load_experiment(_scenario_path(sweep, sweep_path))
    except ExperimentError as exc:
        raise SweepError(f'{where}: scenario: {exc}') from None
    cfg = loop_config_from_experiment(exp)
    points = sweep_points(sweep)
    for path in {p for pt in points for p in pt['overrides']}:
        node, _, name = path.partition('.')
        section = getattr(cfg, NODES[node])
        if section is None:
            raise SweepError(f"{where}: '{path}': the scenario {exp.name} has no {node} node")
        if name not in section and name != 'seed':
            raise SweepError(f"{where}: '{path}': the {node} node of {exp.name} has no "
                             f"parameter '{name}'")
    return Prepared(sweep, cfg, float(sweep.duration or exp.duration), points)


class _Progress:
    """One progress line on stderr (rewritten in place on a terminal)."""

    def __init__(self, total: int, skipped: int, log):
        self.total, self.skipped, self.log = total, skipped, log
        self.done = self.failed = 0
        self.t0 = time.monotonic()
        self.last = 0.0
        self.tty = sys.stderr.isatty()

    def update(self, row, final=False):
        if row is not None:
            self.done += 1
            self.failed += bool(row.get('error'))
        now = time.monotonic()
        if not final and now - self.last < (0.5 if self.tty else 10.0):
            return
        self.last = now
        rate = self.done / max(now - self.t0, 1e-9)
        left = (self.total - self.done) / rate if rate > 0 else float('nan')
        line = (f'[sweep] {self.done}/{self.total} points ({self.skipped} already done, '
                f'{self.failed} refused) {rate:.2f} points/s, {left:.0f} s left')
        if self.tty:
            sys.stderr.write('\r' + line + ('\n' if final else ''))
            sys.stderr.flush()
        else:
            self.log(line)


def make_client(workers: int | None = None, scheduler: str | None = None):
    """A Dask client: on ``scheduler`` if given, else a LocalCluster of ``workers`` processes
    (default: every core), one thread each (the closed loop is single-threaded Python).

    The local cluster is the client's own: closing the client closes it (and its workers).
    """
    from distributed import Client
    if scheduler:
        return Client(scheduler)
    n = workers or os.cpu_count() or 1
    return Client(n_workers=n, threads_per_worker=1, processes=True,
                  dashboard_address=':0', silence_logs=40)   # dashboard on any free port


def run_sweep(prep: Prepared, out: Path, *, workers: int | None = None,
              scheduler: str | None = None, serial: bool = False, limit: int | None = None,
              flush_s: float = 10.0, flush_rows: int = 200, client=None,
              log=print) -> list[dict]:
    """Run the points missing from ``out``; returns all rows in point order.

    ``client``: an existing Dask client to use (kept open), instead of a new one.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    done = results.done_keys(out)
    todo = [p for p in prep.points if p['point'] not in done]
    if limit is not None:
        todo = todo[:limit]
    metrics = list(prep.sweep.metrics)
    progress = _Progress(len(todo), sum(p['point'] in done for p in prep.points), log)
    buffer, last_flush = [], time.monotonic()

    def keep(row):
        nonlocal last_flush
        buffer.append(row)
        progress.update(row)
        if len(buffer) >= flush_rows or time.monotonic() - last_flush > flush_s:
            results.write_part(out, buffer)
            buffer.clear()
            last_flush = time.monotonic()

    try:
        if serial or not todo:
            for p in todo:
                keep(run_point(prep.cfg, prep.duration, p, metrics))
        else:
            from contextlib import nullcontext

            from distributed import as_completed
            own = client is None
            with make_client(workers, scheduler) if own else nullcontext(client) as client:
                if own:
                    log(f'[sweep] Dask: {len(client.scheduler_info()["workers"])} worker(s) '
                        f'({scheduler or "local cluster"})')
                cfg = client.scatter(prep.cfg, broadcast=True)
                futures = client.map(run_point, [cfg] * len(todo), [prep.duration] * len(todo),
                                     todo, [metrics] * len(todo), pure=False)
                for fut in as_completed(futures):
                    keep(fut.result())
                    fut.release()
    except KeyboardInterrupt:
        results.write_part(out, buffer)
        progress.update(None, final=True)
        log(f'[sweep] interrupted: {progress.done} new point(s) kept in {out}; run the same '
            'command again to resume')
        raise
    results.write_part(out, buffer)
    progress.update(None, final=True)
    return results.merge(out, [p['point'] for p in prep.points])
