"""Run a sweep's points on Dask (a LocalCluster by default, or a scheduler's address), or serially.

No rclpy. :func:`prepare` loads the scenario once (the experiment file -> LoopConfig, exactly as
``experiment run --offline`` does), checks every override path against it and counts the points
without making them; :func:`check_size` refuses a sweep above :data:`MAX_SIM_SECONDS` of
simulated time or :data:`MAX_POINTS` points unless forced. :func:`run_sweep` makes the points one
at a time (:func:`.axes.iter_points`), keeps at most :data:`IN_FLIGHT` per worker submitted
(``client.submit`` of :func:`.point.run_point`, the scenario scattered once to every worker),
writes completed rows to Parquet parts every ``flush_s`` seconds or ``flush_rows`` rows (an
interrupted sweep resumes where it stopped), shows a progress bar (:class:`Progress`) and merges
the parts at the end.

A distributed cluster (``scheduler='tcp://host:8786'``) needs this workspace's environment on
every worker (the same venv and ``install/``, e.g. ``./irs exec dask worker tcp://host:8786``):
the workers import :mod:`irs_studies.sweep.point`, and the scenario travels as plain data.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import itertools
import os
from pathlib import Path
import sys
import threading
import time

from . import results
from .axes import count_points, iter_points, override_paths
from .log_lines import library_errors_in_one_line as _library_errors_in_one_line
from .point import run_point
from .sweep_file import NODES, SweepError, SweepModel

#: Refused without ``--force``: more simulated time than this in all points together [s] (about
#: an hour on 2 cores: 20,000 points of 5 s at 6-8 points/s, docs/sweeps.md) ...
MAX_SIM_SECONDS = 100_000.0
#: ... or more points than this.
MAX_POINTS = 100_000
#: Points submitted but not finished, per worker: enough to keep every worker busy.
IN_FLIGHT = 4


@dataclass
class Prepared:
    """What every point shares: the scenario's loop configuration and duration; the count."""

    sweep: SweepModel
    cfg: object
    duration: float
    count: int

    @property
    def points(self) -> list:
        """Every point as a list (small sweeps and tests; :func:`iter_points` for any size)."""
        return list(iter_points(self.sweep))

    def size_line(self) -> str:
        """``N points x D s = T s of simulated time (S steps)``: the sweep's size in one line."""
        total = self.count * self.duration
        return (f'{self.count:,} points ({len(self.sweep.seed_list):,} seed(s)) x '
                f'{self.duration:g} s = {total:,.0f} s of simulated time')


def _scenario_path(sweep: SweepModel, sweep_path: Path | None) -> str:
    s = sweep.scenario
    if sweep_path is not None and (s.endswith(('.yaml', '.yml')) or '/' in s):
        cand = Path(sweep_path).parent / s
        if cand.is_file():
            return str(cand)
    return s


def prepare(sweep: SweepModel, sweep_path: Path | None = None) -> Prepared:
    """Load the scenario, count the points; :class:`SweepError` (one line) if they do not fit."""
    from irs_bringup.experiment import ExperimentError, load_experiment
    from irs_bringup.offline_twin.from_experiment import loop_config_from_experiment
    where = sweep_path or sweep.name
    try:
        exp = load_experiment(_scenario_path(sweep, sweep_path))
    except ExperimentError as exc:
        raise SweepError(f'{where}: scenario: {exc}') from None
    cfg = loop_config_from_experiment(exp)
    for path in sorted(override_paths(sweep)):
        node, _, name = path.partition('.')
        section = getattr(cfg, NODES[node])
        if section is None:
            raise SweepError(f"{where}: '{path}': the scenario {exp.name} has no {node} node")
        if name not in section and name != 'seed':
            raise SweepError(f"{where}: '{path}': the {node} node of {exp.name} has no "
                             f"parameter '{name}'")
    return Prepared(sweep, cfg, float(sweep.duration or exp.duration), count_points(sweep))


def check_size(prep: Prepared, force: bool = False, limit: int | None = None) -> None:
    """:class:`SweepError` naming the size if the sweep (its first ``limit`` points) is above
    the limits (module docstring) and not ``force``d.
    """
    count = prep.count if limit is None else min(prep.count, limit)
    if force or (count * prep.duration <= MAX_SIM_SECONDS and count <= MAX_POINTS):
        return
    raise SweepError(f'{prep.sweep.name}: {prep.size_line()}: above the limit of '
                     f'{MAX_SIM_SECONDS:,.0f} s or {MAX_POINTS:,} points (docs/sweeps.md); '
                     'make it smaller, run part of it with --limit N, or give --force')


class Progress:
    """A progress bar on stderr: done/total, the rate over the last :attr:`WINDOW` s, time left.

    The rate counts completions only from the first one on (cluster start-up and worker imports
    are not points); until ``warmup`` points are in, the time left reads "estimating". On a
    terminal the bar is redrawn in place every 0.2 s (a ticker thread, also while no point
    completes); in a log a line every 5 s.
    """

    WINDOW = 30.0

    def __init__(self, total: int, skipped: int, log, warmup: int = 2, stream=None):
        self.total, self.skipped, self.log = total, skipped, log
        self.warmup = max(1, warmup)
        self.done = self.failed = 0
        self.stream = stream or sys.stderr
        self.t0 = time.monotonic()
        self.samples = deque()          # (time, done) since the first completion
        self.tty = self.stream.isatty()
        self.period = 0.2 if self.tty else 5.0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None

    def start(self):
        self._thread = threading.Thread(target=self._tick, daemon=True, name='sweep-progress')
        self._thread.start()
        return self

    def _tick(self):
        while not self._stop.wait(self.period):
            self.show()

    def update(self, row):
        with self._lock:
            self.done += 1
            self.failed += bool(row.get('error'))
            now = time.monotonic()
            self.samples.append((now, self.done))
            while len(self.samples) > 2 and now - self.samples[1][0] > self.WINDOW:
                self.samples.popleft()

    def rate(self) -> float | None:
        """Points per second over the window, None while estimating."""
        if self.done < self.warmup or len(self.samples) < 2:
            return None
        (t_a, n_a), (t_b, n_b) = self.samples[0], self.samples[-1]
        span = max(time.monotonic(), t_b) - t_a
        return (n_b - n_a) / span if span > 0 else None

    def line(self) -> str:
        with self._lock:
            frac = self.done / self.total if self.total else 1.0
            rate = self.rate()
            left = 'estimating' if rate is None else (
                f'{(self.total - self.done) / rate:,.0f} s left' if rate > 0 else '? s left')
            speed = '' if rate is None else f' | {rate:.2f} points/s'
            bar = '#' * int(24 * frac)
            extra = ', '.join(x for x in (f'{self.skipped} already done' if self.skipped else '',
                                          f'{self.failed} refused' if self.failed else '') if x)
            return (f'[sweep] [{bar:<24}] {100 * frac:3.0f}% {self.done:,}/{self.total:,} points'
                    f'{speed} | {left} | {time.monotonic() - self.t0:,.0f} s elapsed'
                    + (f' ({extra})' if extra else ''))

    def show(self, final: bool = False):
        text = self.line()
        if self.tty:
            self.stream.write('\r\x1b[K' + text + ('\n' if final else ''))
            self.stream.flush()
        else:
            self.log(text)

    def close(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(1.0)
        self.show(final=True)


def make_client(workers: int | None = None, scheduler: str | None = None):
    """A Dask client: on ``scheduler`` if given, else a LocalCluster of ``workers`` processes
    (default: every core), one thread each (the closed loop is single-threaded Python).

    The local cluster is the client's own: closing the client closes it (and its workers). A
    scheduler address where no Dask scheduler answers is one :class:`SweepError` line.
    """
    from distributed import Client
    if scheduler:
        try:
            return Client(scheduler, timeout='10s')
        except Exception as exc:  # noqa: BLE001 -- whatever the peer did, it is no scheduler
            text = ' '.join(str(exc).split())[:160] or type(exc).__name__
            raise SweepError(f'--scheduler {scheduler}: no Dask scheduler answered there '
                             f'({type(exc).__name__}: {text})') from None
    n = workers or os.cpu_count() or 1
    # preload: each worker ignores SIGINT (worker_signals), only this process stops the sweep
    return Client(n_workers=n, threads_per_worker=1, processes=True,
                  dashboard_address=':0', silence_logs=40,   # dashboard on any free port
                  preload=['irs_studies.sweep.worker_signals'])


def _kill(pids):
    """SIGKILL to those of ``pids`` that are still this process's children."""
    import signal
    for pid in pids:
        try:
            stat = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
            if int(stat[1]) == os.getpid():
                os.kill(pid, signal.SIGKILL)
        except (OSError, ValueError, IndexError):
            pass


def _close(client, worker_pids, timeout: float = 5.0):
    """Close the client and its local cluster within about ``timeout`` s; workers still there
    after that are killed (an interrupted sweep stops in bounded time).

    A first signal while closing is held until the close is done and then acted on
    (:func:`irs_common.cli.held_signals`): cut in the middle, Dask's close would leave its
    cluster half closed and log the cancelled coroutine with a traceback from its loop thread.
    A second signal still leaves at once (the workers killed first).
    """
    from irs_common.cli import held_signals
    with held_signals() as held:
        try:
            with _library_errors_in_one_line():
                client.close(timeout=timeout)
        except Exception:  # noqa: BLE001 -- closing on the way out: the kill below follows
            pass
        _kill(worker_pids)
    held.deliver()


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
    todo = (p for p in iter_points(prep.sweep) if p['point'] not in done)
    skipped = len(done)
    n_todo = max(0, prep.count - skipped)
    if limit is not None:
        todo = itertools.islice(todo, limit)
        n_todo = min(n_todo, limit)
    metrics = list(prep.sweep.metrics)
    buffer, last_flush = [], time.monotonic()
    progress = None

    def keep(row):
        nonlocal last_flush
        buffer.append(row)
        progress.update(row)
        if len(buffer) >= flush_rows or time.monotonic() - last_flush > flush_s:
            results.write_part(out, buffer)
            buffer.clear()
            last_flush = time.monotonic()

    try:
        if serial or not n_todo:
            progress = Progress(n_todo, skipped, log).start()
            for p in todo:
                keep(run_point(prep.cfg, prep.duration, p, metrics))
        else:
            own = client is None
            if own:
                client = make_client(workers, scheduler)
            worker_pids = []
            try:
                n_workers = len(client.scheduler_info()['workers'])
                if own:
                    log(f'[sweep] Dask: {n_workers} worker(s) ({scheduler or "local cluster"}); '
                        f'dashboard {client.dashboard_link}')
                    if not scheduler:
                        worker_pids = list(client.run(os.getpid).values())
                        _on_second_signal(lambda: _kill(worker_pids))
                progress = Progress(n_todo, skipped, log, warmup=max(2, n_workers + 1)).start()
                _run_on_dask(client, prep, todo, metrics, keep, IN_FLIGHT * max(1, n_workers))
            finally:
                if own:
                    _close(client, worker_pids)
    except KeyboardInterrupt:
        results.write_part(out, buffer)
        if progress is not None:
            progress.close()
            log(f'[sweep] interrupted: {progress.done} new point(s) kept in {out}; run the same '
                'command again to resume')
        raise
    results.write_part(out, buffer)
    progress.close()
    return results.merge(out, (p['point'] for p in iter_points(prep.sweep)))


def _on_second_signal(hook):
    """A second signal (:mod:`irs_common.cli`) runs ``hook`` before the process leaves."""
    from irs_common.cli import current_guard
    guard = current_guard()
    if guard is not None:
        guard.force_hooks.append(hook)


def _run_on_dask(client, prep, todo, metrics, keep, in_flight: int):
    """Submit ``todo`` lazily, at most ``in_flight`` at a time; ``keep`` every row.

    A first SIGINT/SIGTERM only sets a flag here (:class:`irs_common.cli.SignalGuard`
    ``on_first``), checked between Dask calls, so that it never interrupts one of them (a
    KeyboardInterrupt inside ``distributed.utils.sync`` leaves a half-done gather and, at worst,
    a logged traceback: :func:`_library_errors_in_one_line`); the points still submitted are then
    cancelled and :class:`irs_common.cli.Interrupted` is raised.
    """
    from distributed import as_completed

    from irs_common.cli import Interrupted, current_guard
    guard = current_guard()
    stop = threading.Event()
    previous = guard.on_first if guard is not None else None
    if guard is not None:
        guard.on_first = lambda _signum: stop.set()
        if guard.signum is not None:    # a signal whose Interrupted Python ignored (player.py)
            stop.set()
    pending = None
    try:
        cfg = client.scatter(prep.cfg, broadcast=True)

        def submit(p):
            return client.submit(run_point, cfg, prep.duration, p, metrics, pure=False)

        pending = as_completed([])
        for p in itertools.islice(todo, in_flight):
            if stop.is_set():
                break
            pending.add(submit(p))
        while not stop.is_set() and not pending.is_empty():
            batch = pending.next_batch(block=False)
            if not batch:
                stop.wait(0.02)   # a signal ends the wait at once; a point takes far longer
                continue
            for fut in batch:
                row = fut.result()
                fut.release()
                keep(row)
                nxt = None if stop.is_set() else next(todo, None)
                if nxt is not None:
                    pending.add(submit(nxt))
    finally:
        if guard is not None:
            guard.on_first = previous
    if stop.is_set():
        if pending is not None:
            with pending.lock:
                running = list(pending.futures)
            with _library_errors_in_one_line():
                client.cancel(running)
        raise Interrupted(guard.signum)
