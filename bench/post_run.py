"""Time from a run's end to the prompt of ``experiment run``, and until its plots are written.

    flock /tmp/irs_bench.lock ./irs exec python bench/post_run.py [--pairs 2] [--base /work/main]

Per experiment (a lock-step Figure 10 run of 8 s, ``realtime_figure10_composed`` for 10 s),
runs alternate between the tree ``--base`` (its ``./irs``, e.g. the main branch) and this one
(background plots, then with ``--wait-plots``), so that the load of the shared machine hits all
alike. Each run is ``experiment run`` as a user starts it, in a fresh ``--runs-dir``; its output
lines are timestamped as they arrive. Measured: from the runner's line ``<name>: completed;
simulated ...`` (every node stopped) to the exit of the command (the prompt), and to the
appearance of ``views.done`` (background plots written) [s of wall time]. Results go to
``bench/results/post_run-<time>.json``.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import domain, write_results   # noqa: E402 (bench/ is on sys.path)

RUNS = (('figure10_mrc_with_actuator', 8.0), ('realtime_figure10_composed', 10.0))
DEADLINE = 600.0        # [s] longest wait for a run or its plots


def one(irs: Path, name: str, seconds: float, extra=(), background=False) -> dict:
    """One ``experiment run`` through ``irs``; the times of its end, prompt, plots
    (``background``: the runner makes them after its exit, ``views.done`` marks the end).
    """
    runs = Path(tempfile.mkdtemp(prefix='irs_bench_post_'))
    cmd = [str(irs), 'run', 'irs_bringup', 'experiment', 'run', name, '--duration',
           str(seconds), '--runs-dir', str(runs), *extra]
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED='1'))
    end = None
    for line in proc.stdout:
        if end is None and f'] {name}: ' in line and ' simulated ' in line:
            end = time.monotonic()
    proc.wait(timeout=DEADLINE)
    prompt = time.monotonic()
    done = prompt                    # a blocking runner: the plots are there at the prompt
    if background:
        deadline = prompt + DEADLINE
        while not list(runs.glob('*/views.done')) and time.monotonic() < deadline:
            time.sleep(0.1)
        marks = list(runs.glob('*/views.done'))
        done = marks[0].stat().st_mtime - (time.time() - time.monotonic()) if marks else None
    pngs = sorted(p.name for p in runs.glob('*/plots/*.png'))
    row = {'tree': str(irs.parent), 'name': name, 'extra': list(extra), 'exit': proc.returncode,
           'run_s': None if end is None else end - t0,
           'end_to_prompt_s': None if end is None else prompt - end,
           'end_to_plots_s': None if end is None or done is None else done - end,
           'pngs': pngs, 'rrd': bool(list(runs.glob('*/run.rrd')))}
    print(f"{row['tree']:22s} {name:30s} {' '.join(extra):13s} exit {proc.returncode} run "
          f"{row['run_s'] or float('nan'):6.1f} s  end->prompt "
          f"{row['end_to_prompt_s'] or float('nan'):6.1f} s  end->plots "
          f"{row['end_to_plots_s'] or float('nan'):6.1f} s  {len(pngs)} PNG "
          f"{'rrd' if row['rrd'] else 'NO rrd'}", flush=True)
    shutil.rmtree(runs, ignore_errors=True)
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--pairs', type=int, default=2)
    ap.add_argument('--base', default='/work/main', help='tree of the blocking runner')
    args = ap.parse_args()
    domain()
    rows = []
    trees = [(Path(args.base) / 'irs', (), False), (HERE.parent / 'irs', (), True),
             (HERE.parent / 'irs', ('--wait-plots',), False)]
    for _ in range(args.pairs):
        for name, seconds in RUNS:
            for irs, extra, background in trees:
                rows.append(one(irs, name, seconds, extra, background))
    write_results({'rows': rows}, HERE / 'results', 'post_run-')
    return 0


if __name__ == '__main__':
    sys.exit(main())
