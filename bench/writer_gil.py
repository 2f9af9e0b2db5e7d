"""A 1 kHz thread beside a bag's writer thread: how late its ticks come, and why (the GIL).

    ./irs exec flock /tmp/irs_bench.lock python bench/writer_gil.py [--seconds 12] [--rounds 2]

The main thread sleeps to each 1 ms tick and hands 13 messages of 300 bytes to a
:class:`irs_bag.writer.BagWriter` with ``background=True``, as the composed recorder does in a
real-time loop; the writer thread indexes and compresses each 1 MiB chunk. How late the ticks
come (over 0.5 ms and over 1 ms, p99, max) is compared, in interleaved rounds, with:

- ``no writer``: the same loop alone;
- ``C hog``: a thread hashing 1 MiB buffers without pause (CPU taken, the GIL released);
- ``Python hog``: a thread running Python bytecode without pause (the GIL held; a thread that
  wants it asks after the interpreter's switch interval, 5 ms);
- ``writer, switch 0.2 ms``: the writer with ``sys.setswitchinterval(200e-6)``;
- ``writer, N per chunk``: the writer with ``chunk_messages=N`` (256, 512 or 1024; a recorder
  in the loop's process has 512): mcap indexes a chunk in one call that holds the GIL about
  0.6 us per message.

``--cases`` picks some of them.

Each case runs in a process of its own (one JSON line each on stdout, a table at the end).
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import threading
import time

CASES = ('no writer', 'writer', 'C hog', 'Python hog', 'writer, switch 0.2 ms',
         'writer, 256 per chunk', 'writer, 512 per chunk', 'writer, 1024 per chunk')
TOPICS = 13
PAYLOAD = bytes(300)


def _c_hog():
    buf = bytes(1 << 20)
    while True:
        hashlib.sha256(buf).digest()


def _python_hog():
    x = 0
    while True:
        for i in range(1000):
            x += i


def run_case(case: str, seconds: float) -> dict:
    """Late ticks of a 1 kHz loop in this process, set up as ``case``."""
    from irs_bag.writer import BagWriter
    writer = None
    if case.startswith('writer'):
        writer = BagWriter(os.path.join(tempfile.mkdtemp(prefix='irs_gil_'), 'bag'),
                           background=True,
                           chunk_messages=(int(case.split()[1]) if case.endswith('per chunk')
                                           else None))
        for i in range(TOPICS):
            writer.add_topic(f'/t{i}', 'std_msgs/msg/String')
    if case == 'writer, switch 0.2 ms':
        sys.setswitchinterval(200e-6)
    if case in ('C hog', 'Python hog'):
        threading.Thread(target=_c_hog if case == 'C hog' else _python_hog, daemon=True).start()
    late = []
    period, t0 = 1_000_000, time.monotonic_ns()
    for k in range(1, int(seconds * 1000) + 1):
        due = t0 + k * period
        now = time.monotonic_ns()
        while now < due:
            time.sleep((due - now) / 1e9)
            now = time.monotonic_ns()
        late.append(now - due)
        if writer is not None:
            for i in range(TOPICS):
                writer.write(f'/t{i}', 'std_msgs/msg/String', PAYLOAD, now)
    if writer is not None:
        writer.close()
    late.sort()
    n = len(late)
    return {'case': case, 'ticks': n,
            'late_over_0_5ms_pct': 100.0 * sum(x > 500_000 for x in late) / n,
            'late_over_1ms_pct': 100.0 * sum(x > 1_000_000 for x in late) / n,
            'p99_us': late[int(0.99 * n)] / 1e3, 'max_us': late[-1] / 1e3}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--seconds', type=float, default=12.0, help='per case (default 12)')
    ap.add_argument('--rounds', type=int, default=2, help='interleaved rounds (default 2)')
    ap.add_argument('--cases', nargs='+', choices=CASES, default=list(CASES),
                    help='the cases to run (default: all)')
    ap.add_argument('--case', choices=CASES, help=argparse.SUPPRESS)   # a child's one case
    args = ap.parse_args(argv)
    if args.case:
        print(json.dumps(run_case(args.case, args.seconds)), flush=True)
        return 0
    rows = []
    for _ in range(args.rounds):
        for case in args.cases:
            out = subprocess.run([sys.executable, __file__, '--case', case, '--seconds',
                                  str(args.seconds)], capture_output=True, text=True, check=True)
            rows.append(json.loads(out.stdout.splitlines()[-1]))
            print(out.stdout.strip(), flush=True)
    print(f"{'case':24s} {'late > 0.5 ms':>14s} {'> 1 ms':>8s} {'p99':>9s} {'max':>9s}")
    for r in rows:
        print(f"{r['case']:24s} {r['late_over_0_5ms_pct']:12.2f} % {r['late_over_1ms_pct']:6.2f} %"
              f" {r['p99_us']:6.0f} us {r['max_us']:6.0f} us")
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
