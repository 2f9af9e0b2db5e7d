"""``irs-bag info <bag>``: print topics, types, counts, rates, times and metadata of a bag.

Usage::

    python -m irs_bag.info BAG [--validate] [--no-metadata]

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 1 ``--validate`` found problems, 2 unreadable bag (one line on stderr naming
the file and what is wrong) or usage error.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import sys
from typing import List, Optional, TextIO

from .reader import BagError, BagReader, open_bag
from .validation import validate

__all__ = ['main', 'format_info']


def _stamp(ns: int) -> str:
    t = (_dt.datetime.fromtimestamp(ns // 10**9, tz=_dt.timezone.utc)
         + _dt.timedelta(microseconds=(ns % 10**9) // 1000))  # truncated, no float rounding
    return f'{t.isoformat(timespec="microseconds")} ({ns // 10**9}.{ns % 10**9:09d} s)'


def format_info(reader: BagReader, show_metadata: bool = True) -> str:
    """The human-readable info text for an open :class:`BagReader`."""
    lines = [
        f'Bag:          {reader.path}',
        f'Files:        {", ".join(p.name for p in reader.mcap_paths)}',
        f'Profile:      {reader.profile}   library: {reader.library}',
        f'Messages:     {reader.message_count}',
    ]
    if reader.message_count:
        lines += [
            f'Duration:     {reader.duration_ns / 1e9:.6f} s',
            f'Start:        {_stamp(reader.start_time_ns)}',
            f'End:          {_stamp(reader.end_time_ns)}',
        ]
    topics = reader.topics
    lines.append(f'Topics:       {len(topics)}')
    if topics:
        w_t = max(len(t) for t in topics)
        w_y = max(len(i.type) for i in topics.values())
        lines.append(f'  {"topic":<{w_t}}  {"type":<{w_y}}  {"count":>9}  {"rate [Hz]":>10}')
        for name in sorted(topics):
            i = topics[name]
            rate = f'{i.rate_hz:.3f}' if i.rate_hz is not None else '-'
            lines.append(f'  {name:<{w_t}}  {i.type:<{w_y}}  {i.message_count:>9}  {rate:>10}')
    meta = reader.bag_metadata
    if meta and isinstance(meta.get('custom_data'), dict) and meta['custom_data']:
        lines.append('Custom data (metadata.yaml):')
        for k, v in meta['custom_data'].items():
            lines.append(f'  {k}: {v}')
    if show_metadata:
        recs = [r for r in reader.metadata_records() if r[0] != 'rosbag2']
        lines.append(f'Metadata records: {len(recs)}')
        for name, data in recs:
            lines.append(f'  [{name}]')
            for k, v in data.items():
                v1 = v.replace('\n', '\\n')
                if len(v1) > 100:
                    v1 = v1[:97] + '...'
                lines.append(f'    {k}: {v1}')
    return '\n'.join(lines)


def main(argv: Optional[List[str]] = None, out: Optional[TextIO] = None) -> int:
    """Entry point of ``irs-bag info``; returns the exit code."""
    out = sys.stdout if out is None else out
    p = argparse.ArgumentParser(
        prog='irs-bag info', description='Show what a rosbag2 MCAP bag contains.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--validate', action='store_true',
                   help='also read everything with CRC checks and cross-check the indexes')
    p.add_argument('--no-metadata', action='store_true', help='do not list metadata records')
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'irs-bag info') as r:
            print(format_info(r, show_metadata=not args.no_metadata), file=out)
        if args.validate:
            rep = validate(args.bag)
            if rep.ok:
                part = '' if rep.complete else ' (recovered prefix of an unfinished bag)'
                print(f'Validation:   OK{part} ({rep.message_count} messages, '
                      f'{rep.chunk_count} chunks, CRCs valid)', file=out)
            else:
                print('Validation:   FAILED', file=out)
                for prob in rep.problems:
                    print(f'  - {prob}', file=out)
                return 1
    except (BagError, OSError) as exc:
        print(f'irs-bag info: error: {exc}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
