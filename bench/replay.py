"""Benchmark: ``bag play`` timing error and what the ``recorder`` sustains (not a test).

Usage::

    ./irs exec python -m replay [--topics 8] [--hz 1000] [--seconds 3]
                                                  [--rates 1 2 4] [--domain 91]

For every rate factor R it writes nothing new: one synthetic bag (``--topics`` JointState topics
``/bench/t<i>`` at ``--hz`` Hz for ``--seconds`` s, 8 x 1 kHz by default) is played with
``bag play --rate R`` (= topics x hz x R messages/s) into a ``recorder`` process
(``topics: ['/bench/*']``), and the benchmark prints

- the player's timing error (|actual - due| mean / p99 / max in ms, measured by the player),
- messages published vs. recorded, drops the recorder reported, and the recorded rate;
- the recorder's CPU (user + system time of its process, start-up and discovery included) per
  offered message.

Uses its own ROS_DOMAIN_ID (``--domain``) and a temporary directory.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path


def make_bench_bag(path, topics: int, hz: int, seconds: float) -> int:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from irs_bag.writer import BagWriter

    n = int(hz * seconds)
    dt = int(round(1e9 / hz))
    with BagWriter(path) as w:
        for k in range(n):
            for i in range(topics):
                js = JointState()
                js.header.stamp.sec, js.header.stamp.nanosec = divmod(k * dt, 10**9)
                js.name = ['a', 'b', 'c']
                js.position = [k * 1e-3, float(i), 0.5]
                w.write(f'/bench/t{i}', 'sensor_msgs/msg/JointState', serialize_message(js),
                        10**9 + k * dt + i * 1000)
    return n * topics


def _cpu_s(pid: int) -> float:
    """User + system CPU time [s] of process ``pid`` so far (``/proc/<pid>/stat``)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def run(args) -> int:
    from irs_bag.reader import BagReader
    from irs_bringup.executables import resolve_executable

    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain))
    os.environ['ROS_DOMAIN_ID'] = str(args.domain)
    tmp = Path(tempfile.mkdtemp(prefix='irs_bench_'))
    src = tmp / 'source'
    total = make_bench_bag(src, args.topics, args.hz, args.seconds)
    print(f'bench: {args.topics} topics x {args.hz} Hz x {args.seconds} s = {total} messages '
          f'({tmp})', flush=True)
    bag_exe = resolve_executable('irs_bag', 'bag')
    rec_exe = resolve_executable('irs_bag', 'recorder')
    rows = []
    for rate in args.rates:
        out = tmp / f'rec_{rate:g}'
        rec = subprocess.Popen([rec_exe, '--ros-args', '-p', f'output:={out}',
                                '-p', "topics:=['/bench/*']", '-p', 'status_period:=0.2'],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               env=env, start_new_session=True)
        try:
            # the player waits until the recorder matched every topic
            play = subprocess.run([bag_exe, 'play', str(src), '--rate', f'{rate:g}',
                                   '--wait-for-subscribers', '1', '--quiet'],
                                  capture_output=True, text=True, env=env, timeout=600)
            cpu = _cpu_s(rec.pid)
        finally:
            rec.send_signal(2)
            rec_out, _ = rec.communicate(timeout=60)
        line = play.stdout.strip().splitlines()[-1] if play.stdout.strip() else play.stderr
        m = re.search(r'mean ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms', line)
        with BagReader(out) as r:
            got = r.message_count
            dur = r.duration_ns * 1e-9
            drops = r.bag_metadata['custom_data'].get('irs.dropped_messages', '?')
        rows.append((rate, m.groups() if m else ('?', '?', '?'), got, drops, dur,
                     1e6 * cpu / total))
        print(f'rate {rate:g}x ({args.topics * args.hz * rate:.0f} msg/s offered): timing error '
              f'mean {rows[-1][1][0]} ms, p99 {rows[-1][1][1]} ms, max {rows[-1][1][2]} ms; '
              f'recorded {got}/{total}, drops reported {drops}, '
              f'{got / dur if dur else 0:.0f} msg/s over {dur:.2f} s; recorder CPU '
              f'{rows[-1][5]:.1f} us per message', flush=True)
        if rec.returncode != 0:
            print(f'recorder exited {rec.returncode}:\n{rec_out[-2000:]}', flush=True)
    print(json.dumps({'rows': rows}))
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog='bench_replay', description=__doc__.split('\n')[0])
    p.add_argument('--topics', type=int, default=8)
    p.add_argument('--hz', type=int, default=1000)
    p.add_argument('--seconds', type=float, default=3.0)
    p.add_argument('--rates', type=float, nargs='+', default=[1.0, 2.0, 4.0])
    p.add_argument('--domain', type=int, default=91)
    return run(p.parse_args(argv))


if __name__ == '__main__':
    sys.exit(main())
