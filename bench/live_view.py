"""Cost of the live view to the 1 kHz loop: ``realtime_figure10_composed`` with and without it.

    flock /tmp/irs_bench.lock ./irs exec python bench/live_view.py [--pairs 3] [--seconds 15]

Runs alternate (off, on, trimmed, foxglove, off, ...) so that the load of the shared machine
hits all alike. "on" is ``--view`` (all ten topics), "trimmed" a hand-started ``live_view`` with
three (:data:`TRIMMED`); the view writes an ``.rrd`` file (the same node and batches as
streaming to a viewer, without a viewer process on the machine). "foxglove" is ``--view
ws://127.0.0.1:P`` (the default topics, Foxglove only) with a client subscribed to every
channel (:class:`irs_system_tests.foxglove_client.Client`, in this process) receiving every
message. ``--variants`` picks some. Per run: deadline misses
[%], loop latency p50/p99 [ms] (the rig's ``rig/timing``), CPU per step of the loop process and
of the view [us]. Results go to ``bench/results/live_view-<time>.json``; compare the medians of
the interleaved runs, not single runs.
"""
import argparse
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import domain, write_results   # noqa: E402 (bench/ is on sys.path)


#: The trimmed view: topics no node of the loop subscribes to (the car, the true lateral
#: position, commanded and achieved steer), so the loop's own messages stay in-process.
TRIMMED = ['ground_truth/odom', 'ground_truth/sensor_point', 'steering/state']


def run(seconds: float, view) -> dict:
    """One run; ``view``: False, True (``--view``), 'trimmed' (a hand-started live_view
    with ``topics`` = :data:`TRIMMED`) or 'foxglove' (``--view ws://...`` and a client).
    """
    import socket
    from irs_system_tests.foxglove_client import Client
    import subprocess
    from irs_bringup.executables import resolve_executable
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner
    exp = load_experiment('realtime_figure10_composed').with_duration(seconds)
    runs = Path(tempfile.mkdtemp(prefix='irs_bench_view_'))
    hand = client = None
    target = str(runs / 'live.rrd') if view is True else None
    if view == 'foxglove':
        with socket.socket() as sock:
            sock.bind(('127.0.0.1', 0))
            target = f'ws://127.0.0.1:{sock.getsockname()[1]}'
        client = Client(target)
    if view == 'trimmed':
        hand = subprocess.Popen(
            [resolve_executable('irs_bag', 'live_view'), '--ros-args', '-p',
             f"topics:=[{','.join(TRIMMED)}]", '-p', f"save:={runs / 'live.rrd'}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        r = ExperimentRunner(exp, runs_dir=runs, progress=False, log=lambda *_: None,
                             view=target).run()
    finally:
        if hand is not None:
            hand.send_signal(2)
            hand.wait(timeout=20)
        if client is not None:
            client.stop()
    steps = r.timing.get('steps') or 1
    row = {'view': view, 'completed': r.completed, 'message': r.message, **r.timing,
           'cpu_per_step_us': {k: 1e6 * v / steps for k, v in r.cpu.items()}}
    if client is not None:
        row['foxglove_messages'] = len(client.messages)
    print(f"view {str(view):8s} {'ok' if r.completed else 'FAILED'} misses "
          f"{row.get('miss_pct', float('nan')):6.3f} %  latency p50/p99 "
          f"{row.get('latency_p50_ms', float('nan')):.3f}/"
          f"{row.get('latency_p99_ms', float('nan')):.3f} ms  CPU/step "
          + ', '.join(f'{k} {v:.0f} us' for k, v in row['cpu_per_step_us'].items())
          + (f"  Foxglove client got {row['foxglove_messages']} messages" if client else ''),
          flush=True)
    if not r.completed:
        print('    ' + ' '.join(r.message.split())[:300], flush=True)
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--pairs', type=int, default=3)
    ap.add_argument('--seconds', type=float, default=15.0)
    ap.add_argument('--variants', default='off,on,trimmed,foxglove',
                    help='comma-separated: off, on, trimmed, foxglove')
    args = ap.parse_args()
    domain(40)
    names = {'off': False, 'on': True, 'trimmed': 'trimmed', 'foxglove': 'foxglove'}
    variants = tuple(names[v] for v in args.variants.split(','))
    rows = [run(args.seconds, view) for _ in range(args.pairs) for view in variants]
    summary = {}
    for view in variants:
        sel = [r for r in rows if r['view'] == view and r['completed']]
        summary[str(view)] = {
            k: statistics.median(r[k] for r in sel) for k in
            ('miss_pct', 'latency_p50_ms', 'latency_p99_ms') if sel and all(k in r for r in sel)}
        summary[str(view)]['loop_cpu_per_step_us'] = statistics.median(
            r['cpu_per_step_us'].get('loop', float('nan')) for r in sel) if sel else None
    print('medians:', summary, flush=True)
    write_results({'rows': rows, 'summary': summary, 'seconds': args.seconds},
                  HERE / 'results', prefix='live_view-')
    return 0


if __name__ == '__main__':
    sys.exit(main())
