"""A timeline of one node process's loop, to find what delays its 1 kHz ticks (no rclpy).

With ``IRS_TRACE=<prefix>`` in the environment every node process (``run_nodes``) spins a
:class:`~irs_common.executor.TracedLeanExecutor` and writes ``<prefix>.<pid>.npz`` when it
stops. Four records, each with ``time.monotonic_ns`` stamps [ns]:

``spins`` (one row per ``spin_once``)
    ``before_wait, due, woke, done``: the wait starts at ``before_wait`` and should return by
    ``due`` = ``before_wait`` + the smaller of its timeout and the next timer's
    ``time_until_next_call`` (``-1``: no limit); it returned at ``woke``; the callbacks it ran
    were done at ``done``.
``calls`` (timer callbacks that took at least ``CALL_MIN_NS``)
    ``start, end, timer``: ``timer`` indexes ``names``, the callbacks' qualified names.
``chunks`` (each chunk of an :class:`irs_bag.writer.BagWriter` in this process)
    ``added, start, end, messages``: from ``added`` the chunk's messages were added to mcap's
    writer (the writer thread pauses every 16 messages); from ``start`` to ``end`` its end ran
    (compression, message indexes, the file flushed: one call, the interpreter lock held for
    most of it), by the writer thread or in line.
``gcs`` (each collection of Python's garbage collector)
    ``start, end, generation``.

The file also holds the process's node names and whether they run on simulated time.

:func:`report` reads such files and says how many timer wakes came late (``woke - due`` above
a threshold, 0.5 ms by default, ``--late-ms``), and what overlapped each late wake, in this
order: a bag chunk's end (it holds the interpreter lock for up to milliseconds:
docs/performance.md), the writer adding a chunk's messages, a garbage collection, or none of
these (another thread's Python, another process, the VM). ``python -m irs_common.loop_trace
FILE...`` prints it.

The due times are for real-time runs: under simulated time (lock-step) a timer's
``time_until_next_call`` is in simulated time, so the report does not judge the waits of a
process whose nodes run on simulated time.

The recording adds about 1 us per timer to each ``spin_once`` (7 us with six timers on the
2-core machine of docs/performance.md, 2026-12-05) and 8 bytes per stamp; it stops after
``IRS_TRACE_SPINS`` spins (default 1,200,000: 10 min of a composed 1 kHz loop at about two
spins per step) and the report says so.
"""
from __future__ import annotations

import argparse
from array import array
from dataclasses import dataclass
import gc
import math
import os
import sys
import time
import zipfile
import zlib

__all__ = ['LoopTrace', 'ACTIVE', 'start', 'stop', 'load', 'report', 'summarise', 'TraceSummary',
           'TraceFileError']

#: A timer callback shorter than this [ns] is not recorded.
CALL_MIN_NS = 200_000
DEFAULT_SPINS = 1_200_000

#: The trace of this process while one is recorded (``start``), else None.
ACTIVE: 'LoopTrace | None' = None


class LoopTrace:
    """The four records of one process (module docstring), kept in ``array('q')``."""

    def __init__(self, path: str, max_spins: int = DEFAULT_SPINS):
        self.path = path
        self.nodes: list[str] = []      # the process's nodes (set by run_nodes)
        self.sim_time = False           # they run on simulated time: waits not judged
        self.max_spins = int(max_spins)
        self.spins = array('q')
        self.calls = array('q')
        self.chunks = array('q')
        self.gcs = array('q')
        self.names: list[str] = []
        self._name_index: dict = {}
        self._gc_start = 0
        self.truncated = False

    # -- recording (each a few appends; the executor and the bag writer call them)
    def spin(self, before_wait: int, due: int, woke: int, done: int) -> None:
        if len(self.spins) >= 4 * self.max_spins:
            self.truncated = True
            return
        self.spins.extend((before_wait, due, woke, done))

    def call(self, start: int, end: int, name: str) -> None:
        index = self._name_index.get(name)
        if index is None:
            index = self._name_index[name] = len(self.names)
            self.names.append(name)
        self.calls.extend((start, end, index))

    def chunk(self, added: int, start: int, end: int, messages: int) -> None:
        self.chunks.extend((added, start, end, messages))

    def _on_gc(self, phase: str, info: dict) -> None:
        if phase == 'start':
            self._gc_start = time.monotonic_ns()
        else:
            self.gcs.extend((self._gc_start, time.monotonic_ns(), info.get('generation', -1)))

    # -- output
    def save(self) -> str:
        """Write ``<path>`` (npz: the four records as n x 3 or n x 4 int64 arrays)."""
        import numpy as np

        def table(values, width):
            return np.frombuffer(values, dtype=np.int64).reshape(-1, width).copy()
        np.savez_compressed(self.path, spins=table(self.spins, 4), calls=table(self.calls, 3),
                            chunks=table(self.chunks, 4), gcs=table(self.gcs, 3),
                            names=np.array(self.names, dtype=str),
                            nodes=np.array(self.nodes, dtype=str),
                            sim_time=np.array(self.sim_time),
                            truncated=np.array(self.truncated))
        return self.path


def start(prefix: str, max_spins: int | None = None) -> LoopTrace:
    """Begin this process's trace into ``<prefix>.<pid>.npz`` (:data:`ACTIVE`); collections
    of the garbage collector are recorded from now on.
    """
    global ACTIVE
    if max_spins is None:
        text = os.environ.get('IRS_TRACE_SPINS', '').strip() or str(DEFAULT_SPINS)
        try:
            max_spins = int(text)
        except ValueError:
            max_spins = 0
        if max_spins < 1:
            raise ValueError(f'IRS_TRACE_SPINS={text!r}: expected a whole number >= 1')
    folder = os.path.dirname(prefix) or '.'
    if not os.path.isdir(folder):
        raise ValueError(f'IRS_TRACE={prefix!r}: the folder {folder!r} does not exist')
    ACTIVE = LoopTrace(f'{prefix}.{os.getpid()}.npz', max_spins)
    gc.callbacks.append(ACTIVE._on_gc)
    return ACTIVE


def stop() -> LoopTrace | None:
    """End the trace (its file is written by the caller); the trace, or None."""
    global ACTIVE
    trace, ACTIVE = ACTIVE, None
    if trace is not None and trace._on_gc in gc.callbacks:
        gc.callbacks.remove(trace._on_gc)
    return trace


# ---------------------------------------------------------------------------------- analysis
@dataclass
class TraceSummary:
    """What :func:`summarise` finds in one trace (times in ms unless named otherwise)."""

    seconds: float
    spins: int
    timer_wakes: int          # spins whose wait had a due time (a timer or a timeout)
    late: int                 # of those, woke more than the threshold after their due time
    late_in_chunk: int        # a late wake whose lateness overlaps a bag chunk's end
    late_in_adding: int       # ... the writer adding a chunk's messages (and no chunk end)
    late_in_gc: int           # ... a garbage collection (and neither of those)
    late_p50: float
    late_max: float
    long_dispatches: int      # spins whose callbacks took more than 1 ms
    longest_dispatch: float
    slowest_calls: list       # (name, count, max ms) of the recorded timer callbacks
    chunks: int
    chunk_p50: float
    chunk_max: float
    gcs: int
    gc_max: float
    truncated: bool
    nodes: list
    sim_time: bool


def _overlaps(starts, ends, lo, hi):
    """For each interval [lo, hi], whether any [starts, ends] interval overlaps it."""
    import numpy as np
    if len(starts) == 0:
        return np.zeros(len(lo), dtype=bool)
    order = np.argsort(starts)
    starts, ends = starts[order], ends[order]
    ends_max = np.maximum.accumulate(ends)
    # the intervals that start before hi: the latest of their ends must reach lo
    k = np.searchsorted(starts, hi, side='right') - 1
    hit = k >= 0
    return hit & (ends_max[np.maximum(k, 0)] >= lo)


def summarise(data, late_ms: float = 0.5) -> TraceSummary:
    """The :class:`TraceSummary` of one loaded trace (a mapping of the npz's arrays)."""
    import numpy as np
    spins, calls, chunks, gcs = (np.asarray(data[k]) for k in ('spins', 'calls', 'chunks',
                                                                'gcs'))
    names = [str(n) for n in np.asarray(data['names'])]
    sim_time = bool(np.asarray(data['sim_time']))
    limited = spins[spins[:, 1] >= 0] if not sim_time else spins[:0]
    lateness = (limited[:, 2] - limited[:, 1]).astype(float) if len(limited) else np.zeros(0)
    late = lateness > late_ms * 1e6
    due, woke = limited[late, 1], limited[late, 2]
    in_chunk = _overlaps(chunks[:, 1], chunks[:, 2], due, woke)
    in_adding = _overlaps(chunks[:, 0], chunks[:, 1], due, woke) & ~in_chunk
    in_gc = _overlaps(gcs[:, 0], gcs[:, 1], due, woke) & ~in_chunk & ~in_adding
    dispatch = (spins[:, 3] - spins[:, 2]) / 1e6 if len(spins) else np.zeros(0)
    slowest = []
    for index, name in enumerate(names):
        mine = calls[calls[:, 2] == index]
        durations = (mine[:, 1] - mine[:, 0]) / 1e6
        slowest.append((name, len(durations), float(durations.max()) if len(durations) else 0))
    slowest.sort(key=lambda row: -row[2])
    chunk_ms = (chunks[:, 2] - chunks[:, 1]) / 1e6
    gc_ms = (gcs[:, 1] - gcs[:, 0]) / 1e6 if len(gcs) else np.zeros(0)
    late_values = lateness[late] / 1e6
    return TraceSummary(
        seconds=float(spins[-1, 3] - spins[0, 0]) / 1e9 if len(spins) else 0.0,
        spins=len(spins), timer_wakes=len(limited), late=int(late.sum()),
        late_in_chunk=int(in_chunk.sum()), late_in_adding=int(in_adding.sum()),
        late_in_gc=int(in_gc.sum()),
        late_p50=float(np.median(late_values)) if len(late_values) else 0.0,
        late_max=float(late_values.max()) if len(late_values) else 0.0,
        long_dispatches=int((dispatch > 1.0).sum()),
        longest_dispatch=float(dispatch.max()) if len(dispatch) else 0.0,
        slowest_calls=slowest[:5], chunks=len(chunks),
        chunk_p50=float(np.median(chunk_ms)) if len(chunk_ms) else 0.0,
        chunk_max=float(chunk_ms.max()) if len(chunk_ms) else 0.0,
        gcs=len(gcs), gc_max=float(gc_ms.max()) if len(gc_ms) else 0.0,
        truncated=bool(np.asarray(data['truncated'])),
        nodes=[str(n) for n in np.asarray(data['nodes'])], sim_time=sim_time)


#: The arrays of a trace file and their number of columns (None: one dimension or a scalar).
_ARRAYS = {'spins': 4, 'calls': 3, 'chunks': 4, 'gcs': 3, 'names': None, 'nodes': None,
           'truncated': None, 'sim_time': None}


class TraceFileError(ValueError):
    """A file that is not a trace written by :meth:`LoopTrace.save` (one line)."""


def load(path: str) -> dict:
    """The arrays of the trace file ``path``, checked; :class:`TraceFileError` otherwise."""
    import numpy as np
    try:
        data = np.load(path, allow_pickle=False)
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError) as exc:
        raise TraceFileError(f'not an IRS_TRACE file ({type(exc).__name__})') from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise TraceFileError('not an IRS_TRACE file (a single numpy array)')
    try:
        with data:
            arrays = {k: data[k] for k in data.files}
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError) as exc:
        raise TraceFileError(f'not an IRS_TRACE file ({type(exc).__name__})') from None
    for name, columns in _ARRAYS.items():
        if name not in arrays:
            raise TraceFileError(f'not an IRS_TRACE file (no {name!r} array)')
        shape = arrays[name].shape
        if columns is not None and (len(shape) != 2 or shape[1] != columns):
            raise TraceFileError(f'not an IRS_TRACE file ({name!r} has shape {shape}, '
                                 f'expected n x {columns})')
    return arrays


def report(path: str, late_ms: float = 0.5) -> str:
    """The text :func:`main` prints for one trace file."""
    s = summarise(load(path), late_ms)
    nodes = ', '.join(s.nodes) or 'no nodes'
    lines = [f'{path} ({nodes}): {s.seconds:.1f} s, {s.spins} spins'
             + (' (truncated at IRS_TRACE_SPINS)' if s.truncated else '')]
    if s.sim_time:
        lines.append('  simulated time: the waits are not judged (their due times are in '
                     'simulated time)')
    else:
        pct = 100.0 * s.late / s.timer_wakes if s.timer_wakes else 0.0
        lines += [
            f'  waits that returned over {late_ms:g} ms after due: {s.late} of '
            f'{s.timer_wakes} ({pct:.2f} %)'
            + (f'; late by p50 {s.late_p50:.2f} ms, max {s.late_max:.2f} ms' if s.late else ''),
            f"    during a bag chunk's end: {s.late_in_chunk}; while the writer added a "
            f"chunk's messages: {s.late_in_adding}; during a garbage collection: "
            f'{s.late_in_gc}; none of these (another thread, another process, the VM): '
            f'{s.late - s.late_in_chunk - s.late_in_adding - s.late_in_gc}']
    lines.append(f'  spins whose callbacks took > 1 ms: {s.long_dispatches} (longest '
                 f'{s.longest_dispatch:.2f} ms)')
    for name, count, longest in s.slowest_calls:
        lines.append(f'    timer callback {name}: {count} over {CALL_MIN_NS / 1e6:g} ms, '
                     f'longest {longest:.2f} ms')
    lines.append(f'  bag chunk ends: {s.chunks}' + (
        f', p50 {s.chunk_p50:.2f} ms, max {s.chunk_max:.2f} ms' if s.chunks else ''))
    lines.append(f'  garbage collections: {s.gcs}' + (
        f', longest {s.gc_max:.2f} ms' if s.gcs else ''))
    return '\n'.join(lines)


def _threshold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f'expected a finite number of ms > 0, got {text!r}')
    return value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m irs_common.loop_trace',
        description='Summarise IRS_TRACE files (<prefix>.<pid>.npz) of node processes: late '
                    'waits and what overlapped them.')
    parser.add_argument('files', nargs='+', help='trace files written with IRS_TRACE=<prefix>')
    parser.add_argument('--late-ms', type=_threshold, default=0.5,
                        help='a wait that returns later than this after its due time is late '
                             '(default 0.5)')
    args = parser.parse_args(argv)
    code = 0
    for path in args.files:
        try:
            print(report(path, args.late_ms), flush=True)
        except (OSError, TraceFileError) as exc:
            text = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            print(f'loop_trace: error: {path}: {" ".join(str(text).split())}', file=sys.stderr)
            code = 2
    return code


if __name__ == '__main__':
    sys.exit(main())
