"""Read, validate and recover rosbag2 MCAP bags (no rclpy).

* :class:`BagReader` opens a bag directory (``metadata.yaml`` + ``*.mcap``) or a single
  ``.mcap`` file and iterates :class:`BagMessage` ``(topic, type, log_time_ns, data)`` in
  log-time order, optionally for some topics only; ``data`` is the raw CDR bytes.
* :func:`validate` reads every record with the mcap library's CRC checks on (chunk CRCs,
  data-section CRC) plus the summary CRC, and checks that statistics, chunk indexes, message
  indexes and ``metadata.yaml`` agree with what is actually in the file.
* :func:`recover` returns the messages of every complete chunk of a truncated or damaged file
  (e.g. a recorder that was killed) using the sequential stream reader, stopping at the first
  bad record.
* :func:`deserialize` / :meth:`BagReader.decoded` decode CDR with ``mcap_ros2`` using the
  definitions stored in the bag.

Every failure is a :class:`BagError` with a one-line message (never a raw library traceback).
"""

from __future__ import annotations

import heapq
import io
import os
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, Iterator, List, NamedTuple, Optional, Tuple, Union

import yaml
from mcap.reader import make_reader
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Message,
                          MessageIndex, Metadata, Schema, Statistics)
from mcap.stream_reader import StreamReader, breakup_chunk

__all__ = [
    'BagError',
    'BagMessage',
    'BagReader',
    'Recovered',
    'TopicInfo',
    'ValidationReport',
    'deserialize',
    'read_messages',
    'recover',
    'validate',
]

_MAGIC = b'\x89MCAP0\r\n'
_FOOTER_LEN = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, crc

PathLike = Union[str, os.PathLike]


class BagError(Exception):
    """A bag cannot be opened, read or validated; ``str()`` is a one-line explanation."""


class BagMessage(NamedTuple):
    """One recorded message: raw CDR ``data`` as written."""

    topic: str
    type: str
    log_time_ns: int
    data: bytes


@dataclass
class TopicInfo:
    """A topic in a bag."""

    name: str
    type: str
    message_count: int
    offered_qos_profiles: str = ''
    type_hash: str = ''
    first_log_time_ns: Optional[int] = None
    last_log_time_ns: Optional[int] = None

    @property
    def rate_hz(self) -> Optional[float]:
        """Mean rate (n - 1) / (last - first) [Hz]; None with < 2 messages or zero span."""
        if (self.message_count < 2 or self.first_log_time_ns is None
                or self.last_log_time_ns is None
                or self.last_log_time_ns <= self.first_log_time_ns):
            return None
        return (self.message_count - 1) * 1e9 / (self.last_log_time_ns - self.first_log_time_ns)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().replace('\n', ' ')
    name = type(exc).__name__
    return f'{name}: {text}' if text else name


def _resolve(path: PathLike) -> Tuple[Path, List[Path], Optional[dict]]:
    """(bag path, mcap files, rosbag2_bagfile_information or None)."""
    p = Path(path)
    if not p.exists():
        raise BagError(f'{p}: no such bag directory or file')
    if p.is_dir():
        meta_path = p / 'metadata.yaml'
        meta = None
        if meta_path.is_file():
            try:
                doc = yaml.safe_load(meta_path.read_text(encoding='utf-8'))
                meta = doc['rosbag2_bagfile_information']
                files = [p / Path(x).name for x in meta['relative_file_paths']]
            except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
                raise BagError(f'{meta_path}: not a valid rosbag2 metadata.yaml '
                               f'({_one_line(exc)})') from None
            missing = [str(f) for f in files if not f.is_file()]
            if missing:
                raise BagError(f'{p}: files listed in metadata.yaml are missing: {missing}')
            bad = [f.name for f in files if f.suffix != '.mcap']
            if bad:
                raise BagError(f'{p}: only MCAP storage is supported, got {bad}')
        else:
            files = sorted(p.glob('*.mcap'))
            if not files:
                raise BagError(f'{p}: no metadata.yaml and no .mcap file in this directory')
        return p, files, meta
    if p.suffix != '.mcap':
        raise BagError(f'{p}: expected a bag directory or a .mcap file')
    return p, [p], None


def _check_complete(path: Path) -> None:
    try:
        size = path.stat().st_size
        with open(path, 'rb') as f:
            head = f.read(8)
            if size >= 16:
                f.seek(-8, io.SEEK_END)
            tail = f.read(8)
    except OSError as exc:
        raise BagError(f'{path}: cannot read ({_one_line(exc)})') from None
    if head != _MAGIC:
        raise BagError(f'{path}: not an MCAP file (bad magic)')
    if size < 16 + _FOOTER_LEN or tail != _MAGIC:
        raise BagError(f'{path}: truncated or not closed (no MCAP footer); '
                       f'use bag_reader.recover() to get the complete chunks')


class _File:
    """One opened MCAP file with its summary."""

    def __init__(self, path: Path, validate_crcs: bool) -> None:
        _check_complete(path)
        self.path = path
        try:
            self.f = open(path, 'rb')
        except OSError as exc:
            raise BagError(f'{path}: cannot open ({_one_line(exc)})') from None
        try:
            self.reader = make_reader(self.f, validate_crcs=validate_crcs)
            self.header = self.reader.get_header()
            summary = self.reader.get_summary()
        except Exception as exc:
            self.f.close()
            raise BagError(f'{path}: unreadable MCAP header/summary ({_one_line(exc)})') from None
        if summary is None or summary.statistics is None:
            self.f.close()
            raise BagError(f'{path}: MCAP file has no summary/statistics (not closed?); '
                           f'use bag_reader.recover()')
        self.summary = summary

    def close(self) -> None:
        self.f.close()


class BagReader:
    """Read a rosbag2 MCAP bag directory or a single ``.mcap`` file.

    Parameters
    ----------
    path : str or Path
        Bag directory or ``.mcap`` file.
    validate_crcs : bool
        Check chunk CRCs while reading messages (default True).

    Raises
    ------
    BagError
        Missing/invalid files, truncated file (no footer), unreadable summary.
    """

    def __init__(self, path: PathLike, *, validate_crcs: bool = True) -> None:
        self.path, self.mcap_paths, self.bag_metadata = _resolve(path)
        self._files: List[_File] = []
        try:
            for p in self.mcap_paths:
                self._files.append(_File(p, validate_crcs))
        except BagError:
            self.close()
            raise
        self._decoders: Dict[Tuple[str, bytes], Any] = {}
        self._topics: Optional[Dict[str, TopicInfo]] = None

    # -------------------------------------------------------------- context
    def close(self) -> None:
        """Close the files."""
        for f in self._files:
            f.close()
        self._files = []

    def __enter__(self) -> 'BagReader':
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -------------------------------------------------------------- info
    @property
    def profile(self) -> str:
        """MCAP header profile of the first file (``ros2`` for rosbag2 bags)."""
        return self._files[0].header.profile

    @property
    def library(self) -> str:
        """MCAP header library string of the first file."""
        return self._files[0].header.library

    @property
    def message_count(self) -> int:
        """Total number of messages (from the MCAP statistics)."""
        return sum(f.summary.statistics.message_count for f in self._files)

    @property
    def start_time_ns(self) -> int:
        """Earliest log time [ns] (0 for an empty bag)."""
        ts = [f.summary.statistics.message_start_time for f in self._files
              if f.summary.statistics.message_count]
        return min(ts) if ts else 0

    @property
    def end_time_ns(self) -> int:
        """Latest log time [ns] (0 for an empty bag)."""
        ts = [f.summary.statistics.message_end_time for f in self._files
              if f.summary.statistics.message_count]
        return max(ts) if ts else 0

    @property
    def duration_ns(self) -> int:
        """end - start [ns]."""
        return self.end_time_ns - self.start_time_ns

    @property
    def schemas(self) -> Dict[str, str]:
        """Message type -> stored (``ros2msg``) definition text."""
        out: Dict[str, str] = {}
        for f in self._files:
            for s in f.summary.schemas.values():
                out.setdefault(s.name, s.data.decode('utf-8', 'replace'))
        return out

    @property
    def topics(self) -> Dict[str, TopicInfo]:
        """Topic name -> :class:`TopicInfo` (counts from statistics, times from indexes)."""
        if self._topics is None:
            self._topics = self._collect_topics()
        return self._topics

    def _collect_topics(self) -> Dict[str, TopicInfo]:
        topics: Dict[str, TopicInfo] = {}
        for f in self._files:
            counts = f.summary.statistics.channel_message_counts
            for cid, ch in f.summary.channels.items():
                schema = f.summary.schemas.get(ch.schema_id)
                info = topics.get(ch.topic)
                if info is None:
                    info = topics[ch.topic] = TopicInfo(
                        ch.topic, schema.name if schema else '', 0,
                        ch.metadata.get('offered_qos_profiles', ''),
                        ch.metadata.get('topic_type_hash', ''))
                info.message_count += counts.get(cid, 0)
            try:
                ranges = self._index_ranges(f)
            except Exception as exc:
                raise BagError(f'{f.path}: bad message index ({_one_line(exc)})') from None
            for cid, (lo, hi) in ranges.items():
                info = topics[f.summary.channels[cid].topic]
                info.first_log_time_ns = lo if info.first_log_time_ns is None else min(
                    lo, info.first_log_time_ns)
                info.last_log_time_ns = hi if info.last_log_time_ns is None else max(
                    hi, info.last_log_time_ns)
        return topics

    @staticmethod
    def _index_ranges(f: _File) -> Dict[int, Tuple[int, int]]:
        """Per-channel (first, last) log time from the message index records."""
        from mcap.data_stream import ReadDataStream
        ranges: Dict[int, Tuple[int, int]] = {}
        for ci in f.summary.chunk_indexes:
            for cid, off in ci.message_index_offsets.items():
                f.f.seek(off + 1 + 8)
                idx = MessageIndex.read(ReadDataStream(f.f))
                if not idx.records:
                    continue
                ts = [t for t, _ in idx.records]
                lo, hi = min(ts), max(ts)
                old = ranges.get(cid)
                ranges[cid] = (lo, hi) if old is None else (min(lo, old[0]), max(hi, old[1]))
        return ranges

    def metadata_records(self) -> List[Tuple[str, Dict[str, str]]]:
        """All MCAP Metadata records as ``(name, dict)``, in file order."""
        out = []
        for f in self._files:
            try:
                for m in f.reader.iter_metadata():
                    out.append((m.name, dict(m.metadata)))
            except Exception as exc:
                raise BagError(f'{f.path}: cannot read metadata records '
                               f'({_one_line(exc)})') from None
        return out

    # -------------------------------------------------------------- messages
    def messages(self, topics: Optional[Iterable[str]] = None) -> Iterator[BagMessage]:
        """Iterate :class:`BagMessage` in log-time order (ties: file order).

        Parameters
        ----------
        topics : iterable of str, optional
            Only these topics (default: all). Unknown names are simply absent.
        """
        tlist = None if topics is None else ([topics] if isinstance(topics, str)
                                              else list(topics))
        iters = [self._iter_file(i, f, tlist) for i, f in enumerate(self._files)]
        if len(iters) == 1:
            for _, _, _, m in iters[0]:
                yield m
        else:
            for _, _, _, m in heapq.merge(*iters):
                yield m

    def _iter_file(self, fi: int, f: _File, topics: Optional[List[str]]):
        n = 0
        try:
            for schema, channel, msg in f.reader.iter_messages(topics=topics,
                                                               log_time_order=True):
                yield (msg.log_time, fi, n, BagMessage(channel.topic,
                                                       schema.name if schema else '',
                                                       msg.log_time, msg.data))
                n += 1
        except BagError:
            raise
        except Exception as exc:
            raise BagError(f'{f.path}: error while reading messages ({_one_line(exc)})') from None

    def decoded(self, topics: Optional[Iterable[str]] = None
                ) -> Iterator[Tuple[BagMessage, Any]]:
        """Iterate ``(BagMessage, decoded_message)`` using the bag's stored definitions."""
        schemas = self.schemas
        for m in self.messages(topics):
            yield m, deserialize(m.type, schemas.get(m.type, ''), m.data)


def read_messages(path: PathLike, topics: Optional[Iterable[str]] = None
                  ) -> Iterator[BagMessage]:
    """Convenience generator: open ``path`` and yield its messages in log-time order."""
    with BagReader(path) as r:
        yield from r.messages(topics)


# ------------------------------------------------------------------ decoding
_DECODERS: Dict[Tuple[str, str], Any] = {}


def deserialize(type_name: str, definition: str, data: bytes) -> Any:
    """Decode CDR ``data`` of ``type_name`` with ``mcap_ros2`` and a ``ros2msg`` definition.

    ``definition`` is the full text stored in the bag (or from
    :func:`irs_bringup.msg_definitions.get_message_definition`). Returns an object with one
    attribute per field (``__slots__`` lists them in definition order). Raises
    :class:`BagError` if the definition cannot be parsed or the bytes do not decode.
    """
    key = (type_name, definition)
    dec = _DECODERS.get(key)
    if dec is None:
        try:
            from mcap_ros2._dynamic import generate_dynamic
            dec = generate_dynamic(type_name, definition)[type_name]
        except Exception as exc:
            raise BagError(f'cannot build a decoder for {type_name!r} from its definition '
                           f'({_one_line(exc)})') from None
        _DECODERS[key] = dec
    try:
        return dec(data)
    except Exception as exc:
        raise BagError(f'cannot decode a {type_name!r} message ({_one_line(exc)})') from None


# ------------------------------------------------------------------ recovery
class Recovered(list):
    """List of :class:`BagMessage` from :func:`recover`, plus what stopped the scan.

    Attributes
    ----------
    error : str or None
        One-line reason the scan stopped early (None if the whole file was read to its footer).
    complete : bool
        True if the file ended with a valid footer.
    chunks : int
        Number of complete chunks recovered.
    metadata : list of (str, dict)
        Metadata records found before the stop point.
    """

    def __init__(self, items=(), error=None, complete=False, chunks=0, metadata=None):
        super().__init__(items)
        self.error: Optional[str] = error
        self.complete: bool = complete
        self.chunks: int = chunks
        self.metadata: List[Tuple[str, Dict[str, str]]] = metadata or []


def recover(path: PathLike) -> Recovered:
    """Messages of every complete, CRC-valid chunk of a possibly truncated/corrupt bag.

    Reads the file(s) sequentially with the mcap stream reader (CRCs validated) and stops at
    the first record that is cut off or fails to parse, decompress or match its CRC. Chunks are
    all-or-nothing. The result is sorted by log time (stable).

    Raises
    ------
    BagError
        Only if the path is not a bag at all (missing, no MCAP magic).
    """
    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob('*.mcap'))
        if not files:
            raise BagError(f'{p}: no .mcap file to recover')
    elif p.is_file():
        files = [p]
    else:
        raise BagError(f'{p}: no such bag directory or file')
    out: List[BagMessage] = []
    errors: List[str] = []
    complete = True
    chunks = 0
    metadata: List[Tuple[str, Dict[str, str]]] = []
    for fp in files:
        try:
            with open(fp, 'rb') as f:
                if f.read(8) != _MAGIC:
                    raise BagError(f'{fp}: not an MCAP file (bad magic)')
                f.seek(0)
                msgs, err, n, md = _scan(f)
        except OSError as exc:
            raise BagError(f'{fp}: cannot read ({_one_line(exc)})') from None
        out.extend(msgs)
        chunks += n
        metadata.extend(md)
        if err is not None:
            complete = False
            errors.append(f'{fp.name}: {err}')
    out.sort(key=lambda m: m.log_time_ns)
    return Recovered(out, '; '.join(errors) or None, complete, chunks, metadata)


def _scan(f) -> Tuple[List[BagMessage], Optional[str], int, List[Tuple[str, Dict[str, str]]]]:
    schemas: Dict[int, Schema] = {}
    channels: Dict[int, Channel] = {}
    msgs: List[BagMessage] = []
    metadata: List[Tuple[str, Dict[str, str]]] = []
    chunks = 0

    def take(records) -> List[BagMessage]:
        got = []
        for r in records:
            if isinstance(r, Schema):
                schemas[r.id] = r
            elif isinstance(r, Channel):
                channels[r.id] = r
            elif isinstance(r, Message):
                ch = channels.get(r.channel_id)
                if ch is None:
                    raise ValueError(f'message on unknown channel {r.channel_id}')
                sc = schemas.get(ch.schema_id)
                got.append(BagMessage(ch.topic, sc.name if sc else '', r.log_time, r.data))
        return got

    reader = StreamReader(f, emit_chunks=True, validate_crcs=True)
    footer = False
    try:
        for rec in reader.records:
            if isinstance(rec, Chunk):
                msgs.extend(take(breakup_chunk(rec, validate_crc=True)))
                chunks += 1
            elif isinstance(rec, (Schema, Channel, Message)):
                msgs.extend(take([rec]))
            elif isinstance(rec, Metadata):
                metadata.append((rec.name, dict(rec.metadata)))
            elif isinstance(rec, DataEnd):
                pass
            elif isinstance(rec, Footer):
                footer = True  # the generator then checks the closing magic
    except Exception as exc:  # truncated, corrupt, CRC mismatch, bad compression...
        return msgs, _one_line(exc) or 'unreadable record', chunks, metadata
    if footer:
        return msgs, None, chunks, metadata
    return msgs, 'file ended without footer', chunks, metadata


# ------------------------------------------------------------------ validation
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
    bag, files, meta = _resolve(path)
    rep = ValidationReport(str(bag))
    stats_sum = {'count': 0, 'start': None, 'end': None}
    per_topic: Dict[str, int] = {}
    for fp in files:
        _validate_file(fp, rep, per_topic, stats_sum)
    rep.topic_counts = per_topic
    if meta is not None:
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
        probs.append(str(exc))
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


def _chunk_positions(chunk: Chunk) -> List[int]:
    """Offsets of the Message records inside a chunk's decompressed records."""
    from mcap.stream_reader import get_chunk_data_stream
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
    except (KeyError, TypeError, ValueError) as exc:
        probs.append(f'metadata.yaml malformed ({_one_line(exc)})')
