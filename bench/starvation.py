"""How much starvation each real-time deployment survives: kept, controlled stop or lost.

    ./irs exec python bench/run.py --only starvation        # (about 5 min)

For each deployment (``realtime_figure10``: a process per node; ``realtime_figure10_composed``:
one process) and each stall length, one run of the Figure 10 graph in real time, recorder on
(``rig/status`` and the ground truth recorded too): after ``WARMUP`` s of wall time one process
is stopped (SIGSTOP) for the stall length and continued (SIGCONT); the run goes on for
``AFTER`` s. From the bag: *lost* if ``rig/status`` ever says the car left the belt, else
*controlled stop* if the rig stopped (``safe_state`` >= ``SAFE_STOPPING``, with the cause), else
*kept*. The stopped process is the treadmill regulator's (process per node) or the whole
composed process (composed: every node, the rig included, stalls). The ``bursts`` column stops
nothing: after ``WARMUP`` s, waves of process start-ups run beside the graph, as ``ros2``
commands typed by hand do (each imports rclpy, creates a node and spins it for 1 s;
``BURST_WAVES`` waves of ``BURST_SIZE``, ``BURST_GAP`` s apart).
"""
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

from common import domain as _domain

WARMUP = 5.0          # [s] wall time before the stall
AFTER = 15.0          # [s] after it: a controlled stop comes to rest in about 11 s
STALLS = (0.2, 0.5, 2.0, 5.0, 'bursts')
BURST_WAVES, BURST_SIZE, BURST_GAP = 8, 3, 0.3
BURST_SECONDS = 15.0    # [s] about how long the waves take on this VM
_BURST_CODE = ("import time, rclpy; rclpy.init(); n = rclpy.create_node('starvation_burst'); "
               "t = time.monotonic()\nwhile time.monotonic() - t < 1.0: "
               "rclpy.spin_once(n, timeout_sec=0.05)")
DEPLOYMENTS = {'realtime_figure10': 'treadmill_regulator', 'realtime_figure10_composed': 'loop'}
SAFE_NAMES = ('running', 'holding', 'stopping', 'stopped', 'recovering')


def _outcome(bag_dir) -> dict:
    from irs_bag.reader import BagReader
    worst, cause, on_belt, fault = 0, '', True, ''
    with BagReader(bag_dir) as reader:
        for _raw, msg in reader.decoded(topics=['/rig/status']):
            worst = max(worst, int(getattr(msg, 'safe_state', 0)))
            cause = cause or getattr(msg, 'stop_cause', '')
            if not msg.car_on_belt:
                on_belt, fault = False, msg.fault_text
    outcome = 'lost' if not on_belt else 'controlled stop' if worst >= 2 else 'kept'
    return {'outcome': outcome, 'worst_state': SAFE_NAMES[worst], 'cause': cause or fault}


def _one(name: str, target: str, stall: float) -> dict:
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner
    exp = load_experiment(name)
    exp.duration = WARMUP + (BURST_SECONDS if stall == 'bursts' else stall) + AFTER
    exp.record_topics = sorted(set(exp.record_topics) | {'/rig/status'})
    runner = ExperimentRunner(exp, runs_dir=tempfile.mkdtemp(prefix='irs_starve_'),
                              progress=False, log=lambda *_: None)
    result = {}
    thread = threading.Thread(target=lambda: result.update(r=runner.run()))
    thread.start()
    while runner.phase != 'running' and thread.is_alive():
        time.sleep(0.05)
    time.sleep(WARMUP)
    proc = runner.procs.get(target)
    if stall == 'bursts':
        _bursts()
    elif proc is not None and proc.poll() is None:
        os.kill(proc.pid, signal.SIGSTOP)
        time.sleep(stall)
        os.kill(proc.pid, signal.SIGCONT)
    thread.join()
    r = result['r']
    row = {'deployment': name, 'stalled': target, 'stall_s': stall, 'completed': r.completed,
           'miss_pct': r.timing.get('miss_pct')}
    if r.bag_dir is not None and r.bag_dir.exists():
        row.update(_outcome(r.bag_dir))
    else:
        row.update(outcome='no bag', cause=r.message)
    return row


def _bursts() -> None:
    """Waves of process start-ups beside the graph (module docstring); returns when done."""
    for _ in range(BURST_WAVES):
        procs = [subprocess.Popen([sys.executable, '-c', _BURST_CODE]) for _ in range(BURST_SIZE)]
        for p in procs:
            p.wait()
        time.sleep(BURST_GAP)


def starvation(stalls=STALLS) -> list:
    rows = []
    for name, target in DEPLOYMENTS.items():
        for stall in stalls:
            _domain(40 + len(rows))
            row = _one(name, target, stall)
            rows.append(row)
            what = 'bursts beside' if stall == 'bursts' else f'stall {stall:4.1f} s of'
            print(f"{name:28s} {what} {target:20s} -> {row['outcome']:16s} "
                  f"({row.get('worst_state', '?')}) {row.get('cause', '')}", flush=True)
    return rows


def table(rows) -> str:
    """The markdown table: deployment x stall length -> outcome."""
    seen = {r['stall_s'] for r in rows}
    stalls = sorted(s for s in seen if s != 'bursts') + ['bursts'] * ('bursts' in seen)
    lines = ['| deployment (process stopped) | '
             + ' | '.join(s if s == 'bursts' else f'{s:g} s' for s in stalls) + ' |',
             '|---|' + '---|' * len(stalls)]
    for name in dict.fromkeys(r['deployment'] for r in rows):
        cells = {r['stall_s']: r['outcome'] for r in rows if r['deployment'] == name}
        target = next(r['stalled'] for r in rows if r['deployment'] == name)
        lines.append(f'| {name} ({target}) | '
                     + ' | '.join(cells.get(s, '') for s in stalls) + ' |')
    return '\n'.join(lines)
