"""Read rosbag2 MCAP bags, also unfinished or damaged ones (no rclpy).

* :class:`BagReader` opens a bag directory (``metadata.yaml`` + ``*.mcap``) or a single
  ``.mcap`` file and iterates :class:`BagMessage` ``(topic, type, log_time_ns, data)`` in
  log-time order, optionally for some topics only; ``data`` is the raw CDR bytes.
* A file is read through its summary section (indexes, statistics) when the summary is sound:
  footer present, summary CRC right, indexes consistent with each other and the file. Otherwise
  the data section is scanned sequentially (:mod:`irs_bag.scan`) and the messages are
  held in memory: with a complete data section that is the whole bag (one warning in
  :attr:`BagReader.warnings`); with an unfinished one (no footer, e.g. a killed recorder) or a
  damaged one it is the prefix of complete chunks, which ``allow_partial=True`` accepts (with
  a warning) and the default refuses with a :class:`BagError`.
* A ``metadata.yaml`` that is not UTF-8, not YAML or not a rosbag2 one is ignored with a
  warning, and the directory's ``*.mcap`` files are read.
* :func:`recover` returns the complete chunks of a truncated or damaged bag.
* :func:`deserialize` / :meth:`BagReader.decoded` decode CDR with
  ``mcap_ros2.decoder.DecoderFactory`` using the definitions stored in the bag.

Times are integer nanoseconds (log time = receive time). Every failure is a :class:`BagError`
with a one-line message (never a raw library traceback).
"""

from __future__ import annotations

import heapq
import io
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Iterable, Iterator, List, Optional, Tuple, Union

from mcap.data_stream import ReadDataStream
from mcap.reader import SeekingReader
from mcap.records import Channel, MessageIndex, Metadata, Schema
from mcap.stream_reader import StreamReader

from .layout import FOOTER_LEN as _FOOTER_LEN, PathLike, resolve_bag as _resolve
from .scan import MAGIC, BagError, BagMessage, Recovered, ScanResult, scan_file
from .scan import one_line as _one_line
from .scan import recover as _recover

__all__ = [
    'BagError',
    'BagMessage',
    'BagReader',
    'Recovered',
    'TopicInfo',
    'deserialize',
    'open_bag',
    'read_messages',
    'reading',
    'recover',
]



@dataclass
class TopicInfo:
    """A topic in a bag; times in ns (log time)."""

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


class _SummaryBad(Exception):
    """The summary section cannot be trusted (message says why)."""


class _Indexed:
    """One MCAP file read through its summary, which is checked before it is trusted."""

    def __init__(self, path: Path, validate_crcs: bool) -> None:
        self.path = path
        self.f = open(path, 'rb')
        try:
            self._load(validate_crcs)
        except BaseException:
            self.f.close()
            raise

    def _load(self, validate_crcs: bool) -> None:
        f = self.f
        size = f.seek(0, io.SEEK_END)
        f.seek(size - 8 - _FOOTER_LEN)
        op, length, s_start, _, s_crc = struct.unpack('<BQQQI', f.read(_FOOTER_LEN))
        if op != 0x02 or length != _FOOTER_LEN - 9:
            raise _SummaryBad('damaged footer')
        if not 8 < s_start < size - 8 - _FOOTER_LEN:
            raise _SummaryBad('no summary section' if s_start == 0 else
                              f'footer points at summary offset {s_start} outside the file')
        f.seek(s_start)
        if s_crc and zlib.crc32(f.read(size - 8 - 4 - s_start)) != s_crc:
            raise _SummaryBad('damaged summary section (summary CRC mismatch)')
        self.warnings: List[str] = []
        try:
            f.seek(0)
            self.reader = SeekingReader(f, validate_crcs=validate_crcs, record_size_limit=size)
            summary = self.reader.get_summary()
        except Exception as exc:
            raise _SummaryBad(f'unreadable summary section ({_one_line(exc)})') from None
        try:
            self.header = self.reader.get_header()
        except Exception as exc:
            self.header = None
            self.warnings.append(f'{self.path}: damaged MCAP header record ({_one_line(exc)}); '
                                 f'profile and library unknown')
        if summary is None or summary.statistics is None:
            raise _SummaryBad('summary section without statistics')
        self.summary = summary
        self.schemas: Dict[int, Schema] = dict(summary.schemas)
        self.channels: Dict[int, Channel] = dict(summary.channels)
        stats = summary.statistics
        self.counts: Dict[int, int] = dict(stats.channel_message_counts)
        if any(c.schema_id and c.schema_id not in self.schemas for c in self.channels.values()):
            raise _SummaryBad('summary channel refers to a missing schema')
        if not set(self.counts) <= set(self.channels) or (
                self.counts and sum(self.counts.values()) != stats.message_count):
            raise _SummaryBad('summary statistics disagree with its channels')
        self.message_count = stats.message_count
        self.start, self.end = stats.message_start_time, stats.message_end_time
        self.ranges = self._index_ranges(s_start)
        self.metadata: List[Tuple[str, Dict[str, str]]] = []
        for md in summary.metadata_indexes:
            if not 8 <= md.offset < s_start:
                raise _SummaryBad('metadata index points outside the data section')
            try:
                f.seek(md.offset)
                rec = next(StreamReader(f, skip_magic=True, record_size_limit=size).records)
                if not isinstance(rec, Metadata):
                    raise ValueError('no Metadata record there')
                self.metadata.append((rec.name, dict(rec.metadata)))
            except Exception as exc:
                self.warnings.append(f'{self.path}: damaged metadata record {md.name!r} '
                                     f'skipped ({_one_line(exc, 120)})')

    def _index_ranges(self, data_end: int) -> Dict[int, Tuple[int, int]]:
        """Per-channel (first, last) log time [ns] from the chunk and message indexes."""
        ranges: Dict[int, Tuple[int, int]] = {}
        for ci in self.summary.chunk_indexes:
            if not (8 <= ci.chunk_start_offset and
                    ci.chunk_start_offset + ci.chunk_length <= data_end):
                raise _SummaryBad('chunk index points outside the data section')
            for cid, off in ci.message_index_offsets.items():
                if cid not in self.channels or not 8 <= off < data_end:
                    raise _SummaryBad('chunk index lists a bad message index')
                try:
                    self.f.seek(off + 1 + 8)
                    idx = MessageIndex.read(ReadDataStream(self.f))
                except Exception as exc:
                    raise _SummaryBad(f'unreadable message index ({_one_line(exc)})') from None
                ts = [t for t, _ in idx.records]
                if idx.channel_id != cid or (ts and (
                        min(ts) < ci.message_start_time or max(ts) > ci.message_end_time)):
                    raise _SummaryBad('message index disagrees with its chunk index')
                if ts:
                    lo, hi = min(ts), max(ts)
                    old = ranges.get(cid)
                    ranges[cid] = (lo, hi) if old is None else (min(lo, old[0]),
                                                                max(hi, old[1]))
        return ranges

    def iter_messages(self, topics: Optional[List[str]]) -> Iterator[BagMessage]:
        try:
            for schema, channel, msg in self.reader.iter_messages(topics=topics,
                                                                  log_time_order=True):
                yield BagMessage(channel.topic, schema.name if schema else '', msg.log_time,
                                 msg.data)
        except Exception as exc:
            raise BagError(f'{self.path}: damaged data section, cannot read its messages '
                           f'({_one_line(exc)}); `bag recover` gives back the complete '
                           f'chunks') from None

    def metadata_records(self) -> List[Tuple[str, Dict[str, str]]]:
        return list(self.metadata)

    def close(self) -> None:
        self.f.close()


class _Scanned:
    """One MCAP file whose data section was scanned; messages held in memory."""

    def __init__(self, scan: ScanResult) -> None:
        self.path = scan.path
        self.header = scan.header
        self.schemas, self.channels = scan.schemas, scan.channels
        self._metadata = scan.metadata
        by_topic = {c.topic: cid for cid, c in self.channels.items()}
        self.messages = sorted(scan.messages, key=lambda m: m.log_time_ns)
        self.counts: Dict[int, int] = {}
        self.ranges: Dict[int, Tuple[int, int]] = {}
        for m in self.messages:
            cid = by_topic[m.topic]
            self.counts[cid] = self.counts.get(cid, 0) + 1
            lo, hi = self.ranges.get(cid, (m.log_time_ns, m.log_time_ns))
            self.ranges[cid] = (min(lo, m.log_time_ns), max(hi, m.log_time_ns))
        self.message_count = len(self.messages)
        self.start = self.messages[0].log_time_ns if self.messages else 0
        self.end = self.messages[-1].log_time_ns if self.messages else 0

    def iter_messages(self, topics: Optional[List[str]]) -> Iterator[BagMessage]:
        wanted = None if topics is None else set(topics)
        return (m for m in self.messages if wanted is None or m.topic in wanted)

    def metadata_records(self) -> List[Tuple[str, Dict[str, str]]]:
        return list(self._metadata)

    def close(self) -> None:
        pass


def _open_file(path: Path, validate_crcs: bool, allow_partial: bool,
               warnings: List[str]):
    """An :class:`_Indexed` file, or a :class:`_Scanned` one with a warning (see module doc)."""
    try:
        size = path.stat().st_size
        with open(path, 'rb') as f:
            head = f.read(8)
            f.seek(max(size - 8, 0))
            tail = f.read(8)
        if head != MAGIC:
            raise BagError(f'{path}: not an MCAP file (bad magic)')
        reason = 'unfinished (no MCAP footer: not closed, or cut off)'
        if size >= 16 + _FOOTER_LEN and tail == MAGIC:
            try:
                indexed = _Indexed(path, validate_crcs)
                warnings.extend(indexed.warnings)
                return indexed
            except _SummaryBad as exc:
                reason = str(exc)
        scan = scan_file(path)
    except OSError as exc:
        raise BagError(f'{path}: cannot read ({_one_line(exc)})') from None
    n = len(scan.messages)
    if scan.error is None:
        warnings.append(f'{path}: {reason}; read its data section instead ({n} messages)')
        return _Scanned(scan)
    cut = (f'{n} messages in {scan.chunks} complete chunks; the scan stopped at: '
           f'{scan.error}')
    if not allow_partial:
        raise BagError(f'{path}: {reason}; only a prefix is readable ({cut}); '
                       f'`bag recover` writes it as a valid bag')
    warnings.append(f'{path}: {reason}; reading its recovered prefix ({cut}; '
                    f'`bag recover` writes a valid copy)')
    return _Scanned(scan)


class BagReader:
    """Read a rosbag2 MCAP bag directory or a single ``.mcap`` file.

    Parameters
    ----------
    path : str or Path
        Bag directory or ``.mcap`` file.
    validate_crcs : bool
        Check chunk CRCs while reading messages (default True).
    allow_partial : bool
        Accept a bag of which only a prefix is readable (unfinished or damaged: its complete
        chunks are read, with a warning); default False: :class:`BagError`.

    Attributes
    ----------
    warnings : list of str
        One line per thing worked around (unusable metadata.yaml, summary not used, prefix
        only); empty for a sound bag.

    Raises
    ------
    BagError
        Not a bag, unreadable file, or (without ``allow_partial``) only a prefix readable.
    """

    def __init__(self, path: PathLike, *, validate_crcs: bool = True,
                 allow_partial: bool = False) -> None:
        self.warnings: List[str] = []
        self.path, self.mcap_paths, self.bag_metadata = _resolve(path, self.warnings)
        self._files: list = []
        try:
            for p in self.mcap_paths:
                self._files.append(_open_file(p, validate_crcs, allow_partial, self.warnings))
        except BagError:
            self.close()
            raise
        self._topics: Optional[Dict[str, TopicInfo]] = None

    @property
    def partial(self) -> bool:
        """True if some file is read from a scan of its data section (see :attr:`warnings`)."""
        return any(isinstance(f, _Scanned) for f in self._files)

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
        h = self._files[0].header
        return h.profile if h is not None else ''

    @property
    def library(self) -> str:
        """MCAP header library string of the first file."""
        h = self._files[0].header
        return h.library if h is not None else ''

    @property
    def message_count(self) -> int:
        """Total number of messages."""
        return sum(f.message_count for f in self._files)

    @property
    def start_time_ns(self) -> int:
        """Earliest log time [ns] (0 for an empty bag)."""
        ts = [f.start for f in self._files if f.message_count]
        return min(ts) if ts else 0

    @property
    def end_time_ns(self) -> int:
        """Latest log time [ns] (0 for an empty bag)."""
        ts = [f.end for f in self._files if f.message_count]
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
            for s in f.schemas.values():
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
            for cid, ch in f.channels.items():
                schema = f.schemas.get(ch.schema_id)
                info = topics.get(ch.topic)
                if info is None:
                    info = topics[ch.topic] = TopicInfo(
                        ch.topic, schema.name if schema else '', 0,
                        ch.metadata.get('offered_qos_profiles', ''),
                        ch.metadata.get('topic_type_hash', ''))
                info.message_count += f.counts.get(cid, 0)
                if cid in f.ranges:
                    lo, hi = f.ranges[cid]
                    info.first_log_time_ns = lo if info.first_log_time_ns is None else min(
                        lo, info.first_log_time_ns)
                    info.last_log_time_ns = hi if info.last_log_time_ns is None else max(
                        hi, info.last_log_time_ns)
        return topics

    def metadata_records(self) -> List[Tuple[str, Dict[str, str]]]:
        """All MCAP Metadata records as ``(name, dict)``, in file order."""
        out = []
        for f in self._files:
            out.extend(f.metadata_records())
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
        if len(self._files) == 1:
            yield from self._files[0].iter_messages(tlist)
            return
        iters = [((m.log_time_ns, i, n, m) for n, m in enumerate(f.iter_messages(tlist)))
                 for i, f in enumerate(self._files)]
        for _, _, _, m in heapq.merge(*iters):
            yield m

    def decoded(self, topics: Optional[Iterable[str]] = None
                ) -> Iterator[Tuple[BagMessage, Any]]:
        """Iterate ``(BagMessage, decoded_message)`` using the bag's stored definitions."""
        schemas = self.schemas
        for m in self.messages(topics):
            yield m, deserialize(m.type, schemas.get(m.type, ''), m.data)


def open_bag(bag: Union[PathLike, BagReader], prog: str, stream=None) -> BagReader:
    """What the ``bag`` verbs use: a :class:`BagReader` with ``allow_partial=True``; its
    warnings (if any) are printed as one line ``<prog>: warning: ...`` on ``stream`` (stderr).
    An already open reader is returned as it is.
    """
    if isinstance(bag, BagReader):
        return bag
    r = BagReader(bag, allow_partial=True)
    if r.warnings:
        import sys
        print(f'{prog}: warning: ' + '; '.join(r.warnings), file=stream or sys.stderr,
              flush=True)
    return r


def reading(bag: Union[PathLike, BagReader]):
    """Context manager: ``bag`` if it is an open :class:`BagReader` (left open), else a new
    strict ``BagReader(bag)`` closed on exit.
    """
    import contextlib
    return contextlib.nullcontext(bag) if isinstance(bag, BagReader) else BagReader(bag)


def read_messages(path: PathLike, topics: Optional[Iterable[str]] = None
                  ) -> Iterator[BagMessage]:
    """Convenience generator: open ``path`` and yield its messages in log-time order."""
    with BagReader(path) as r:
        yield from r.messages(topics)


# ------------------------------------------------------------------ decoding
_DECODERS: Dict[Tuple[str, str], Any] = {}
_FACTORY: List[Any] = []


def deserialize(type_name: str, definition: str, data: bytes) -> Any:
    """Decode CDR ``data`` of ``type_name`` with ``mcap_ros2`` and a ``ros2msg`` definition.

    ``definition`` is the full text stored in the bag (or from
    :func:`irs_bag.msg_definitions.get_message_definition`). Returns an object with one
    attribute per field (``__slots__`` lists them in definition order). Raises
    :class:`BagError` if the definition cannot be parsed or the bytes do not decode.
    """
    key = (type_name, definition)
    dec = _DECODERS.get(key)
    if dec is None:
        try:
            if not _FACTORY:
                from mcap_ros2.decoder import DecoderFactory
                _FACTORY.append(DecoderFactory())
            schema = Schema(id=len(_DECODERS) + 1, name=type_name, encoding='ros2msg',
                            data=definition.encode('utf-8'))
            dec = _FACTORY[0].decoder_for('cdr', schema)
            if dec is None:
                raise ValueError('no decoder')
        except Exception as exc:
            raise BagError(f'cannot build a decoder for {type_name!r} from its definition '
                           f'({_one_line(exc)})') from None
        _DECODERS[key] = dec
    try:
        return dec(data)
    except Exception as exc:
        raise BagError(f'cannot decode a {type_name!r} message ({_one_line(exc)})') from None


def recover(path: PathLike) -> Recovered:
    """Messages of every complete, CRC-valid chunk of a possibly truncated/corrupt bag.

    Reads the file(s) sequentially (see :mod:`irs_bag.scan`) and stops at the first
    record that is cut off or fails to parse, decompress or match its CRC, or at the end of the
    data section. Chunks are all-or-nothing. The result is sorted by log time (stable).

    Raises
    ------
    BagError
        Only if the path is not a bag at all (missing, no MCAP magic).
    """
    return _recover(path)

