"""``bag info <bag>``: print topics, types, counts, rates, times and metadata of a bag.

Usage::

    bag info BAG [--validate] [--no-metadata]

The clock mode comes first (:func:`irs_bag.stamps.clock_mode`): a lock-step bag's header
stamps are simulated time, so its span and step rate are given in simulated time (from
``/clock``, else from the stamps of every stamped topic) besides the receive-time duration
(how fast the graph stepped). Each topic has two rates: per second of receive time and per
second of header stamps. The counters the recorder writes into ``metadata.yaml`` are explained
where they are printed (:data:`COUNTERS`).

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 1 ``--validate`` found problems, 2 unreadable bag (one line on stderr naming
the file and what is wrong) or usage error.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import sys
from typing import List, Optional, TextIO

from .errors import BagError
from .reader import BagReader, open_bag
from .writer import PROVISIONAL_KEY
from .validation import validate

__all__ = ['main', 'format_info']


def _stamp(ns: int) -> str:
    t = (_dt.datetime.fromtimestamp(ns // 10**9, tz=_dt.timezone.utc)
         + _dt.timedelta(microseconds=(ns % 10**9) // 1000))  # truncated, no float rounding
    return f'{t.isoformat(timespec="microseconds")} ({ns // 10**9}.{ns % 10**9:09d} s)'


#: What the counters the recorder writes into metadata.yaml ``custom_data`` mean.
COUNTERS = {
    'irs.dropped_messages': 'messages the recorder knows it lost (gaps in the sequence numbers '
                            'of the publishers); 0 = none lost',
    'irs.dropped_messages_per_topic': 'the same, per topic (JSON)',
    'irs.late_messages': 'messages received after a chunk holding later receive times was '
                         'written: kept, in a later chunk (readers merge overlapping chunks); '
                         'not a loss',
    PROVISIONAL_KEY: 'this metadata.yaml was written while the bag was open: its writer did '
                     'not close it',
}
_RATES = ('rate = messages per second of receive (wall) time; stamp rate = per second of '
          'header stamps')


def _clock_lines(reader: BagReader) -> List[str]:
    """The clock mode, and for a lock-step bag the span and rate of its simulated time."""
    mode, why = reader.clock_mode
    if mode != 'lockstep':
        what = 'real time' if mode == 'realtime' else 'real time (assumed)'
        return [f'Clock:        {what}: {why}']
    lines = [f'Clock:        lock-step ({why}): header stamps are simulated time; receive '
             f'times are how fast the graph stepped']
    topics = reader.topics
    stamped = [i for i in topics.values() if i.first_stamp_ns is not None]
    clock = topics.get('/clock')
    ref = clock if clock is not None and clock.first_stamp_ns is not None else None
    if ref is not None:
        first, last = ref.first_stamp_ns, ref.last_stamp_ns
        rate = ref.stamp_rate_hz
        src = f'/clock: {ref.message_count} steps at {rate:.1f} Hz' if rate else '/clock'
    elif stamped:
        first = min(i.first_stamp_ns for i in stamped)
        last = max(i.last_stamp_ns for i in stamped)
        src = 'header stamps of every stamped topic'
    else:
        return lines
    lines.append(f'Sim time:     {(last - first) * 1e-9:.6f} s ({first * 1e-9:.6f} .. '
                 f'{last * 1e-9:.6f} s; {src})')
    return lines


def _topic_lines(topics) -> List[str]:
    lines = [f'Topics:       {len(topics)}']
    if not topics:
        return lines
    w_t = max(len(t) for t in topics)
    w_y = max(len(i.type) for i in topics.values())
    lines.append(f'  {"topic":<{w_t}}  {"type":<{w_y}}  {"count":>9}  {"rate [Hz]":>10}  '
                 f'{"stamp rate [Hz]":>15}')
    for name in sorted(topics):
        i = topics[name]
        rate = f'{i.rate_hz:.3f}' if i.rate_hz is not None else '-'
        srate = f'{i.stamp_rate_hz:.3f}' if i.stamp_rate_hz is not None else '-'
        lines.append(f'  {name:<{w_t}}  {i.type:<{w_y}}  {i.message_count:>9}  {rate:>10}  '
                     f'{srate:>15}')
    lines.append(f'  ({_RATES})')
    return lines


def _custom_lines(meta) -> List[str]:
    """metadata.yaml ``custom_data``, each counter the recorder writes explained."""
    custom = meta.get('custom_data') if meta else None
    if not isinstance(custom, dict) or not custom:
        return []
    lines = ['Custom data (metadata.yaml):']
    for k, v in custom.items():
        note = COUNTERS.get(k)
        lines.append(f'  {k}: {v}' + (f'   -- {note}' if note else ''))
    return lines


def _metadata_lines(reader: BagReader) -> List[str]:
    recs = [r for r in reader.metadata_records() if r[0] != 'rosbag2']
    lines = [f'Metadata records: {len(recs)}']
    for name, data in recs:
        lines.append(f'  [{name}]')
        for k, v in data.items():
            v1 = v.replace('\n', '\\n')
            if len(v1) > 100:
                v1 = v1[:97] + '...'
            lines.append(f'    {k}: {v1}')
    return lines


def format_info(reader: BagReader, show_metadata: bool = True) -> str:
    """The human-readable info text for an open :class:`BagReader`."""
    lines = [
        f'Bag:          {reader.path}',
        f'Files:        {", ".join(p.name for p in reader.mcap_paths)}',
        f'Profile:      {reader.profile}   library: {reader.library}',
    ]
    if reader.partial:
        lines.append('State:        not closed or damaged: read from its data section (the '
                     'warning says why); `bag recover` writes a closed copy')
    lines += _clock_lines(reader)
    lines.append(f'Messages:     {reader.message_count}')
    if reader.message_count:
        lines += [
            f'Duration:     {reader.duration_ns / 1e9:.6f} s (receive time)',
            f'Start:        {_stamp(reader.start_time_ns)}',
            f'End:          {_stamp(reader.end_time_ns)}',
        ]
    lines += _topic_lines(reader.topics)
    lines += _custom_lines(reader.bag_metadata)
    if show_metadata:
        lines += _metadata_lines(reader)
    return '\n'.join(lines)


def main(argv: Optional[List[str]] = None, out: Optional[TextIO] = None) -> int:
    """Entry point of ``bag info``; returns the exit code."""
    out = sys.stdout if out is None else out
    p = argparse.ArgumentParser(
        prog='bag info', description='Show what a rosbag2 MCAP bag contains.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--validate', action='store_true',
                   help='also read everything with CRC checks and cross-check the indexes')
    p.add_argument('--no-metadata', action='store_true', help='do not list metadata records')
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'bag info') as r:
            print(format_info(r, show_metadata=not args.no_metadata), file=out)
        if args.validate:
            rep = validate(args.bag)
            if rep.ok:
                print(f'Validation:   OK ({rep.message_count} messages, '
                      f'{rep.chunk_count} chunks, CRCs valid)', file=out)
            else:
                print('Validation:   FAILED', file=out)
                for prob in rep.problems:
                    print(f'  - {prob}', file=out)
                return 1
    except (BagError, OSError) as exc:
        print(f'bag info: error: {exc}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
