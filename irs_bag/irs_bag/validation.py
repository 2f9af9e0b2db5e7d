"""Validate a rosbag2 MCAP bag: CRCs, summary, indexes, metadata.yaml (no rclpy).

:func:`validate` reads every record of every file with the mcap library's CRC checks on and
cross-checks the summary (statistics, chunk and message indexes) and ``metadata.yaml`` against
what the data section holds. An unfinished file (no footer: a killed recorder) is validated up
to its last complete chunk and reported with ``complete = False`` and a warning, not as a
problem; an unusable ``metadata.yaml`` is a problem, and the MCAP files are still checked.
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

from .layout import PathLike, check_complete as _check_complete, resolve_bag as _resolve
from .scan import BagError, one_line as _one_line, scan_file

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


def _validate_file(fp: Path, rep: ValidationReport, per_topic: Dict[str, int],
                   agg: Dict[str, Any]) -> None:
    probs = rep.problems
    name = fp.name
    try:
        _check_complete(fp)
    except BagError as exc:
        if 'no MCAP footer' not in str(exc):
            probs.append(str(exc))
        else:
            _validate_prefix(fp, rep, per_topic, agg)
        return
    data = fp.read_bytes()
    schemas: Dict[int, Schema] = {}
    channels: Dict[int, Channel] = {}
    chan_counts: Dict[int, int] = {}
    chunk_recs: Dict[int, Chunk] = {}
    chunk_msgs: Dict[int, List[Tuple[int, int, int]]] = {}  # offset -> (channel, time, pos)
    msg_index: Dict[Tuple[int, int], List[Tuple[int, int]]] = {}
    meta_names: List[str] = []
    header: Optional[Header] = None
    stats: Optional[Statistics] = None
    chunk_indexes: List[ChunkIndex] = []
    footer: Optional[Footer] = None
    count, tmin, tmax = 0, None, None
    # 1. sequential pass with CRC validation; track offsets to cross-check indexes.
    stream = io.BytesIO(data)
    reader = StreamReader(stream, emit_chunks=True, validate_crcs=True)
    last_chunk_off = None
    try:
        it = reader.records
        while True:
            off = stream.tell()
            try:
                rec = next(it)
            except StopIteration:
                break
            if isinstance(rec, Header):
                header = rec
            elif isinstance(rec, Schema):
                schemas.setdefault(rec.id, rec)
            elif isinstance(rec, Channel):
                channels.setdefault(rec.id, rec)
            elif isinstance(rec, Chunk):
                chunk_recs[off] = rec
                last_chunk_off = off
                recs = breakup_chunk(rec, validate_crc=True)
                inner, times = [], []
                pos = _chunk_positions(rec)
                mi = 0
                for r in recs:
                    if isinstance(r, Schema):
                        schemas.setdefault(r.id, r)
                    elif isinstance(r, Channel):
                        channels.setdefault(r.id, r)
                    elif isinstance(r, Message):
                        inner.append((r.channel_id, r.log_time, pos[mi]))
                        mi += 1
                        times.append(r.log_time)
                        chan_counts[r.channel_id] = chan_counts.get(r.channel_id, 0) + 1
                        count += 1
                        tmin = r.log_time if tmin is None else min(tmin, r.log_time)
                        tmax = r.log_time if tmax is None else max(tmax, r.log_time)
                chunk_msgs[off] = inner
                if times != sorted(times):
                    rep.unordered_chunks += 1
                if times and (rec.message_start_time != min(times)
                              or rec.message_end_time != max(times)):
                    probs.append(f'{name}: chunk at {off} start/end times do not match its '
                                 f'messages')
            elif isinstance(rec, MessageIndex):
                if last_chunk_off is not None:
                    msg_index[(last_chunk_off, rec.channel_id)] = list(rec.records)
            elif isinstance(rec, Message):
                chan_counts[rec.channel_id] = chan_counts.get(rec.channel_id, 0) + 1
                count += 1
                tmin = rec.log_time if tmin is None else min(tmin, rec.log_time)
                tmax = rec.log_time if tmax is None else max(tmax, rec.log_time)
            elif isinstance(rec, Metadata):
                meta_names.append(rec.name)
            elif isinstance(rec, Statistics):
                stats = rec
            elif isinstance(rec, ChunkIndex):
                chunk_indexes.append(rec)
            elif isinstance(rec, Footer):
                footer = rec
    except Exception as exc:
        probs.append(f'{name}: sequential CRC-validated read failed ({_one_line(exc)})')
        return
    rep.metadata_names.extend(meta_names)
    rep.message_count += count
    rep.chunk_count += len(chunk_recs)
    for cid, n in chan_counts.items():
        ch = channels.get(cid)
        if ch is None:
            probs.append(f'{name}: messages on undeclared channel {cid}')
            continue
        per_topic[ch.topic] = per_topic.get(ch.topic, 0) + n
    if count:
        agg['start'] = tmin if agg['start'] is None else min(agg['start'], tmin)
        agg['end'] = tmax if agg['end'] is None else max(agg['end'], tmax)
    agg['count'] += count

    # 2. header / encodings
    if header is None or header.profile != 'ros2':
        probs.append(f"{name}: header profile is {getattr(header, 'profile', None)!r}, "
                     f"expected 'ros2'")
    for s in schemas.values():
        if s.encoding != 'ros2msg':
            probs.append(f'{name}: schema {s.name!r} encoding {s.encoding!r}, expected ros2msg')
    for c in channels.values():
        if c.message_encoding != 'cdr':
            probs.append(f'{name}: channel {c.topic!r} encoding {c.message_encoding!r}, '
                         f'expected cdr')
        if c.schema_id not in schemas:
            probs.append(f'{name}: channel {c.topic!r} refers to missing schema {c.schema_id}')

    # 3. footer / summary CRC
    if footer is None or footer.summary_start == 0:
        probs.append(f'{name}: no summary section')
        return
    if footer.summary_crc != 0:
        crc = zlib.crc32(data[footer.summary_start:len(data) - 8 - 4])
        if crc != footer.summary_crc:
            probs.append(f'{name}: summary CRC mismatch ({crc:#010x} != '
                         f'{footer.summary_crc:#010x})')

    # 4. statistics
    if stats is None:
        probs.append(f'{name}: no statistics record')
    else:
        if stats.message_count != count:
            probs.append(f'{name}: statistics message_count {stats.message_count} != '
                         f'{count} messages in the file')
        if dict(stats.channel_message_counts) != {k: v for k, v in chan_counts.items()}:
            probs.append(f'{name}: statistics per-channel counts disagree with the data')
        if count and (stats.message_start_time != tmin or stats.message_end_time != tmax):
            probs.append(f'{name}: statistics start/end time disagree with the data')
        if stats.chunk_count != len(chunk_recs):
            probs.append(f'{name}: statistics chunk_count {stats.chunk_count} != '
                         f'{len(chunk_recs)} chunks')
        if stats.schema_count != len(schemas) or stats.channel_count != len(channels):
            probs.append(f'{name}: statistics schema/channel counts disagree with the data')
        if stats.metadata_count != len(meta_names):
            probs.append(f'{name}: statistics metadata_count {stats.metadata_count} != '
                         f'{len(meta_names)} metadata records')

    # 5. chunk + message indexes
    if len(chunk_indexes) != len(chunk_recs):
        probs.append(f'{name}: {len(chunk_indexes)} chunk indexes for {len(chunk_recs)} chunks')
    for ci in chunk_indexes:
        ch = chunk_recs.get(ci.chunk_start_offset)
        if ch is None:
            probs.append(f'{name}: chunk index points at {ci.chunk_start_offset}, no chunk there')
            continue
        if (ci.message_start_time != ch.message_start_time
                or ci.message_end_time != ch.message_end_time
                or ci.uncompressed_size != ch.uncompressed_size
                or ci.compression != ch.compression):
            probs.append(f'{name}: chunk index at {ci.chunk_start_offset} disagrees with chunk')
        expect: Dict[int, List[Tuple[int, int]]] = {}
        for cid, t, pos in chunk_msgs[ci.chunk_start_offset]:
            expect.setdefault(cid, []).append((t, pos))
        got = {cid: msg_index.get((ci.chunk_start_offset, cid)) for cid in
               ci.message_index_offsets}
        if set(got) != set(expect):
            probs.append(f'{name}: message index channels of chunk at {ci.chunk_start_offset} '
                         f'do not match its messages')
            continue
        for cid, recs in got.items():
            if recs is None or sorted(recs) != sorted(expect[cid]):
                probs.append(f'{name}: message index of channel {cid} in chunk at '
                             f'{ci.chunk_start_offset} does not match the chunk')

    # 6. seeking, log-time-ordered read with CRC validation
    try:
        with open(fp, 'rb') as f:
            r = make_reader(f, validate_crcs=True)
            n, last = 0, None
            for _, _, m in r.iter_messages(log_time_order=True):
                if last is not None and m.log_time < last:
                    probs.append(f'{name}: seeking reader returned messages out of time order')
                    break
                last = m.log_time
                n += 1
            if n != count:
                probs.append(f'{name}: indexed read gave {n} messages, sequential read {count}')
    except Exception as exc:
        probs.append(f'{name}: indexed CRC-validated read failed ({_one_line(exc)})')


def _validate_prefix(fp: Path, rep: 'ValidationReport', per_topic: Dict[str, int],
                     agg: Dict[str, Any]) -> None:
    """An unfinished file: its complete chunks are checked (CRCs); the cut is a warning."""
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
    rep.warnings.append(f'{fp}: unfinished (no MCAP footer); validated its recovered prefix: '
                        f'{len(s.messages)} messages in {s.chunks} complete chunks, CRCs valid '
                        f'(the scan stopped at: {s.error})')


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
