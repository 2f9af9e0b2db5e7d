"""A long real-time soak with memory per process every minute: flat after warm-up, or a leak.

    ./irs exec python bench/run.py --only soak_hour                  # 60 min
    ./irs exec python bench/run.py --only soak_hour --soak-minutes 15

``realtime_figure10_composed`` (the five nodes and the recorder in one process) at 1 kHz with
SCHED_FIFO 50, for the given length. Every ``PERIOD`` s the resident set (``VmRSS``) and the
proportional set (``Pss`` of ``smaps_rollup``) of every process of the run, and the
container's memory (cgroup ``memory.current``), are sampled. The growth is the least-squares
slope over the samples after ``WARMUP`` s, in MB per hour: a leak of 1.4 MB per 10 min shows as
8 MB/h; a flat process is within a fraction of 1 MB/h. The recorder's MCAP writer holds one
chunk index per written chunk until the bag closes (the format's summary): the run prints that
share of the growth from the bag's chunk count. With ``memtrace`` (off by default) the
processes run under ``tracemalloc`` (``IRS_MEMTRACE``, irs_common.node_main) and the allocation
sites that grew most are printed: where a leak is. It costs so much CPU per step that the composed
1 kHz loop no longer keeps real time (measured: the rig fell seconds behind and stopped).
"""
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from common import domain as _domain

PERIOD = 60.0         # [s] between samples
WARMUP = 180.0        # [s] left out of the slope (start-up, first bag chunks, caches)
#: [B] mcap's writer keeps one ``ChunkIndex`` per written chunk (with the offsets of its 13
#: channels' message indexes) for the summary it writes at close: 1,513 B per chunk under
#: tracemalloc (13 JointState topics, 55 chunks, 2026-12-02); the resident set grows by 1.1-3.4
#: KB per chunk (the allocator's arenas come in steps).
INDEX_BYTES_PER_CHUNK = 1513


def _kib(path: Path, key: str) -> float:
    try:
        for line in path.read_text().splitlines():
            if line.startswith(key + ':'):
                return float(line.split()[1])
    except OSError:
        pass
    return float('nan')


def _cgroup_mb() -> float:
    for path in ('/sys/fs/cgroup/memory.current', '/sys/fs/cgroup/memory/memory.usage_in_bytes'):
        try:
            return int(Path(path).read_text()) / 1e6
        except OSError:
            continue
    return float('nan')


def _sample(procs: dict, t: float) -> dict:
    row = {'t_s': t, 'cgroup_mb': _cgroup_mb()}
    pids = {label: proc.pid for label, proc in procs.items()}
    pids['runner'] = os.getpid()      # the experiment runner runs in this process
    for label, pid in pids.items():
        row[f'{label}.rss_mb'] = _kib(Path(f'/proc/{pid}/status'), 'VmRSS') / 1024.0
        row[f'{label}.pss_mb'] = _kib(Path(f'/proc/{pid}/smaps_rollup'), 'Pss') / 1024.0
    return row


def _slopes(samples: list) -> dict:
    """Least-squares slope [MB/h] of every column over the samples after the warm-up."""
    late = [s for s in samples if s['t_s'] >= WARMUP]
    if len(late) < 3:
        return {}
    t = np.array([s['t_s'] for s in late]) / 3600.0
    out = {}
    for key in late[0]:
        if key == 't_s':
            continue
        y = np.array([s.get(key, np.nan) for s in late])
        if np.all(np.isfinite(y)):
            out[key] = float(np.polyfit(t, y, 1)[0])
    return out


def _memtrace_tail(prefix: str, lines: int = 40) -> str:
    """The last report of every ``<prefix>.<pid>.txt`` the processes wrote."""
    out = []
    for path in sorted(Path(prefix).parent.glob(Path(prefix).name + '.*.txt')):
        text = path.read_text()
        out.append(f'-- {path.name}\n' + '\n'.join(text[text.rfind('== '):].splitlines()[:lines]))
    return '\n'.join(out)


def _summary_index(bag_dir: Path, minutes: float) -> dict:
    """The bag's chunk count and the memory its writer holds for the summary's chunk indexes."""
    from mcap.reader import make_reader
    path = next(Path(bag_dir).glob('*.mcap'))
    with open(path, 'rb') as f:
        chunks = len(make_reader(f).get_summary().chunk_indexes)
    return {'chunks': chunks, 'mb_per_h': chunks * INDEX_BYTES_PER_CHUNK / 1e6 * 60.0 / minutes}


def soak(minutes: float, memtrace: bool = False) -> dict:
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner
    _domain(60)
    exp = load_experiment('realtime_figure10_composed')
    exp.duration = 60.0 * minutes
    runs_dir = tempfile.mkdtemp(prefix='irs_soak_hour_')
    prefix = f'{runs_dir}/memtrace'
    if memtrace:
        os.environ['IRS_MEMTRACE'] = prefix
        os.environ['IRS_MEMTRACE_PERIOD'] = '240'
    runner = ExperimentRunner(exp, runs_dir=runs_dir,
                              progress=False, rt_priority=50, log=lambda *_: None)
    result = {}
    thread = threading.Thread(target=lambda: result.update(r=runner.run()))
    thread.start()
    while runner.phase != 'running' and thread.is_alive():
        time.sleep(0.1)
    t0 = time.monotonic()
    samples = []
    while thread.is_alive():
        samples.append(_sample(dict(runner.procs), time.monotonic() - t0))
        line = ', '.join(f'{k} {v:.1f}' for k, v in samples[-1].items() if k != 't_s')
        print(f"  t = {samples[-1]['t_s'] / 60:5.1f} min: {line}", flush=True)
        thread.join(PERIOD)
    r = result['r']
    slopes = _slopes(samples)
    row = {'name': f'soak_hour realtime_figure10_composed SCHED_FIFO ({minutes:g} min)',
           'completed': r.completed, 'message': r.message, **r.timing,
           'samples': samples, 'growth_mb_per_h': slopes}
    print(f"{row['name']}: {'ok' if r.completed else 'FAILED'}, misses "
          f"{r.timing.get('miss_pct', float('nan')):.2f} %", flush=True)
    for key, slope in sorted(slopes.items()):
        print(f'    {key:32s} {slope:+8.2f} MB/h after {WARMUP / 60:g} min', flush=True)
    if r.bag_dir is not None and r.bag_dir.exists():
        row['summary_index'] = _summary_index(r.bag_dir, minutes)
        print(f"    the bag's MCAP summary index: {row['summary_index']['chunks']} chunks x "
              f'{INDEX_BYTES_PER_CHUNK} B = {row["summary_index"]["mb_per_h"]:.2f} MB/h held '
              'by the writer until the bag closes', flush=True)
    if memtrace:
        os.environ.pop('IRS_MEMTRACE', None)
        row['memtrace'] = _memtrace_tail(prefix)
        print(row['memtrace'], flush=True)
    return row
