"""``bag play <bag>``: publish the recorded CDR bytes again, with the recorded timing.

Usage::

    bag play BAG [--rate R | --fast] [--pace {auto,header,log}] [--topics T ...]
                 [--remap OLD:=NEW ...] [--start-offset S] [--loop]
                 [--clock [--clock-from {auto,log,header}]]
                 [--wait-for-subscribers N | --paused-until-matched] [--wait-timeout S]
                 [--ack-timeout S] [--qos-depth D] [--quiet] [--dry-run] [--ros-args ...]

This module checks the options and reads the plan (:func:`prepare`, no ROS node): the messages
to play (read into memory first, so chunk decompression never delays one) and their time line
``t_i`` (``--pace``): ``log`` = the receive (log) time; ``header`` = simulation time, the
running maximum of the played messages' ``header.stamp`` (or leading Time) and of the bag's
``/clock`` messages; ``auto`` (default) = ``header`` for a lock-step bag
(:func:`irs_bag.stamps.clock_mode`), else ``log``. ``--start-offset`` is in log time. The
publishing, the ``/clock`` lead-in and the schedule are in :mod:`irs_bag.player`.

A remap's names must be valid ROS topic names (rclpy's ``validate_full_topic_name``, rcl's
rule), and no two played topics (nor ``/clock`` with ``--clock``) may land on one name with
different types; both are checked here, before anything is published.

An unfinished or damaged bag plays its readable part (one warning line on stderr).
Exit codes: 0 played; 1 timeout waiting for subscribers; 2 unreadable bag (one line naming the
file and what is wrong) or usage error (e.g. unknown topic, a bad ``--ros-args``); 130
interrupted by SIGINT
(Ctrl-C: also the usual way to end ``--loop``), 143 by SIGTERM.
"""
from __future__ import annotations

import argparse
import importlib
import math
import signal
import sys
from dataclasses import dataclass, field
from typing import Dict, List, Optional

from .errors import BagError
from .reader import BagMessage, BagReader, open_bag
from .stamps import lockstep_reason, stamp_reader

__all__ = ['main', 'Plan', 'prepare']


class UsageError(Exception):
    """Bad option values (exit code 2)."""


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
        old, new = (n if n.startswith('/') else '/' + n for n in (old, new))
        from .player import topic_name_problem      # rcl's rule, through rclpy
        problem = topic_name_problem(new)
        if problem:
            raise UsageError(f'--remap {item}: {problem} {new!r}')
        out[old] = new
    return out


def _check_names(wanted: List[str], infos, remaps: Dict[str, str], clock: bool) -> None:
    """UsageError if two topics would be published on one name with different types."""
    published: Dict[str, tuple] = {'/clock': ('rosgraph_msgs/msg/Clock', '--clock')} \
        if clock else {}
    for t in wanted:
        name, kind = remaps.get(t, t), infos[t].type
        other = published.setdefault(name, (kind, t))
        if other[0] != kind:
            raise UsageError(f'--remap: {t} ({kind}) and {other[1]} ({other[0]}) would both be '
                             f'published on {name}')


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


def _check_options(args):
    """(rate, subscribers to wait for) from the options; UsageError for bad values."""
    if args.fast and args.rate is not None:
        raise UsageError('--fast and --rate: give one (--fast is --rate 0)')
    rate = 0.0 if args.fast else 1.0 if args.rate is None else args.rate
    if not (0.0 <= rate < math.inf):
        raise UsageError(f'--rate must be a finite factor >= 0 (0: as fast as possible), '
                         f'got {args.rate}')
    if args.qos_depth < 1:
        raise UsageError(f'--qos-depth must be at least 1, got {args.qos_depth}')
    if args.wait_for_subscribers < 0:
        raise UsageError(f'--wait-for-subscribers must be >= 0, got {args.wait_for_subscribers}')
    if args.clock_from != 'auto' and not args.clock:
        raise UsageError(f'--clock-from {args.clock_from} without --clock: no /clock is played')
    for option, value in (('--start-offset', args.start_offset),
                          ('--wait-timeout', args.wait_timeout),
                          ('--ack-timeout', args.ack_timeout)):
        if not (0.0 <= value < math.inf):
            raise UsageError(f'{option} must be a finite number of seconds >= 0, got {value}')
    return rate, max(args.wait_for_subscribers, 1 if args.paused_until_matched else 0)


def _selection(args, infos, remaps: Dict[str, str]) -> List[str]:
    """The topics to play; UsageError for a topic not in the bag or a remap of none played."""
    if args.topics:
        wanted = [t if t.startswith('/') else '/' + t for t in args.topics]
        unknown = [t for t in wanted if t not in infos]
        if unknown:
            raise UsageError(f'topic(s) not in the bag: {", ".join(unknown)} '
                             f'(it has: {", ".join(sorted(infos)) or "none"})')
    else:
        wanted = sorted(infos)
    if args.clock:
        wanted = [t for t in wanted if t != '/clock']   # the player's /clock replaces it
    for old in remaps:
        if old not in wanted:
            raise UsageError(f'--remap: topic {old} is not played')
    _check_names(wanted, infos, remaps, args.clock)
    return wanted


def _message_types(wanted: List[str], infos) -> Dict[str, type]:
    types = {}
    for t in wanted:
        try:
            types[t] = _import_type(infos[t].type)
        except (ImportError, AttributeError, ValueError):
            raise BagError(f'type {infos[t].type!r} of {t} is not installed') from None
    return types


def _read_messages(reader: BagReader, plan: Plan, start_offset: float, stream) -> None:
    """Read the selection into ``plan.todo`` and set its time lines.

    Everything to play is read (and decompressed) before the clock starts: reading MCAP chunks
    while playing costs tens of ms per chunk in Python and shows as timing error.
    """
    infos, schemas = plan.infos, reader.schemas
    t_first = reader.start_time_ns + int(round(start_offset * 1e9))
    header = 'header' in (plan.pace, plan.clock_from)
    extra = ['/clock'] if header and '/clock' in infos and '/clock' not in plan.wanted else []
    clock_msgs = []
    for m in reader.messages(plan.wanted + extra):
        if m.log_time_ns >= t_first:
            (plan.todo if m.topic in plan.types else clock_msgs).append(m)
    hdr = []
    if header:
        if '/clock' in plan.types:
            clock_msgs = [m for m in plan.todo if m.topic == '/clock']
        stamp_of = {t: stamp_reader(schemas.get(infos[t].type, '')) for t in plan.wanted}
        hdr = _pace_times(plan.todo, stamp_of, clock_msgs)
        if not hdr and plan.todo:
            print('bag play: warning: no message of the selection has a header stamp; '
                  'pacing by log time', file=stream or sys.stderr)
            plan.pace = plan.clock_from = 'log'
    plan.times = hdr if plan.pace == 'header' else [m.log_time_ns for m in plan.todo]
    plan.clock_times = hdr if plan.clock_from == 'header' else plan.times


def prepare(args, stream=None) -> Plan:
    """Check the options and read everything to play (no rclpy); UsageError / BagError."""
    rate, n_wait = _check_options(args)
    remaps = _parse_remaps(args.remap)
    with open_bag(args.bag, 'bag play', stream) as reader:
        infos = reader.topics
        wanted = _selection(args, infos, remaps)
        if args.pace == 'auto':
            why = lockstep_reason(reader.metadata_records(), infos)
            pace = 'header' if why else 'log'
        else:
            why, pace = '--pace ' + args.pace, args.pace
        plan = Plan(wanted, [], [], pace, pace if args.clock_from == 'auto' else args.clock_from,
                    why or 'not a lock-step bag', {}, infos, remaps, rate, n_wait,
                    reader.message_count)
        if wanted and reader.message_count:
            plan.types = _message_types(wanted, infos)
            _read_messages(reader, plan, args.start_offset, stream)
    return plan


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='bag play', description='Replay a rosbag2 MCAP bag onto its topics.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--rate', type=float, default=None,
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
    p.add_argument('--ack-timeout', type=float, default=10.0, metavar='S',
                   help='longest wait for the reliable subscribers to acknowledge the first '
                        '/clock and, at the end, every message; then a warning (default 10)')
    p.add_argument('--qos-depth', type=int, default=1000, help='publisher KEEP_LAST depth')
    p.add_argument('--quiet', action='store_true', help='only print the final summary')
    p.add_argument('--dry-run', action='store_true',
                   help='read and check everything, print the plan, publish nothing')
    return p


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag play``; returns the exit code (module docstring)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args: List[str] = []
    if '--ros-args' in argv:
        i = argv.index('--ros-args')
        argv, ros_args = argv[:i], argv[i:]
    args = build_parser().parse_args(argv)
    from .player import Interrupt, run_player
    interrupt = Interrupt()
    try:
        try:
            plan = prepare(args)
        except (UsageError, BagError, OSError) as exc:
            print(f'bag play: error: {exc}', file=sys.stderr)
            return 2
        if interrupt:
            print(f'bag play: interrupted by {signal.Signals(interrupt.signum).name} (exit code '
                  f'{interrupt.exit_code}) before playing', flush=True)
            return interrupt.exit_code
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
        return run_player(args, ros_args, plan, interrupt)
    finally:
        interrupt.restore()
