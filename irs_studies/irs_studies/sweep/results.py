"""Sweep results on disk: Parquet parts written as points complete, merged at the end.

Layout of a results directory::

    <out>/parts/part-<n>.parquet   rows as they completed (one file per flush; a killed sweep
                                   keeps every flushed part)
    <out>/results.parquet          all rows, in the sweep's point order (written at the end)
    <out>/summary.md, *.png        the summary table and plots

Resume: :func:`done_keys` reads the ``point`` column of every part; the runner skips those
points. A row is a flat mapping ``point`` (str), ``seed`` (int), one column per axis (float, or
str for a categorical axis), one per metric (float), ``error`` (str, empty when the point ran).
"""
from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq


def parts_dir(out: Path) -> Path:
    return Path(out) / 'parts'


def read_parts(out: Path) -> list[dict]:
    """Every row of every part (unordered); [] when there are none."""
    rows = []
    for f in sorted(parts_dir(out).glob('part-*.parquet')):
        try:
            rows.extend(pq.read_table(f).to_pylist())
        except (OSError, pa.ArrowInvalid):
            continue   # a part cut short by a kill: its points run again
    return rows


def done_keys(out: Path) -> set:
    """``point`` keys already in the results."""
    return {r['point'] for r in read_parts(out)}


def write_part(out: Path, rows: list[dict]) -> Path | None:
    """Write ``rows`` as the next part (atomically: a temporary name, then rename)."""
    if not rows:
        return None
    d = parts_dir(out)
    d.mkdir(parents=True, exist_ok=True)
    n = 1 + max((int(f.stem.split('-')[1]) for f in d.glob('part-*.parquet')), default=-1)
    path = d / f'part-{n:05d}.parquet'
    tmp = path.with_suffix('.tmp')
    pq.write_table(pa.Table.from_pylist(rows), tmp)
    tmp.replace(path)
    return path


def merge(out: Path, order) -> list[dict]:
    """All rows in ``order`` (an iterable of point keys; the first row of a key wins), written
    to ``results.parquet``; returns them. ``order`` is read only until every row is placed.
    """
    by_key = {}
    for r in read_parts(out):
        by_key.setdefault(r['point'], r)
    rows = []
    for key in order:
        if len(rows) == len(by_key):
            break
        if key in by_key:
            rows.append(by_key[key])
    if rows:
        pq.write_table(pa.Table.from_pylist(rows), Path(out) / 'results.parquet')
    return rows


def read_results(path: Path) -> list[dict]:
    """Rows of ``results.parquet`` (or of a results directory)."""
    p = Path(path)
    if p.is_dir():
        p = p / 'results.parquet'
    return pq.read_table(p).to_pylist()
