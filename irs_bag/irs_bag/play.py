"""``bag play <bag>``: publish the recorded CDR bytes again, with the recorded timing.

Usage::

    bag play BAG [--rate R | --fast] [--pace {auto,header,log}] [--topics T ...]
                 [--remap OLD:=NEW ...] [--start-offset S] [--loop]
                 [--clock [--clock-from {auto,log,header}]]
                 [--wait-for-subscribers N | --paused-until-matched] [--wait-timeout S]
                 [--qos-depth D] [--quiet] [--dry-run] [--ros-args ...]

- Each topic gets a publisher of its recorded type (RELIABLE, KEEP_LAST ``--qos-depth``
  (default 1000), VOLATILE; TRANSIENT_LOCAL if every recorded publisher of the topic was) and
  the recorded bytes are published as they are (``Publisher.publish(bytes)`` ->
  ``publish_raw`` in rclpy 7.1.6): no deserialization, byte-for-byte identical.
- Timing: message i is due at ``wall_start + (t_i - t_first) / rate`` (an absolute schedule,
  errors do not accumulate); the player sleeps until ~0.3 ms before the due time and spins the
  rest. ``--rate 0`` / ``--fast``: as fast as possible. At the end it prints the timing error
  statistics (mean / p99 / max of ``actual - due`` over all messages).
- Time line ``t_i`` (``--pace``): ``log`` = the receive (log) time; ``header`` = simulation
  time: the running maximum of the ``header.stamp`` (or leading ``builtin_interfaces/Time``)
  of the played messages and of the bag's ``/clock`` messages, so a message without a stamp
  plays right after the one before it. ``auto`` (default) = ``header`` for a lock-step bag
  (it has ``/clock``, or its ``irs_experiment`` metadata holds an experiment yaml with
  ``clock: lockstep``), else ``log``. In a lock-step run the receive times are stretched or
  compressed by how fast the graph stepped; the stamps are the simulated time, so
  ``--rate 1`` plays N s of simulated time in N s. ``--start-offset`` is in log time.
- ``--clock``: publishes ``/clock`` (rosgraph_msgs/Clock) right before each message whose time
  is later than the last clock published, with that time, so consumers running on sim time see
  exactly the data's time line (no coarse bursts). ``--clock-from log`` uses the log
  (receive) time, ``--clock-from header`` the header time line above; ``auto`` (default)
  follows ``--pace``. A recorded ``/clock`` topic is then not played (the player's replaces
  it).
- ``--wait-for-subscribers N``: start (at t_first) only once every played publisher (and /clock
  with ``--clock``) has matched at least N subscriptions, so no leading message is lost with
  reliable subscribers. ``--paused-until-matched`` = ``--wait-for-subscribers 1``.
- The played messages are read into memory before playback starts (memory ~ the selection's
  uncompressed size), so chunk decompression never delays a message.
- At the end the player waits (<= 10 s) until every reliable subscriber acknowledged every
  message (``Publisher.wait_for_all_acked``) before it exits.

An unfinished or damaged bag plays its readable part (one warning line on stderr).
Exit codes: 0 ok (also after Ctrl-C), 1 timeout waiting for subscribers, 2 unreadable bag
(one line naming the file and what is wrong) or usage error (e.g. unknown topic).
"""
from __future__ import annotations

import argparse
import importlib
import struct
import sys
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import yaml

from .reader import BagError, BagMessage, BagReader, open_bag

__all__ = ['main', 'stamp_reader', 'TimingStats', 'Plan', 'prepare', 'lockstep_reason']

_SPIN_S = 0.0003


class UsageError(Exception):
    """Bad option values (exit code 2)."""


def _first_field_type(definition: str) -> str:
    for line in definition.splitlines():
        s = line.split('#', 1)[0].strip()
        if not s:
            continue
        if s.startswith('=' * 10):
            break
        parts = s.split()
        if len(parts) >= 2 and '=' not in parts[1] and '=' not in parts[0]:
            return parts[0]
    return ''


def stamp_reader(definition: str):
    """A function ``data -> stamp_ns`` reading the leading Header/Time of a CDR message, or None.

    Both ``std_msgs/Header`` and ``builtin_interfaces/Time`` start with ``int32 sec, uint32
    nanosec`` right after the 4-byte CDR encapsulation header.
    """
    first = _first_field_type(definition)
    if first not in ('std_msgs/Header', 'std_msgs/msg/Header', 'Header',
                     'builtin_interfaces/Time', 'builtin_interfaces/msg/Time'):
        return None

    def read(data: bytes) -> Optional[int]:
        if len(data) < 12:
            return None
        fmt = '<iI' if data[1] & 1 else '>iI'
        sec, nsec = struct.unpack_from(fmt, data, 4)
        return sec * 1_000_000_000 + nsec
    return read


class TimingStats:
    """Accumulates ``actual - due`` publication errors [s]."""

    def __init__(self):
        self.errors: List[float] = []

    def add(self, err_s: float) -> None:
        self.errors.append(err_s)

    def summary(self) -> Dict[str, float]:
        if not self.errors:
            return {'n': 0, 'mean_ms': 0.0, 'p99_ms': 0.0, 'max_ms': 0.0, 'mean_signed_ms': 0.0}
        a = sorted(abs(e) for e in self.errors)
        n = len(a)
        return {'n': n, 'mean_ms': 1e3 * sum(a) / n,
                'p99_ms': 1e3 * a[min(n - 1, int(0.99 * n))], 'max_ms': 1e3 * a[-1],
                'mean_signed_ms': 1e3 * sum(self.errors) / n}


def _import_type(type_name: str):
    pkg, sub, name = type_name.split('/')
    return getattr(importlib.import_module(f'{pkg}.{sub}'), name)


def _parse_remaps(items) -> Dict[str, str]:
    out = {}
    for item in items or []:
        if ':=' not in item:
            raise UsageError(f'--remap expects OLD:=NEW, got {item!r}')
        old, new = item.split(':=', 1)
        old, new = old.strip(), new.strip()
        if not old or not new:
            raise UsageError(f'--remap expects OLD:=NEW, got {item!r}')
        out[old if old.startswith('/') else '/' + old] = new if new.startswith('/') else '/' + new
    return out


def lockstep_reason(reader: BagReader) -> Optional[str]:
    """Why ``reader``'s bag is a lock-step recording (header stamps = sim time), or None."""
    if '/clock' in reader.topics:
        return 'it has /clock'
    try:
        records = reader.metadata_records()
    except BagError:
        return None
    for name, data in records:
        if name != 'irs_experiment' or 'experiment_yaml' not in data:
            continue
        try:
            doc = yaml.safe_load(data['experiment_yaml'])
        except yaml.YAMLError:
            continue
        if isinstance(doc, dict) and doc.get('clock') == 'lockstep':
            return 'recorded in a lockstep experiment'
    return None


def _pace_times(msgs: List[BagMessage], stamp_of, clock_msgs: List[BagMessage]) -> List[int]:
    """The header time line [ns] of ``msgs``: running max of their stamps and /clock's."""
    clock_read = stamp_reader('builtin_interfaces/Time clock')
    merged = sorted([(m.log_time_ns, 0, i, m) for i, m in enumerate(clock_msgs)]
                    + [(m.log_time_ns, 1, i, m) for i, m in enumerate(msgs)],
                    key=lambda x: x[:3])
    cursor, out = None, [None] * len(msgs)
    for _, kind, i, m in merged:
        f = clock_read if kind == 0 else stamp_of.get(m.topic)
        s = f(m.data) if f is not None else None
        # a stamp hours ahead is another time base (e.g. wall clock): not the sim time line
        if s is not None and (cursor is None or cursor < s < cursor + 3600 * 10**9):
            cursor = s
        if kind == 1:
            out[i] = cursor
    first = next((t for t in out if t is not None), None)
    return [first if t is None else t for t in out] if first is not None else []


@dataclass
class Plan:
    """What to play, read before ROS starts: messages, their time line [ns], publishers."""

    wanted: List[str]
    todo: List[BagMessage]
    times: List[int]
    pace: str                    # 'log' or 'header'
    clock_from: str              # 'log' or 'header'
    why: str = ''                # why this pace was chosen
    types: Dict[str, type] = field(default_factory=dict)
    infos: Dict[str, object] = field(default_factory=dict)
    remaps: Dict[str, str] = field(default_factory=dict)
    rate: float = 1.0
    n_wait: int = 0
    message_count: int = 0
    clock_times: List[int] = field(default_factory=list)   # /clock values [ns]


def prepare(args, stream=None) -> Plan:
    """Check the options and read everything to play (no rclpy); UsageError / BagError."""
    rate = 0.0 if args.fast else args.rate
    if rate < 0 or rate != rate:
        raise UsageError(f'--rate must be >= 0, got {args.rate}')
    if args.start_offset < 0:
        raise UsageError(f'--start-offset must be >= 0 s, got {args.start_offset}')
    n_wait = max(args.wait_for_subscribers, 1 if args.paused_until_matched else 0)
    remaps = _parse_remaps(args.remap)
    with open_bag(args.bag, 'bag play', stream) as reader:
        infos = reader.topics
        schemas = reader.schemas
        if args.topics:
            wanted = [t if t.startswith('/') else '/' + t for t in args.topics]
            unknown = [t for t in wanted if t not in infos]
            if unknown:
                raise UsageError(f'topic(s) not in the bag: {", ".join(unknown)} '
                                 f'(it has: {", ".join(sorted(infos)) or "none"})')
        else:
            wanted = sorted(infos)
        if args.clock:
            wanted = [t for t in wanted if t != '/clock']
        for old in remaps:
            if old not in wanted:
                raise UsageError(f'--remap: topic {old} is not played')
        why = lockstep_reason(reader) if args.pace == 'auto' else '--pace ' + args.pace
        pace = ('header' if why else 'log') if args.pace == 'auto' else args.pace
        plan = Plan(wanted, [], [], pace, pace if args.clock_from == 'auto' else args.clock_from,
                    why or 'not a lock-step bag', {}, infos, remaps, rate, n_wait,
                    reader.message_count)
        if not wanted or reader.message_count == 0:
            return plan
        for t in wanted:
            try:
                plan.types[t] = _import_type(infos[t].type)
            except (ImportError, AttributeError, ValueError):
                raise BagError(f'type {infos[t].type!r} of {t} is not installed') from None
        stamp_of = {t: stamp_reader(schemas.get(infos[t].type, '')) for t in wanted}
        t_first = reader.start_time_ns + int(round(args.start_offset * 1e9))
        # Everything to play is read (and decompressed) before the clock starts: reading MCAP
        # chunks while playing costs tens of ms per chunk in Python and shows as timing error.
        header = 'header' in (plan.pace, plan.clock_from)
        read = wanted + (['/clock'] if header and '/clock' in infos and '/clock' not in wanted
                         else [])
        clock_msgs, hdr = [], []
        for m in reader.messages(read):
            if m.log_time_ns < t_first:
                continue
            if m.topic in plan.types:
                plan.todo.append(m)
            else:
                clock_msgs.append(m)
        if header:
            if '/clock' in plan.types:
                clock_msgs = [m for m in plan.todo if m.topic == '/clock']
            hdr = _pace_times(plan.todo, stamp_of, clock_msgs)
            if not hdr and plan.todo:
                print('bag play: warning: no message of the selection has a header stamp; '
                      'pacing by log time', file=stream or sys.stderr)
                plan.pace = plan.clock_from = 'log'
        plan.times = hdr if plan.pace == 'header' else [m.log_time_ns for m in plan.todo]
        plan.clock_times = hdr if plan.clock_from == 'header' else plan.times
    return plan


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='bag play', description='Replay a rosbag2 MCAP bag onto its topics.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--rate', type=float, default=1.0,
                   help='playback rate factor (default 1.0; 0 = as fast as possible)')
    p.add_argument('--fast', action='store_true', help='as fast as possible (= --rate 0)')
    p.add_argument('--pace', choices=('auto', 'header', 'log'), default='auto',
                   help='time line: header stamps (sim time), log (receive) times, or auto: '
                        'header for lock-step bags, else log (default)')
    p.add_argument('--topics', nargs='+', metavar='T', help='play only these topics')
    p.add_argument('--remap', nargs='+', metavar='OLD:=NEW', default=[],
                   help='publish topic OLD on NEW')
    p.add_argument('--start-offset', type=float, default=0.0, metavar='S',
                   help='skip the first S seconds (log time) of the bag')
    p.add_argument('--loop', action='store_true', help='play again and again (until Ctrl-C)')
    p.add_argument('--clock', action='store_true',
                   help="publish /clock at the played messages' times")
    p.add_argument('--clock-from', choices=('auto', 'log', 'header'), default='auto',
                   help='time source for /clock: log (receive) time, header time line, or '
                        'auto: as --pace (default)')
    p.add_argument('--wait-for-subscribers', type=int, default=0, metavar='N',
                   help='start only once every played topic has N matched subscribers')
    p.add_argument('--paused-until-matched', action='store_true',
                   help='same as --wait-for-subscribers 1')
    p.add_argument('--wait-timeout', type=float, default=60.0, metavar='S',
                   help='give up waiting for subscribers after S seconds (exit 1)')
    p.add_argument('--qos-depth', type=int, default=1000, help='publisher KEEP_LAST depth')
    p.add_argument('--quiet', action='store_true', help='only print the final summary')
    p.add_argument('--dry-run', action='store_true',
                   help='read and check everything, print the plan, publish nothing')
    return p


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag play``; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args: List[str] = []
    if '--ros-args' in argv:
        i = argv.index('--ros-args')
        argv, ros_args = argv[:i], argv[i:]
    args = build_parser().parse_args(argv)
    try:
        plan = prepare(args)
    except (UsageError, BagError, OSError) as exc:
        print(f'bag play: error: {exc}', file=sys.stderr)
        return 2
    if not plan.todo:
        print('bag play: nothing to play (no messages)')
        return 0
    if not args.quiet or args.dry_run:
        line = 'header stamps (sim time)' if plan.pace == 'header' else 'log (receive) times'
        span = (plan.times[-1] - plan.times[0]) * 1e-9
        print(f'bag play: pacing by {line} ({plan.why}); {len(plan.todo)} messages on '
              f'{len(plan.wanted)} topics spanning {span:.3f} s', flush=True)
    if args.dry_run:
        return 0
    return _run_ros(args, ros_args, plan)


def _run_ros(args, ros_args, plan: Plan) -> int:
    import rclpy
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    from builtin_interfaces.msg import Time
    from rclpy.duration import Duration
    # Ctrl-C (SIGINT): rclpy's handler shuts the context down and a KeyboardInterrupt follows;
    # a publish racing with the shutdown fails with "publisher's context is invalid", which
    # is the same interruption (below). (Without rclpy's handler, a player loaded on a busy
    # machine was seen not to stop within 10 s of SIGINT.)
    rclpy.init(args=['bag_play', *ros_args])
    node = rclpy.create_node('bag_player')
    log = (lambda *a: None) if args.quiet else (lambda s: print(s, flush=True))
    stats = TimingStats()
    rate, n_wait, infos, todo = plan.rate, plan.n_wait, plan.infos, plan.todo
    played = 0
    clocks = 0
    loops = 0
    interrupted = False
    try:
        pubs = {}
        for t in plan.wanted:
            latched = 'transient_local' in (infos[t].offered_qos_profiles or '') and \
                'volatile' not in (infos[t].offered_qos_profiles or '')
            # When subscribers are waited for, keep the whole selection in the writer's history:
            # a reader whose side of the match completes just after ours can still get every
            # message by retransmission, even from an --fast burst.
            depth = max(1, args.qos_depth, infos[t].message_count if n_wait > 0 else 0)
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                         else DurabilityPolicy.VOLATILE))
            pubs[t] = node.create_publisher(plan.types[t], plan.remaps.get(t, t), qos)
        clock_pub = None
        if args.clock:
            clock_pub = node.create_publisher(
                Clock, '/clock', QoSProfile(history=HistoryPolicy.KEEP_LAST,
                                            depth=max(100, len(todo) if n_wait > 0 else 0),
                                            reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.VOLATILE))
        endpoints = list(pubs.values()) + ([clock_pub] if clock_pub else [])
        if n_wait > 0:
            log(f'bag play: waiting for {n_wait} subscriber(s) on '
                f'{", ".join(p.topic_name for p in endpoints)}')
            deadline = time.monotonic() + args.wait_timeout
            while any(p.get_subscription_count() < n_wait for p in endpoints):
                if time.monotonic() > deadline:
                    missing = [p.topic_name for p in endpoints
                               if p.get_subscription_count() < n_wait]
                    print(f'bag play: error: timed out after {args.wait_timeout} s waiting for '
                          f'{n_wait} subscriber(s) on {", ".join(missing)}', file=sys.stderr)
                    return 1
                time.sleep(0.01)
        times, clock_times = plan.times, plan.clock_times
        t_first = times[0]
        sleep = time.sleep
        perf = time.perf_counter
        wall_start_overall = perf()
        while True:
            wall0 = perf()
            last_clock = None   # each loop replays the clock from the start (a jump back)
            for m, t_i, tc in zip(todo, times, clock_times):
                if rate > 0:
                    due = wall0 + (t_i - t_first) * 1e-9 / rate
                    rem = due - perf()
                    if rem > _SPIN_S:
                        sleep(rem - _SPIN_S)
                    while perf() < due:
                        pass
                if clock_pub is not None and tc is not None and (
                        last_clock is None or tc > last_clock):
                    clock_pub.publish(Clock(clock=Time(sec=tc // 1_000_000_000,
                                                       nanosec=tc % 1_000_000_000)))
                    last_clock = tc
                    clocks += 1
                pubs[m.topic].publish(bytes(m.data))
                if rate > 0:
                    stats.add(perf() - due)
                played += 1
            loops += 1
            if not args.loop:
                break
            log(f'bag play: loop {loops} done, playing again')
        elapsed = perf() - wall_start_overall
        t_ack = perf()
        unacked = [p.topic_name for p in endpoints
                   if not p.wait_for_all_acked(Duration(seconds=10.0))]
        if unacked:
            print(f'bag play: warning: not every subscriber acknowledged every message on '
                  f'{", ".join(unacked)} within 10 s', file=sys.stderr, flush=True)
        elif not args.quiet:
            print(f'bag play: all messages acknowledged ({(perf() - t_ack) * 1e3:.1f} ms)',
                  flush=True)
    except KeyboardInterrupt:
        interrupted = True
        elapsed = 0.0
    except Exception:
        if rclpy.ok():
            raise
        interrupted = True      # Ctrl-C shut the context down while a message was published
        elapsed = 0.0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    s = stats.summary()
    timing = (f'timing error mean {s["mean_ms"]:.3f} ms, p99 {s["p99_ms"]:.3f} ms, '
              f'max {s["max_ms"]:.3f} ms' if rate > 0 else 'as fast as possible')
    print(f'bag play: {"interrupted, " if interrupted else ""}played {played} messages'
          f'{f" and {clocks} /clock" if args.clock else ""} in {elapsed:.3f} s; {timing}',
          flush=True)
    return 0
