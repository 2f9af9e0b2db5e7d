"""Sequential scan of an MCAP file's data section (no rclpy, no summary needed).

Used where the summary section cannot be trusted or does not exist: an unfinished file (the
recorder was killed: no summary, no footer), a damaged summary (bad CRC, inconsistent indexes)
or a damaged data section (a chunk that fails its CRC). :func:`scan_file` reads records in
file order with ``mcap.stream_reader.StreamReader`` (chunk and data-section CRCs validated,
record lengths bounded by the file size) and stops at the first record that is cut off or fails
to parse, decompress or match its CRC, or at the ``DataEnd`` record (the end of the data
section; the summary after it is not read). Chunks are all-or-nothing. :func:`recover` is the
same for a bag directory or file, merged and sorted by log time.

Times are integer nanoseconds (MCAP log times).
"""
from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, NamedTuple, Optional, Tuple, Union

from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

__all__ = ['BagError', 'BagMessage', 'Recovered', 'ScanResult', 'one_line', 'recover',
           'scan_file', 'MAGIC']

MAGIC = b'\x89MCAP0\r\n'
PathLike = Union[str, os.PathLike]


class BagError(Exception):
    """A bag cannot be opened, read or validated; ``str()`` is a one-line explanation."""


class BagMessage(NamedTuple):
    """One recorded message: raw CDR ``data`` as written; ``log_time_ns`` [ns]."""

    topic: str
    type: str
    log_time_ns: int
    data: bytes


def one_line(exc: BaseException, limit: int = 300) -> str:
    """``Type: text`` of an exception on one line, at most ``limit`` characters."""
    text = ' '.join(str(exc).split())
    name = type(exc).__name__
    out = f'{name}: {text}' if text else name
    return out if len(out) <= limit else out[:limit - 3] + '...'


@dataclass
class ScanResult:
    """What a sequential scan of one MCAP file found (see :func:`scan_file`).

    ``error`` is None when the data section was read to its ``DataEnd`` (or, for a file
    without one, to a clean end of file); ``data_end`` tells whether ``DataEnd`` was reached,
    ``footer`` whether a footer follows (only checked when the summary is read as well).
    """

    path: Path
    header: Optional[Header] = None
    schemas: Dict[int, Schema] = field(default_factory=dict)
    channels: Dict[int, Channel] = field(default_factory=dict)
    messages: List[BagMessage] = field(default_factory=list)
    extras: List[Tuple[int, int]] = field(default_factory=list)  # (publish_time, sequence)
    metadata: List[Tuple[str, Dict[str, str]]] = field(default_factory=list)
    chunks: int = 0
    data_end: bool = False
    error: Optional[str] = None


def scan_file(path: Path) -> ScanResult:
    """Scan the data section of one MCAP file; never raises for damaged content.

    Raises
    ------
    OSError
        The file cannot be opened/read.
    BagError
        The file does not start with the MCAP magic.
    """
    res = ScanResult(Path(path))
    size = res.path.stat().st_size
    with open(res.path, 'rb') as f:
        if f.read(8) != MAGIC:
            raise BagError(f'{res.path}: not an MCAP file (bad magic)')
        f.seek(0)
        records = StreamReader(f, emit_chunks=True, validate_crcs=True,
                               record_size_limit=max(size, 1)).records
        try:
            res.header = next(records)
            if not isinstance(res.header, Header):
                raise ValueError('no Header record')
        except Exception:   # a damaged Header record: skip it by its length, if that is sane
            f.seek(8)
            op, length = struct.unpack('<BQ', f.read(9).ljust(9, b'\0'))
            if op != 0x01 or not 0 < length < size:
                res.header, res.error = None, 'damaged MCAP header record'
                return res
            res.header = None
            f.seek(17 + length)
            records = StreamReader(f, skip_magic=True, emit_chunks=True, validate_crcs=True,
                                   record_size_limit=max(size, 1)).records
        try:
            for rec in records:
                if isinstance(rec, Chunk):
                    _take(res, breakup_chunk(rec, validate_crc=True))
                    res.chunks += 1
                elif isinstance(rec, (Schema, Channel, Message)):
                    _take(res, [rec])
                elif isinstance(rec, Metadata):
                    res.metadata.append((rec.name, dict(rec.metadata)))
                elif isinstance(rec, (DataEnd, Footer)):
                    res.data_end = True
                    break
        except Exception as exc:  # cut off, corrupt, CRC mismatch, bad compression...
            res.error = one_line(exc) or 'unreadable record'
    if res.error is None and not res.data_end:
        res.error = 'file ended without a DataEnd record (not closed)'
    return res


def _take(res: ScanResult, records) -> None:
    """Add the records of one chunk (or one loose record); all-or-nothing."""
    schemas, channels, got, extras = dict(res.schemas), dict(res.channels), [], []
    for r in records:
        if isinstance(r, Schema):
            schemas[r.id] = r
        elif isinstance(r, Channel):
            channels[r.id] = r
        elif isinstance(r, Message):
            ch = channels.get(r.channel_id)
            if ch is None:
                raise ValueError(f'message on undeclared channel {r.channel_id}')
            sc = schemas.get(ch.schema_id)
            got.append(BagMessage(ch.topic, sc.name if sc else '', r.log_time, r.data))
            extras.append((r.publish_time, r.sequence))
    res.schemas, res.channels = schemas, channels
    res.messages.extend(got)
    res.extras.extend(extras)


class Recovered(list):
    """List of :class:`BagMessage` from :func:`recover`, plus what stopped the scan.

    Attributes
    ----------
    error : str or None
        One-line reason the scan stopped early (None if every data section was read whole).
    complete : bool
        True if every file's data section was read to its end.
    chunks : int
        Number of complete chunks recovered.
    metadata : list of (str, dict)
        Metadata records found before the stop point.
    scans : list of ScanResult
        The per-file scans (schemas, channels with their QoS metadata, header).
    """

    def __init__(self, items=(), error=None, complete=False, chunks=0, metadata=None,
                 scans=None):
        super().__init__(items)
        self.error: Optional[str] = error
        self.complete: bool = complete
        self.chunks: int = chunks
        self.metadata: List[Tuple[str, Dict[str, str]]] = metadata or []
        self.scans: List[ScanResult] = scans or []


def recover(path: PathLike, files: Optional[List[Path]] = None) -> Recovered:
    """Messages of every complete, CRC-valid chunk of a possibly truncated/corrupt bag.

    ``path`` is a bag directory (every ``*.mcap`` in it, or ``files``) or one ``.mcap`` file.
    The result is sorted by log time (stable).

    Raises
    ------
    BagError
        Only if the path is not a bag at all (missing, no ``.mcap``, no MCAP magic, cannot be
        read); the message is one line.
    """
    p = Path(path)
    if files is None:
        if p.is_dir():
            files = sorted(p.glob('*.mcap'))
            if not files:
                raise BagError(f'{p}: no .mcap file to recover')
        elif p.is_file():
            files = [p]
        else:
            raise BagError(f'{p}: no such bag directory or file')
    out: List[BagMessage] = []
    errors, scans = [], []
    chunks = 0
    metadata: List[Tuple[str, Dict[str, str]]] = []
    for fp in files:
        try:
            s = scan_file(fp)
        except OSError as exc:
            raise BagError(f'{fp}: cannot read ({one_line(exc)})') from None
        scans.append(s)
        out.extend(s.messages)
        chunks += s.chunks
        metadata.extend(s.metadata)
        if s.error is not None:
            errors.append(f'{fp.name}: {s.error}')
    out.sort(key=lambda m: m.log_time_ns)
    return Recovered(out, '; '.join(errors) or None, not errors, chunks, metadata, scans)
