"""``irs-bag export <bag> --topics ... --out DIR``: one CSV per topic with flattened fields.

Column naming (``flatten``):

* first columns ``log_time_ns`` (int) and ``log_time`` (float seconds);
* nested message fields joined with dots: ``pose.position.x``;
* array / sequence elements indexed with brackets: ``position[0]``, ``poses[2].pose.x``;
  columns of variable-length arrays are the union over all messages (blank when absent);
* ``builtin_interfaces/Time`` and ``Duration`` values (e.g. ``header.stamp``) become one float
  column in seconds (``sec + nanosec * 1e-9``);
* floats are written with ``repr`` (round-trips exactly); ``bytes`` / ``uint8[]`` elements as
  ints; booleans as ``True``/``False``.

File name: the topic with the leading ``/`` removed and other ``/`` replaced by ``__``, plus
``.csv`` (``/arm/joint_states`` -> ``arm__joint_states.csv``).

Works on unfinished or damaged bags too (their readable part, one warning line on stderr).
Exit codes: 0 ok, 2 unreadable bag / write error / usage error (e.g. unknown topic); errors
are one line on stderr.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Sequence, TextIO, Tuple

from .reader import BagError, open_bag, reading

__all__ = ['flatten', 'export_topics', 'topic_file_name', 'main']


def _is_time(obj: Any) -> bool:
    slots = getattr(type(obj), '__slots__', None)
    return slots is not None and list(slots) == ['sec', 'nanosec']


def flatten(obj: Any, prefix: str = '') -> Iterator[Tuple[str, Any]]:
    """Yield ``(column, value)`` pairs of a decoded message, depth first, in field order."""
    if _is_time(obj):
        yield prefix, obj.sec + obj.nanosec * 1e-9
        return
    slots = getattr(type(obj), '__slots__', None)
    if slots is not None and not isinstance(obj, (str, bytes)):
        for name in slots:
            yield from flatten(getattr(obj, name), f'{prefix}.{name}' if prefix else name)
        return
    if isinstance(obj, (list, tuple, bytes, bytearray)) or (
            hasattr(obj, 'tolist') and hasattr(obj, 'shape')):
        seq = obj.tolist() if hasattr(obj, 'tolist') else obj
        for i, v in enumerate(seq):
            yield from flatten(v, f'{prefix}[{i}]')
        return
    yield prefix, obj


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return str(v)


def topic_file_name(topic: str) -> str:
    """CSV file name for a topic."""
    return topic.lstrip('/').replace('/', '__') + '.csv'


def export_topics(bag, out_dir: str, topics: Optional[Sequence[str]] = None
                  ) -> Dict[str, Tuple[Path, int]]:
    """Write one CSV per topic; returns ``{topic: (csv path, rows)}``.

    ``bag`` is a path (opened strictly) or an open :class:`BagReader`.

    Two passes over the bag: the first collects the columns (so variable-length arrays get a
    stable header), the second writes rows, so memory stays bounded for long recordings.

    Raises
    ------
    BagError
        Unreadable bag or undecodable message.
    ValueError
        A requested topic is not in the bag.
    """
    out = Path(out_dir)
    with reading(bag) as r:
        available = r.topics
        wanted = list(available) if not topics else list(dict.fromkeys(topics))
        missing = [t for t in wanted if t not in available]
        if missing:
            raise ValueError(f'topics not in the bag: {", ".join(missing)} '
                             f'(available: {", ".join(sorted(available)) or "none"})')
        columns: Dict[str, Dict[str, None]] = {t: {} for t in wanted}
        for m, d in r.decoded(wanted):
            cols = columns[m.topic]
            for k, _ in flatten(d):
                if k not in cols:
                    cols[k] = None
        out.mkdir(parents=True, exist_ok=True)
        files, writers, rows = {}, {}, {t: 0 for t in wanted}
        result: Dict[str, Tuple[Path, int]] = {}
        try:
            for t in wanted:
                path = out / topic_file_name(t)
                files[t] = open(path, 'w', newline='', encoding='utf-8')
                writers[t] = csv.writer(files[t])
                writers[t].writerow(['log_time_ns', 'log_time', *columns[t]])
                result[t] = (path, 0)
            for m, d in r.decoded(wanted):
                vals = dict(flatten(d))
                writers[m.topic].writerow([m.log_time_ns, repr(m.log_time_ns / 1e9)] +
                                          [_fmt(vals[c]) if c in vals else ''
                                           for c in columns[m.topic]])
                rows[m.topic] += 1
        finally:
            for f in files.values():
                f.close()
        return {t: (result[t][0], rows[t]) for t in wanted}


def main(argv: Optional[List[str]] = None, out: Optional[TextIO] = None) -> int:
    """Entry point of ``irs-bag export``; returns the exit code."""
    out = sys.stdout if out is None else out
    p = argparse.ArgumentParser(
        prog='irs-bag export', description='Export bag topics to CSV files.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--topics', nargs='+', metavar='TOPIC', help='topics to export (default all)')
    p.add_argument('--out', required=True, metavar='DIR', help='output directory')
    args = p.parse_args(argv)
    try:
        with open_bag(args.bag, 'irs-bag export') as r:
            res = export_topics(r, args.out, args.topics)
    except (BagError, OSError, ValueError) as exc:
        print(f'irs-bag export: error: {exc}', file=sys.stderr)
        return 2
    for t, (path, n) in res.items():
        print(f'{t}: {n} rows -> {path}', file=out)
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
