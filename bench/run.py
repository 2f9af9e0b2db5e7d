"""The IRS benchmark suite: every figure next to its floor, measured in the same run.

    ./irs exec python bench/run.py                 # everything (about 10 min on 2 cores)
    ./irs exec python bench/run.py --quick         # shorter runs (about 4 min), noisier figures
    ./irs exec python bench/run.py --only floor lockstep
    ./irs exec python bench/run.py --only soak      # the 10-minute soak (not in the default)

Sections (each a function below; results go to ``bench/results/<time>.json`` and a table):

- ``floor``: the minimal 3-hop loop (bench/floor.py) with rclpy's SingleThreadedExecutor, a raw
  wait set, our LeanExecutor, and the lean loop composed in one process: lock-step steps/s and
  CPU per hop; real time 1 kHz deadline misses and loop latency;
- ``realtime``: the Figure 10 graph in real time at 1 kHz (``realtime_figure10`` and its
  composed twin), recorder on, with and without SCHED_FIFO: deadline misses, loop latency (arm
  sample published -> steering command received by the rig), per-topic rates and losses from the
  bag, CPU per step per process; the torque car composed (``realtime_torque_car_composed``,
  no SCHED_FIFO: the steering command answers the encoder sample of the same step);
- ``lockstep``: Figure 10 in lock-step, process per node and composed: multiple of real time,
  CPU per step, and whether the two bags carry identical messages;
- ``offline`` (bench/offline.py): the offline twin of the graph in steps/s (the fastest of 3
  runs) against a vectorised linear reference: the identified plant stepped by our core and by
  ``scipy.signal.dlsim``;
- ``replay``: ``bag play`` timing error at 1x, what the recorder keeps of 13 topics x 1 kHz and
  its CPU per message (replay);
- ``startup`` (bench/startup.py): each Figure 10 node's start-up, the interpreter's start to the
  node built, CPU and wall time, with OpenBLAS's thread pool as the environment sets it and with
  the library's default, alternating sample by sample;
- ``sweep``: bench/sweep.py -- points/s of 12 points of the actuator x speed sweep serially and
  on 1 and 2 Dask workers, and 100 linear plants stepped at once (BatchLti) against dlsim;
- ``hil`` (bench/hil.py): real time at 1 kHz through the emulated board's link and drive, next
  to ``vehicle_sim`` in the same run: deadline misses, ADC-sample-to-servo latency, frames lost;
- ``soak`` (only with ``--only soak [--soak-deployments recorder per_node]``, 10 min each):
  ``soak_realtime`` with SCHED_FIFO 50 and the recorder on, (a) the loop composed and the
  standalone recorder in its own process, (b) process per node: misses, latency, CPU per process
  (the recorder's included), and the messages the bag kept and lost;
- ``starvation`` (only with ``--only starvation``, about 8 min; bench/starvation.py): one process
  of each real-time deployment stopped for 0.2-5 s: car kept, controlled stop or lost;
- ``soak_hour`` (only with ``--only soak_hour [--soak-minutes N]``; bench/soak_hour.py): the
  composed real-time graph with the recorder for an hour, memory per process every minute;
- ``waits`` (only with ``--only waits [--waits-test]``; bench/waits.py): what a user waits for,
  timed as a user meets it: ``make demo`` on a clean clone of HEAD, the paper's figures
  (``make figures`` into a temporary folder), ``make test`` if asked, and a plain-Python floor.

Every run ends with the project's speed targets (bench/targets.py) that its sections measured,
each next to its floor from the same run.

Speed is measured here, never asserted in tests. Timing figures are noisy on a shared 2-core
machine: compare ratios within one run (the floor is in the same JSON).
"""
import argparse
import datetime
import json
import os
from pathlib import Path
import sys
import tempfile

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import domain as _domain, write_results   # noqa: E402 (bench/ is on sys.path)
from offline import offline  # noqa: E402,F401 (a section, called by name)
import targets as bench_targets  # noqa: E402 (bench/targets.py)

SECTIONS = ('floor', 'realtime', 'lockstep', 'offline', 'startup', 'replay', 'sweep', 'hil')
#: Sections run only when named with ``--only``.
EXTRA_SECTIONS = ('soak', 'starvation', 'soak_hour', 'waits')


def floor(seconds: float) -> list:
    import floor as fl
    rows = []
    for clock in ('lockstep', 'realtime'):
        for mode, composed in (('single', False), ('waitset', False), ('lean', False),
                               ('lean', True)):
            _domain(len(rows))
            r = fl.run(mode, clock, composed, seconds)
            r['name'] = f"floor {mode}{' composed' if composed else ''} {clock}"
            rows.append(r)
            print(_floor_line(r), flush=True)
    return rows


def _floor_line(r) -> str:
    return (
        f'{r["name"]:34s} {r["steps_per_s"]:8.0f} steps/s  {r["cpu_per_hop_us"]:6.0f} us CPU/hop'
        f'  misses {r["miss_pct"]:5.2f} %  latency p50/p99 {r["latency_p50_ms"]:.3f}/'
        f'{r["latency_p99_ms"]:.3f} ms'
    )


def _bag_figures(bag_dir) -> dict:
    """Per-topic message counts and rates, and the losses the recorder counted."""
    from irs_bag.reader import BagReader
    with BagReader(bag_dir) as reader:
        custom = (reader.bag_metadata or {}).get('custom_data') or {}
        topics = {name: {'count': info.message_count, 'rate_hz': info.rate_hz}
                  for name, info in sorted(reader.topics.items())}
    return {'topics': topics, 'dropped_total': int(custom.get('irs.dropped_messages', 0) or 0)}


def _run_experiment(path_or_name, rt_priority=0, duration=None, runs_dir=None, composed=False):
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner
    exp = path_or_name if not isinstance(path_or_name, str) else load_experiment(path_or_name)
    if composed:
        exp = exp.composed()
    if duration is not None:
        exp.duration = float(duration)
    runner = ExperimentRunner(exp, runs_dir=runs_dir or tempfile.mkdtemp(prefix='irs_bench_'),
                              progress=False, rt_priority=rt_priority, log=lambda *_: None)
    return runner.run()


def _realtime_row(label: str, r) -> dict:
    """One real-time run's figures (timing, CPU per step, the bag's rates and losses); printed."""
    steps = r.timing.get('steps') or 1
    row = {'name': label, 'completed': r.completed, 'message': r.message,
           'safe_stop': r.safe_stop, **r.timing,
           'cpu_per_step_us': {k: 1e6 * v / steps for k, v in r.cpu.items()},
           'cpu_total_per_step_us': 1e6 * sum(r.cpu.values()) / steps}
    if r.bag_dir is not None and r.bag_dir.exists():
        row['bag'] = _bag_figures(r.bag_dir)
    verdict = 'FAILED' if not r.completed else 'STOPPED' if r.safe_stop else 'ok '
    print(f"{row['name']:40s} {verdict} misses "
          f"{row.get('miss_pct', float('nan')):6.2f} %  latency p50/p99/max "
          f"{row.get('latency_p50_ms', float('nan')):.2f}/"
          f"{row.get('latency_p99_ms', float('nan')):.2f}/"
          f"{row.get('latency_max_ms', float('nan')):.1f} ms  CPU "
          f"{row['cpu_total_per_step_us']:.0f} us/step", flush=True)
    if 'bag' in row:
        total = sum(t['count'] for t in row['bag']['topics'].values())
        print(f"    bag: {total} messages, {row['bag']['dropped_total']} lost", flush=True)
    if not r.completed:
        print(f'    {r.message}', flush=True)
    elif r.safe_stop:
        print(f'    the rig stopped the car under control at {r.safe_stop}', flush=True)
    return row


def realtime(seconds: float) -> list:
    rows = []
    for name in ('realtime_figure10', 'realtime_figure10_composed'):
        for prio in (0, 50):
            _domain(10 + len(rows))
            r = _run_experiment(name, prio, seconds)
            rows.append(_realtime_row(f"{name}{' SCHED_FIFO' if prio else ''}", r))
    _domain(10 + len(rows))
    r = _run_experiment('realtime_torque_car_composed', 0, seconds)
    rows.append(_realtime_row('realtime_torque_car_composed', r))
    return rows


def soak(deployments=('recorder', 'per_node')) -> list:
    """``soak_realtime`` for 10 minutes at 1 kHz, recorder on, SCHED_FIFO 50.

    Not in the default sections (``--only soak``). Two deployments:

    - ``recorder``: the five nodes composed in one process and the standalone recorder in its
      own process, so that every recorded message crosses DDS: what the recorder keeps and costs;
    - ``per_node``: one process per node and the recorder (the debugging deployment).
    """
    from dataclasses import replace

    from irs_bringup.experiment import load_experiment
    rows = []
    for deployment in deployments:
        _domain(30 + len(rows))
        exp = load_experiment('soak_realtime')
        if deployment == 'recorder':
            exp = replace(exp.composed('loop'), record_process=None)
            label = 'soak_realtime composed, recorder apart, SCHED_FIFO (600 s)'
        else:
            label = 'soak_realtime process per node SCHED_FIFO (600 s)'
        r = _run_experiment(exp, 50)
        rows.append(_realtime_row(label, r))
    return rows


def _message_class(type_name: str):
    """``'pkg/msg/Type'`` -> the message class."""
    import importlib
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def _messages(bag_dir) -> dict:
    """``{topic: sorted distinct message reprs}``: what 'identical bags' compares.

    Every field of every decoded message (floats exactly: ``repr`` round-trips to the same bits);
    not the CDR bytes, whose alignment padding Fast DDS leaves uninitialised. Receive times
    differ from run to run by nature; a lock-step resend (the rig publishing a step again after
    ``lockstep_resend_period`` without progress) records identical duplicates, which are one
    message of the run's data.
    """
    from rclpy.serialization import deserialize_message
    from irs_bag.reader import BagReader
    out = {}
    with BagReader(bag_dir) as reader:   # fields, not CDR bytes: padding bytes are arbitrary
        types = {name: _message_class(info.type) for name, info in reader.topics.items()}
        for m in reader.messages():
            msg = deserialize_message(bytes(m.data), types[m.topic])
            out.setdefault(m.topic, set()).add(repr(msg))
    return {t: sorted(v) for t, v in out.items()}


def lockstep() -> list:
    rows, bags = [], {}
    for label, composed in (('process per node', False), ('composed (recorder too)', True)):
        _domain(30 + len(rows))
        r = _run_experiment('figure10_mrc_with_actuator', composed=composed)
        steps = r.sim_time / 0.001
        row = {'name': f'lock-step Figure 10, {label}', 'completed': r.completed,
               'sim_time_s': r.sim_time, 'running_time_s': r.running_time,
               'x_real_time': r.sim_time / r.running_time,
               'cpu_per_step_us': {k: 1e6 * v / steps for k, v in r.cpu.items()},
               'cpu_total_per_step_us': 1e6 * sum(r.cpu.values()) / steps}
        rows.append(row)
        bags[label] = r.bag_dir
        print(f"{row['name']:40s} {row['x_real_time']:5.2f}x real time  CPU "
              f"{row['cpu_total_per_step_us']:.0f} us/step", flush=True)
    a, b = (_messages(p) for p in bags.values())
    same = a == b
    rows.append({'name': 'lock-step bags identical (per topic, message bytes)', 'identical': same,
                 'topics': len(a)})
    print(f'lock-step bags identical across deployments: {same} ({len(a)} topics)', flush=True)
    return rows


def replay(seconds: float) -> list:
    import contextlib
    import io
    import replay as bench_replay    # bench/replay.py
    _domain(50)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        bench_replay.main(['--topics', '13', '--hz', '1000', '--seconds', str(seconds),
                           '--rates', '1', '--domain', os.environ['ROS_DOMAIN_ID']])
    lines = buf.getvalue().strip().splitlines()
    for line in lines[:-1]:
        print('    ' + line, flush=True)
    rows = json.loads(lines[-1])['rows']
    return [{'name': 'replay 1x + recorder, 13 topics x 1 kHz', 'rate': r[0],
             'timing_error_ms': {'mean': r[1][0], 'p99': r[1][1], 'max': r[1][2]},
             'recorded': r[2], 'drops_reported': r[3], 'duration_s': r[4],
             'recorder_cpu_us_per_message': r[5]} for r in rows]


def startup() -> list:
    import startup as bench_startup   # bench/startup.py: each node's start-up CPU and wall time
    _domain(60)
    return bench_startup.startup()


def hil(seconds: float) -> list:
    import hil as bench_hil       # bench/hil.py: the emulated link next to vehicle_sim
    return bench_hil.hil(seconds, _run_experiment, _realtime_row)


def starvation() -> list:
    import starvation as bench_starvation    # bench/starvation.py
    rows = bench_starvation.starvation()
    print(bench_starvation.table(rows), flush=True)
    return rows


def soak_hour(minutes: float) -> list:
    import soak_hour as bench_soak            # bench/soak_hour.py
    return [bench_soak.soak(minutes)]


def waits(with_test: bool) -> list:
    import waits as bench_waits   # bench/waits.py: make demo, figures (make test if asked)
    return bench_waits.waits(with_test)


def sweep() -> list:
    import sweep as bench_sweep   # bench/sweep.py: points/s on 1 and 2 Dask workers, BatchLti
    return bench_sweep.sweep_rates(12, None) + bench_sweep.offline(100)


def _interpreter() -> dict:
    """The interpreter the figures are of: a distribution's build and a default pyenv build
    differ by about 15 % in the offline loop (docs/setup.md#requirements).
    """
    import platform
    return {'version': platform.python_version(), 'base_prefix': sys.base_prefix,
            'executable': sys.executable}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--quick', action='store_true', help='shorter runs (noisier figures)')
    ap.add_argument('--only', nargs='+', choices=SECTIONS + EXTRA_SECTIONS, default=list(SECTIONS),
                    help='sections to run (default: all but soak, a 10-minute run)')
    ap.add_argument('--out', default=str(HERE / 'results'), help='folder for the JSON file')
    ap.add_argument('--soak-minutes', type=float, default=60.0,
                    help='length of the soak_hour run [min] (default 60)')
    ap.add_argument('--waits-test', action='store_true',
                    help='waits: also time make test in the clean clone (15-25 min)')
    ap.add_argument('--soak-deployments', nargs='+', choices=('recorder', 'per_node'),
                    default=['recorder', 'per_node'],
                    help='deployments of the 10-minute soak (default both)')
    a = ap.parse_args(argv)
    floor_s, rt_s, replay_s = (5.0, 20.0, 3.0) if a.quick else (10.0, 60.0, 5.0)
    results = {'started': datetime.datetime.now().isoformat(timespec='seconds'),
               'cpus': os.cpu_count(), 'load_before': os.getloadavg(), 'quick': a.quick,
               'python': _interpreter()}
    for section in a.only:
        print(f'== {section}', flush=True)
        fn = globals()[section]
        args = {'floor': (floor_s,), 'realtime': (rt_s,), 'replay': (replay_s,),
                'hil': (rt_s / 2,), 'soak_hour': (a.soak_minutes,),
                'soak': (a.soak_deployments,), 'waits': (a.waits_test,)}.get(section, ())
        results[section] = fn(*args)
    text, results['targets'] = bench_targets.table(results)
    if results['targets']:
        print('== targets (each next to its floor, this run)\n' + text, flush=True)
    write_results(results, a.out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
