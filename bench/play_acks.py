"""Benchmark: how long ``bag play --clock`` waits for acknowledgements (not a test).

Usage::

    ./irs exec python bench/play_acks.py [--pairs 3] [--domain 92]

A 0.4 s bag (400 ``PointStamped`` on ``/a``) is played ``--fast --clock --wait-for-subscribers
2`` into two reliable subscriptions of ``/a`` and two of ``/clock`` in this process, in
interleaved pairs: with the player's own Fast DDS profile (heartbeats every 50 ms,
``irs_bag/config/bag_play_fastdds.xml``) and with Fast DDS's defaults (an empty profile file
named in ``FASTRTPS_DEFAULT_PROFILES_FILE``, which the player then leaves alone: heartbeats
every 3 s). Per run it prints the time from the first message to the end of the playback
(the player's ``played ... in T s``: lead-in and schedule) and its wait for the
acknowledgements of every message at the end.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

EMPTY_PROFILE = ('<?xml version="1.0" encoding="UTF-8" ?>\n<profiles xmlns="http://www.eprosima.'
                 'com/XMLSchemas/fastRTPS_Profiles"></profiles>\n')


def make_bag(path: Path, n: int = 400) -> Path:
    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import serialize_message

    from irs_bag.writer import BagWriter
    with BagWriter(path) as w:
        for k in range(n):
            p = PointStamped()
            p.header.stamp.sec, p.header.stamp.nanosec = divmod(k * 10**6, 10**9)
            p.point.x = float(k)
            w.write('/a', 'geometry_msgs/msg/PointStamped', serialize_message(p),
                    5 * 10**9 + k * 10**6)
    return path


def subscribers():
    """Two reliable subscriptions each of /a and /clock, spun in a thread."""
    import rclpy
    from geometry_msgs.msg import PointStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    rclpy.init()
    node = rclpy.create_node('bench_play_acks')
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                     reliability=ReliabilityPolicy.RELIABLE)
    for _ in range(2):
        node.create_subscription(PointStamped, '/a', lambda m: None, qos, raw=True)
        node.create_subscription(Clock, '/clock', lambda m: None, qos, raw=True)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    return executor


def play_once(bag_exe: str, bag: Path, env: dict) -> dict:
    out = subprocess.run([bag_exe, 'play', str(bag), '--fast', '--clock', '--clock-from',
                          'header', '--wait-for-subscribers', '2'],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                         timeout=120).stdout
    played = re.search(r'played \d+ messages and \d+ /clock in ([\d.]+) s', out)
    acked = re.search(r'all messages acknowledged \(([\d.]+) ms\)', out)
    return {'playback_s': float(played.group(1)) if played else None,
            'end_acks_s': float(acked.group(1)) / 1e3 if acked else None,
            'lead_in_timed_out': 'not acknowledged' in out}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog='bench_play_acks', description=__doc__.split('\n')[0])
    ap.add_argument('--pairs', type=int, default=3)
    ap.add_argument('--domain', type=int, default=92)
    args = ap.parse_args(argv)
    os.environ['ROS_DOMAIN_ID'] = str(args.domain)
    from irs_bringup.executables import resolve_executable
    tmp = Path(tempfile.mkdtemp(prefix='irs_bench_acks_'))
    bag = make_bag(tmp / 'bag')
    empty = tmp / 'empty_profile.xml'
    empty.write_text(EMPTY_PROFILE)
    bag_exe = resolve_executable('irs_bag', 'bag')
    base = {k: v for k, v in os.environ.items()
            if k not in ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')}
    variants = {'player profile': base,
                'Fast DDS defaults': dict(base, FASTRTPS_DEFAULT_PROFILES_FILE=str(empty))}
    subscribers()
    rows = {name: [] for name in variants}
    for pair in range(args.pairs):
        for name, env in variants.items():
            r = play_once(bag_exe, bag, env)
            rows[name].append(r)
            print(f'pair {pair + 1} {name:18s}: playback {r["playback_s"]} s, acknowledgements '
                  f'at the end {r["end_acks_s"]} s, lead-in timed out: {r["lead_in_timed_out"]}',
                  flush=True)
    print(json.dumps(rows))
    os._exit(0)      # the subscribers' executor thread spins on


if __name__ == '__main__':
    sys.exit(main())
