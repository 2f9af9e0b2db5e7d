"""Validate a rosbag2 MCAP bag: CRCs, summary, indexes, metadata.yaml (no rclpy).

:func:`validate` reads every record of every file with the mcap library's CRC checks on and
cross-checks the summary (statistics, chunk and message indexes) and ``metadata.yaml`` against
what the data section holds. An unfinished file (its writer did not close it: a killed
recorder) is a problem naming ``bag recover``; its complete chunks are still checked and
counted (``complete = False``). An unusable ``metadata.yaml`` is a problem, and the MCAP files
are still checked.
Times are integer nanoseconds.
"""
from __future__ import annotations

import io
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

from mcap.reader import make_reader
from mcap.records import (Channel, Chunk, ChunkIndex, Footer, Header, Message, MessageIndex,
                          Metadata, Schema, Statistics)
from mcap.stream_reader import StreamReader, breakup_chunk, get_chunk_data_stream

from .layout import PathLike, resolve_bag as _resolve, unfinished_reason
from .errors import BagError, one_line as _one_line
from .scan import scan_file

__all__ = ['ValidationReport', 'validate']


@dataclass
class ValidationReport:
    """Result of :func:`validate`."""

    path: str
    message_count: int = 0
    chunk_count: int = 0
    topic_counts: Dict[str, int] = field(default_factory=dict)
    metadata_names: List[str] = field(default_factory=list)
    unordered_chunks: int = 0
    problems: List[str] = field(default_factory=list)
    warnings: List[str] = field(default_factory=list)
    complete: bool = True

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems


def validate(path: PathLike, *, strict: bool = False) -> ValidationReport:
    """Read the whole bag with CRC validation and cross-check summary and metadata.

    Checks, per MCAP file: magic and footer; every record parses; chunk CRCs and the
    data-section CRC (mcap ``StreamReader(validate_crcs=True)``); summary CRC; statistics
    (message count, per-channel counts, start/end time, chunk/schema/channel/metadata counts)
    equal what the data section holds; chunk indexes match the chunks; message indexes point
    at the right messages; a seeking read (``make_reader(f, validate_crcs=True)``) in log-time
    order yields the same number of messages; profile ``ros2``, schemas ``ros2msg``, channels
    ``cdr``. For a directory, ``metadata.yaml`` counts/times/topics must agree too. Chunks whose
    messages are not in log-time order are counted in ``unordered_chunks`` (allowed by MCAP).

    Parameters
    ----------
    strict : bool
        Raise :class:`BagError` (listing the problems) instead of returning a failed report.

    Raises
    ------
    BagError
        If the path is not a bag, or with ``strict=True`` if any problem is found.
    """
    yaml_problems: List[str] = []
    bag, files, meta = _resolve(path, yaml_problems)
    rep = ValidationReport(str(bag))
    rep.problems.extend(yaml_problems)
    stats_sum = {'count': 0, 'start': None, 'end': None}
    per_topic: Dict[str, int] = {}
    for fp in files:
        try:
            _validate_file(fp, rep, per_topic, stats_sum)
        except Exception as exc:  # anything unforeseen in a damaged file is a finding
            rep.problems.append(f'{fp.name}: unreadable ({_one_line(exc)})')
    rep.topic_counts = per_topic
    if meta is not None and rep.complete:
        _validate_metadata_yaml(meta, rep, per_topic, stats_sum, files)
    if strict and rep.problems:
        raise BagError(f'{bag}: invalid bag: ' + '; '.join(rep.problems))
    return rep


@dataclass
class _Records:
    """What the sequential, CRC-validated pass over one file found (offsets in the file)."""

    data: bytes
    header: Optional[Header] = None
    schemas: Dict[int, Schema] = field(default_factory=dict)
    channels: Dict[int, Channel] = field(default_factory=dict)
    chan_counts: Dict[int, int] = field(default_factory=dict)
    chunks: Dict[int, Chunk] = field(default_factory=dict)
    chunk_msgs: Dict[int, List[Tuple[int, int, int]]] = field(default_factory=dict)
    msg_index: Dict[Tuple[int, int], List[Tuple[int, int]]] = field(default_factory=dict)
    meta_names: List[str] = field(default_factory=list)
    stats: Optional[Statistics] = None
    chunk_indexes: List[ChunkIndex] = field(default_factory=list)
    footer: Optional[Footer] = None
    count: int = 0
    tmin: Optional[int] = None
    tmax: Optional[int] = None
    unordered_chunks: int = 0
    problems: List[str] = field(default_factory=list)
    last_chunk: Optional[int] = None

    def message(self, channel_id: int, log_time: int) -> None:
        self.chan_counts[channel_id] = self.chan_counts.get(channel_id, 0) + 1
        self.count += 1
        self.tmin = log_time if self.tmin is None else min(self.tmin, log_time)
        self.tmax = log_time if self.tmax is None else max(self.tmax, log_time)

    def take(self, rec, off: int, name: str) -> None:
        """Note one top-level record found at ``off``."""
        if isinstance(rec, Header):
            self.header = rec
        elif isinstance(rec, (Schema, Channel)):
            (self.schemas if isinstance(rec, Schema) else self.channels).setdefault(rec.id, rec)
        elif isinstance(rec, Chunk):
            self._take_chunk(rec, off, name)
        elif isinstance(rec, MessageIndex):
            if self.last_chunk is not None:
                self.msg_index[(self.last_chunk, rec.channel_id)] = list(rec.records)
        elif isinstance(rec, Message):
            self.message(rec.channel_id, rec.log_time)
        elif isinstance(rec, Metadata):
            self.meta_names.append(rec.name)
        elif isinstance(rec, Statistics):
            self.stats = rec
        elif isinstance(rec, ChunkIndex):
            self.chunk_indexes.append(rec)
        elif isinstance(rec, Footer):
            self.footer = rec

    def _take_chunk(self, chunk: Chunk, off: int, name: str) -> None:
        """A chunk's records (chunk CRC validated), message positions and time range."""
        self.chunks[off] = chunk
        self.last_chunk = off
        pos = iter(_chunk_positions(chunk))
        inner, times = [], []
        for r in breakup_chunk(chunk, validate_crc=True):
            if isinstance(r, (Schema, Channel)):
                (self.schemas if isinstance(r, Schema) else self.channels).setdefault(r.id, r)
            elif isinstance(r, Message):
                inner.append((r.channel_id, r.log_time, next(pos)))
                times.append(r.log_time)
                self.message(r.channel_id, r.log_time)
        self.chunk_msgs[off] = inner
        if times != sorted(times):
            self.unordered_chunks += 1
        if times and (chunk.message_start_time != min(times)
                      or chunk.message_end_time != max(times)):
            self.problems.append(f'{name}: chunk at {off} start/end times do not match its '
                                 f'messages')


def _read_records(fp: Path) -> _Records:
    """Every record of the file in order, with mcap's ``StreamReader(validate_crcs=True)``
    (chunk and data-section CRCs). Raises what the reader raises on a damaged record.
    """
    got = _Records(fp.read_bytes())
    stream = io.BytesIO(got.data)
    records = StreamReader(stream, emit_chunks=True, validate_crcs=True).records
    while True:
        off = stream.tell()
        try:
            rec = next(records)
        except StopIteration:
            return got
        got.take(rec, off, fp.name)


def _validate_file(fp: Path, rep: ValidationReport, per_topic: Dict[str, int],
                   agg: Dict[str, Any]) -> None:
    """Validate one MCAP file (see :func:`validate`): named steps, problems into ``rep``."""
    why = unfinished_reason(fp)
    if why is not None:
        _validate_prefix(fp, why, rep, per_topic, agg)
        return
    try:
        got = _read_records(fp)
    except Exception as exc:
        rep.problems.append(f'{fp.name}: sequential CRC-validated read failed ({_one_line(exc)})')
        return
    rep.problems.extend(got.problems)
    rep.unordered_chunks += got.unordered_chunks
    _add_counts(got, fp.name, rep, per_topic, agg)
    _check_encodings(got, fp.name, rep.problems)
    if _check_summary_crc(got, fp.name, rep.problems):
        _check_statistics(got, fp.name, rep.problems)
        _check_indexes(got, fp.name, rep.problems)
        _check_seeking_read(fp, got.count, rep.problems)


def _add_counts(got: _Records, name: str, rep: ValidationReport, per_topic: Dict[str, int],
                agg: Dict[str, Any]) -> None:
    """The file's messages, chunks, metadata names and time range into the totals."""
    rep.metadata_names.extend(got.meta_names)
    rep.message_count += got.count
    rep.chunk_count += len(got.chunks)
    for cid, n in got.chan_counts.items():
        ch = got.channels.get(cid)
        if ch is None:
            rep.problems.append(f'{name}: messages on undeclared channel {cid}')
            continue
        per_topic[ch.topic] = per_topic.get(ch.topic, 0) + n
    if got.count:
        agg['start'] = got.tmin if agg['start'] is None else min(agg['start'], got.tmin)
        agg['end'] = got.tmax if agg['end'] is None else max(agg['end'], got.tmax)
    agg['count'] += got.count


def _check_encodings(got: _Records, name: str, probs: List[str]) -> None:
    """Profile ``ros2``, schemas ``ros2msg``, channels ``cdr`` with a known schema."""
    if got.header is None or got.header.profile != 'ros2':
        probs.append(f"{name}: header profile is {getattr(got.header, 'profile', None)!r}, "
                     f"expected 'ros2'")
    for s in got.schemas.values():
        if s.encoding != 'ros2msg':
            probs.append(f'{name}: schema {s.name!r} encoding {s.encoding!r}, expected ros2msg')
    for c in got.channels.values():
        if c.message_encoding != 'cdr':
            probs.append(f'{name}: channel {c.topic!r} encoding {c.message_encoding!r}, '
                         f'expected cdr')
        if c.schema_id not in got.schemas:
            probs.append(f'{name}: channel {c.topic!r} refers to missing schema {c.schema_id}')


def _check_summary_crc(got: _Records, name: str, probs: List[str]) -> bool:
    """A summary section exists and its CRC matches; False if there is none to check."""
    footer = got.footer
    if footer is None or footer.summary_start == 0:
        probs.append(f'{name}: no summary section')
        return False
    if footer.summary_crc != 0:
        crc = zlib.crc32(got.data[footer.summary_start:len(got.data) - 8 - 4])
        if crc != footer.summary_crc:
            probs.append(f'{name}: summary CRC mismatch ({crc:#010x} != '
                         f'{footer.summary_crc:#010x})')
    return True


def _check_statistics(got: _Records, name: str, probs: List[str]) -> None:
    """The Statistics record agrees with what the data section holds."""
    stats, count = got.stats, got.count
    if stats is None:
        probs.append(f'{name}: no statistics record')
        return
    if stats.message_count != count:
        probs.append(f'{name}: statistics message_count {stats.message_count} != '
                     f'{count} messages in the file')
    if dict(stats.channel_message_counts) != got.chan_counts:
        probs.append(f'{name}: statistics per-channel counts disagree with the data')
    if count and (stats.message_start_time != got.tmin or stats.message_end_time != got.tmax):
        probs.append(f'{name}: statistics start/end time disagree with the data')
    if stats.chunk_count != len(got.chunks):
        probs.append(f'{name}: statistics chunk_count {stats.chunk_count} != '
                     f'{len(got.chunks)} chunks')
    if stats.schema_count != len(got.schemas) or stats.channel_count != len(got.channels):
        probs.append(f'{name}: statistics schema/channel counts disagree with the data')
    if stats.metadata_count != len(got.meta_names):
        probs.append(f'{name}: statistics metadata_count {stats.metadata_count} != '
                     f'{len(got.meta_names)} metadata records')


def _check_indexes(got: _Records, name: str, probs: List[str]) -> None:
    """Chunk indexes match the chunks; message indexes point at the right messages."""
    if len(got.chunk_indexes) != len(got.chunks):
        probs.append(f'{name}: {len(got.chunk_indexes)} chunk indexes for {len(got.chunks)} '
                     f'chunks')
    for ci in got.chunk_indexes:
        off = ci.chunk_start_offset
        ch = got.chunks.get(off)
        if ch is None:
            probs.append(f'{name}: chunk index points at {off}, no chunk there')
            continue
        if (ci.message_start_time != ch.message_start_time
                or ci.message_end_time != ch.message_end_time
                or ci.uncompressed_size != ch.uncompressed_size
                or ci.compression != ch.compression):
            probs.append(f'{name}: chunk index at {off} disagrees with chunk')
        expect: Dict[int, List[Tuple[int, int]]] = {}
        for cid, t, pos in got.chunk_msgs[off]:
            expect.setdefault(cid, []).append((t, pos))
        indexed = {cid: got.msg_index.get((off, cid)) for cid in ci.message_index_offsets}
        if set(indexed) != set(expect):
            probs.append(f'{name}: message index channels of chunk at {off} do not match its '
                         f'messages')
            continue
        for cid, recs in indexed.items():
            if recs is None or sorted(recs) != sorted(expect[cid]):
                probs.append(f'{name}: message index of channel {cid} in chunk at {off} does '
                             f'not match the chunk')


def _check_seeking_read(fp: Path, count: int, probs: List[str]) -> None:
    """mcap's seeking reader (``make_reader``, CRCs on) yields every message in time order."""
    name = fp.name
    try:
        with open(fp, 'rb') as f:
            n, last = 0, None
            for _, _, m in make_reader(f, validate_crcs=True).iter_messages(log_time_order=True):
                if last is not None and m.log_time < last:
                    probs.append(f'{name}: seeking reader returned messages out of time order')
                    break
                last = m.log_time
                n += 1
            if n != count:
                probs.append(f'{name}: indexed read gave {n} messages, sequential read {count}')
    except Exception as exc:
        probs.append(f'{name}: indexed CRC-validated read failed ({_one_line(exc)})')


def _validate_prefix(fp: Path, why: str, rep: ValidationReport, per_topic: Dict[str, int],
                     agg: Dict[str, Any]) -> None:
    """An unfinished file: its complete chunks are checked (CRCs); being unfinished is a
    problem whose text names ``bag recover``.
    """
    s = scan_file(fp)
    rep.complete = False
    rep.message_count += len(s.messages)
    rep.chunk_count += s.chunks
    rep.metadata_names.extend(name for name, _ in s.metadata)
    for m in s.messages:
        per_topic[m.topic] = per_topic.get(m.topic, 0) + 1
    if s.messages:
        ts = [m.log_time_ns for m in s.messages]
        agg['start'] = min(ts) if agg['start'] is None else min(agg['start'], min(ts))
        agg['end'] = max(ts) if agg['end'] is None else max(agg['end'], max(ts))
    agg['count'] += len(s.messages)
    rep.problems.append(f'{fp}: unfinished, its writer did not close it ({why}); '
                        f'{len(s.messages)} messages in {s.chunks} complete chunks are readable '
                        f'(CRCs valid); `bag recover` writes them as a closed bag')


def _chunk_positions(chunk: Chunk) -> List[int]:
    """Offsets of the Message records inside a chunk's decompressed records."""
    stream, length = get_chunk_data_stream(chunk, validate_crc=False)
    out = []
    while stream.count < length:
        pos = stream.count
        opcode = stream.read1()
        n = stream.read8()
        stream.read(n)
        if opcode == 0x05:  # Message
            out.append(pos)
    return out


def _validate_metadata_yaml(meta: dict, rep: ValidationReport, per_topic: Dict[str, int],
                            agg: Dict[str, Any], files: List[Path]) -> None:
    probs = rep.problems
    try:
        if meta.get('storage_identifier') != 'mcap':
            probs.append(f"metadata.yaml storage_identifier is "
                         f"{meta.get('storage_identifier')!r}, expected 'mcap'")
        if int(meta['message_count']) != agg['count']:
            probs.append(f"metadata.yaml message_count {meta['message_count']} != "
                         f"{agg['count']} messages in the MCAP file(s)")
        yaml_topics = {t['topic_metadata']['name']: int(t['message_count'])
                       for t in meta.get('topics_with_message_count') or []}
        for t, n in per_topic.items():
            if yaml_topics.get(t) != n:
                probs.append(f'metadata.yaml topic {t}: count {yaml_topics.get(t)} != {n}')
        for t, n in yaml_topics.items():
            if n and t not in per_topic:
                probs.append(f'metadata.yaml lists {n} messages on {t}, none in the file')
        if agg['count']:
            start = int(meta['starting_time']['nanoseconds_since_epoch'])
            dur = int(meta['duration']['nanoseconds'])
            if start != agg['start'] or start + dur != agg['end']:
                probs.append('metadata.yaml starting_time/duration disagree with message times')
        listed = [Path(x).name for x in meta.get('relative_file_paths') or []]
        if listed != [f.name for f in files]:
            probs.append('metadata.yaml relative_file_paths do not match the files')
        fcount = sum(int(x.get('message_count', 0)) for x in meta.get('files') or [])
        if meta.get('files') and fcount != agg['count']:
            probs.append(f'metadata.yaml files message_count {fcount} != {agg["count"]}')
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        probs.append(f'metadata.yaml malformed ({_one_line(exc)})')
