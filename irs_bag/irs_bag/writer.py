"""Write rosbag2-compatible MCAP bags from already-serialized CDR messages (no rclpy).

A bag written by :class:`BagWriter` is a directory laid out as ``ros2 bag record -s mcap``
(Jazzy) lays it out::

    <directory>/
        <directory name>_0.mcap    # MCAP, profile "ros2", schemas "ros2msg", channels "cdr"
        metadata.yaml              # rosbag2_bagfile_information, version 9

MCAP details: header profile ``ros2``; one schema per message type named ``pkg/msg/Type``
with encoding ``ros2msg`` and the complete definition from
:func:`irs_bag.msg_definitions.get_message_definition`; one channel per topic with
``message_encoding='cdr'`` and metadata ``offered_qos_profiles`` (YAML string, may be empty)
and ``topic_type_hash`` (``RIHS01_...`` or empty); messages are written with their bytes
unchanged; data is chunked and each chunk compressed (``zstd`` default, ``lz4`` or ``none``);
chunk CRCs and the data-section CRC are written; on :meth:`BagWriter.close` the summary
(schemas, channels, statistics, chunk indexes, metadata indexes, summary offsets, summary
CRC) follows, plus a ``rosbag2`` metadata record holding the serialized bag metadata, as
rosbag2_storage_mcap does.

Ordering and crash safety: messages are buffered in memory until the buffer reaches
``chunk_size`` bytes or ``chunk_messages`` messages (or :meth:`BagWriter.flush` is called); the
buffer is then sorted by log time (stable, so equal times keep arrival order), written as one
complete chunk plus its message indexes, and the file is flushed to the OS (``fsync=True`` also
forces it to disk).
Every log time inside a chunk is therefore in order. A message whose log time is earlier than
the end of an already written chunk cannot be moved into that chunk; it is written (chunks then
overlap in time, which MCAP readers handle) and counted in ``late_messages``. While the bag is
open, its file ends after every chunk and metadata record with a footer without summary and
the closing magic (overwritten by the next record), and ``metadata.yaml`` is a provisional one
(the topics declared so far, no counts, ``custom_data`` key ``irs.provisional``): a bag whose
writer dies is opened by readers that need both (rosbags), which read its chunks; the missing
``DataEnd`` record marks it unfinished (:mod:`irs_bag.scan`). It holds every chunk finished so
far; :func:`irs_bag.reader.recover` returns those messages and ``bag recover`` writes them as a
closed bag. At most the buffered messages (< ``chunk_size`` bytes) are lost.
"""

from __future__ import annotations

import copy
import functools
import json
import os
import queue
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Tuple, Union

from irs_common import loop_trace
import yaml
from mcap.writer import CompressionType, IndexType, Writer as McapWriter

from .msg_definitions import get_message_definition, type_description_hash

__all__ = [
    'BagSummary',
    'BagWriter',
    'BagWriterError',
    'COMPRESSIONS',
    'PROVISIONAL_KEY',
    'ROS_DISTRO',
    'TopicStats',
    'bag_metadata_dict',
    'qos_profiles_yaml',
]

try:  # pragma: no cover - trivial
    from importlib.metadata import version as _version
    _MCAP_VERSION = _version('mcap')
except Exception:  # pragma: no cover
    _MCAP_VERSION = 'unknown'

ROS_DISTRO = 'jazzy'
LIBRARY = f'irs_bag.writer; mcap-python/{_MCAP_VERSION}'

#: Chunk compressions usable with mcap 1.6.0 and the installed zstandard / lz4 packages.
COMPRESSIONS = {
    'zstd': CompressionType.ZSTD,
    'lz4': CompressionType.LZ4,
    'none': CompressionType.NONE,
    '': CompressionType.NONE,
}

#: The writer thread sleeps ``_YIELD_S`` after every ``_YIELD_EVERY`` messages it adds: the
#: mcap writer is pure Python and holds the GIL, and a thread that wants the GIL back otherwise
#: waits for the interpreter's switch interval (5 ms) -- measured as 5 ms zero-timeout waits in
#: a composed 1 kHz loop. 16 messages take about 0.2 ms. Once :meth:`BagWriter.close` has begun,
#: the queue left is written without the pauses: the loop it made way for has ended (each pause
#: is a sleep of 0.1 ms or more, 0.6-0.9 s for the 100 batches of 512 messages a composed
#: lock-step run of 8 s leaves queued at its end).
_YIELD_EVERY = 16
_YIELD_S = 0.0001

#: Written after every chunk and metadata record and overwritten by the next one: a Footer
#: without a summary (summary_start 0) and the closing magic. An unfinished file therefore ends
#: like a closed one (rosbags and other readers that need the footer read its chunks), and the
#: missing DataEnd record tells it from a closed one (:mod:`irs_bag.scan`).
_PROVISIONAL_TAIL = (bytes([0x02]) + (20).to_bytes(8, 'little') + bytes(20)
                     + b'\x89MCAP0\r\n')

#: ``custom_data`` key of the metadata.yaml written while a bag is open (replaced at close).
PROVISIONAL_KEY = 'irs.provisional'
PROVISIONAL_TEXT = ('the bag was not closed when this was written: no counts; `bag recover` '
                    'writes a closed copy')

# Time "infinity" rosbag2 uses for unset QoS durations (RMW_DURATION_INFINITE).
_INFINITE = {'sec': 9223372036, 'nsec': 854775807}
_TIME_END = 2 ** 64                 # log and publish times are uint64 [ns]
_TOPIC_RE = re.compile(r'^/?[A-Za-z_~{][A-Za-z0-9_/{}~]*$')


class BagWriterError(RuntimeError):
    """Invalid use of :class:`BagWriter` (bad argument, closed writer, existing bag...)."""


def qos_profiles_yaml(reliability: str = 'reliable', durability: str = 'volatile',
                      history: str = 'keep_last', depth: int = 10, count: int = 1) -> str:
    """An ``offered_qos_profiles`` YAML string in the form Jazzy (metadata v9) writes.

    Parameters
    ----------
    reliability : {'reliable', 'best_effort'}
    durability : {'volatile', 'transient_local'}
    history : {'keep_last', 'keep_all'}
    depth : int
        History depth.
    count : int
        Number of publishers (one profile per publisher).
    """
    prof = {
        'history': history, 'depth': int(depth), 'reliability': reliability,
        'durability': durability, 'deadline': dict(_INFINITE), 'lifespan': dict(_INFINITE),
        'liveliness': 'automatic', 'liveliness_lease_duration': dict(_INFINITE),
        'avoid_ros_namespace_conventions': False,
    }
    return yaml.safe_dump([prof] * int(count), sort_keys=False, default_flow_style=False)


@dataclass
class TopicStats:
    """Per-topic counters of a bag being written."""

    name: str
    type: str
    message_count: int = 0
    dropped: int = 0
    first_log_time_ns: Optional[int] = None
    last_log_time_ns: Optional[int] = None


@dataclass
class BagSummary:
    """What :meth:`BagWriter.close` (or :meth:`BagWriter.summary`) reports."""

    directory: str
    mcap_path: str
    message_count: int
    start_time_ns: int
    end_time_ns: int
    duration_ns: int
    chunk_count: int        # chunks in the file (flushed); a queued chunk counts once written
    late_messages: int
    dropped_total: int
    topics: Dict[str, TopicStats] = field(default_factory=dict)
    closed: bool = False


def _qos_for_metadata(qos: str):
    """Version 9 metadata.yaml stores QoS profiles as a YAML list (the MCAP channel keeps the
    string); an empty string becomes ``[]``; an unparsable string is kept as is.
    """
    if not qos.strip():
        return []
    loaded, parsed = _parse_qos(qos)
    if not parsed or not isinstance(loaded, list):
        return qos
    return copy.deepcopy(loaded)    # one object per topic: shared ones would dump as YAML aliases


@functools.lru_cache(maxsize=256)
def _parse_qos(qos: str):
    """``(yaml.safe_load(qos), True)``, or ``(None, False)`` if it is not YAML. Cached: the
    provisional metadata.yaml is written again on every new topic, with every topic's QoS, and
    one parse takes about 2 ms.
    """
    try:
        return yaml.safe_load(qos), True
    except yaml.YAMLError:
        return None, False


def bag_metadata_dict(*, file_name: str, topics: Mapping[str, Tuple[str, str, str, int]],
                      start_ns: int, duration_ns: int, message_count: int,
                      custom_data: Optional[Mapping[str, str]] = None) -> dict:
    """The inner ``rosbag2_bagfile_information`` mapping (metadata version 9).

    ``topics`` maps topic name -> (type, offered_qos_profiles YAML string,
    type_description_hash, count).
    """
    return {
        'version': 9,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': int(duration_ns)},
        'starting_time': {'nanoseconds_since_epoch': int(start_ns)},
        'message_count': int(message_count),
        'topics_with_message_count': [
            {
                'topic_metadata': {
                    'name': name,
                    'type': typ,
                    'serialization_format': 'cdr',
                    'offered_qos_profiles': _qos_for_metadata(qos),
                    'type_description_hash': thash,
                },
                'message_count': int(count),
            }
            for name, (typ, qos, thash, count) in topics.items()
        ],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [file_name],
        'files': [{
            'path': file_name,
            'starting_time': {'nanoseconds_since_epoch': int(start_ns)},
            'duration': {'nanoseconds': int(duration_ns)},
            'message_count': int(message_count),
        }],
        'custom_data': {str(k): str(v) for k, v in (custom_data or {}).items()},
        'ros_distro': ROS_DISTRO,
    }


def _check_new_directory(directory: Path) -> None:
    """BagWriterError if ``directory`` exists and is not an empty directory (OSError if it
    cannot be looked at, e.g. a name too long).
    """
    if directory.exists():
        if not directory.is_dir():
            raise BagWriterError(f'{directory} exists and is not a directory')
        if any(directory.iterdir()):
            raise BagWriterError(f'bag directory {directory} already exists and is not empty')


class BagWriter:
    """Write serialized CDR messages to a rosbag2-compatible MCAP bag directory.

    Parameters
    ----------
    directory : str or Path
        Bag directory to create. It must not exist or be empty. The MCAP file is
        ``<directory>/<directory name>_0.mcap``.
    chunk_size : int
        Target uncompressed chunk size [bytes] (default 1 MiB, as rosbag2). Also the most data
        a crash can lose. Must be > 0.
    chunk_messages : int, optional
        The most messages in one chunk (default None: no limit, chunks cut by size alone). A
        chunk's message indexes are written by mcap's pure-Python writer, about 0.6 us per
        message holding the interpreter lock in one call (2.5-3.3 ms for 4,000 messages, 0.2-0.6
        ms for 256; measured 2026-12-04): a writer thread in a 1 kHz process keeps that call
        short with a limit (a recorder in the loop's process uses 512, its ``chunk_messages``
        parameter). Each chunk keeps about 1.4 kB in mcap's writer (its chunk index) until the
        bag closes. Must be > 0.
    compression : {'zstd', 'lz4', 'none'}
        Chunk compression (both zstd and lz4 work with the installed mcap 1.6.0).
    fsync : bool
        ``os.fsync`` after every chunk and metadata record (slower, survives power loss).
    custom_data : mapping of str to str, optional
        Extra entries for ``custom_data`` in ``metadata.yaml``.
    definition_prefixes : list of str, optional
        Install prefixes to look up ``.msg`` files (default AMENT_PREFIX_PATH + sys.prefix).
    background : bool
        Cut each chunk in the caller's thread (a list swap) but sort, index, compress and write
        it in a writer thread (default False: all in the caller's thread). For a recorder in a
        1 kHz loop: writing a 1 MiB chunk (about 4,000 messages through mcap's pure-Python
        writer, then zstd) takes 50-100 ms, which the loop cannot lose at once. The mcap writer
        and the file are only touched under an I/O lock; an error in the writer thread is raised
        (as :class:`BagWriterError`) by the next call. A killed process loses, besides the
        buffer, the chunks still queued for the thread.

    Notes
    -----
    Thread-safe: all public methods take an internal lock. Use as a context manager or call
    :meth:`close`; an unclosed bag is still readable up to its last chunk with
    :func:`irs_bag.reader.recover`.
    """

    def __init__(self, directory: Union[str, os.PathLike], *, chunk_size: int = 1024 * 1024,
                 chunk_messages: Optional[int] = None, compression: str = 'zstd',
                 fsync: bool = False,
                 custom_data: Optional[Mapping[str, str]] = None,
                 definition_prefixes: Optional[List[str]] = None,
                 background: bool = False) -> None:
        if not isinstance(chunk_size, int) or isinstance(chunk_size, bool) or chunk_size <= 0:
            raise BagWriterError(f'chunk_size must be a positive int of bytes, got {chunk_size!r}')
        if chunk_messages is not None and (not isinstance(chunk_messages, int)
                                           or isinstance(chunk_messages, bool)
                                           or chunk_messages <= 0):
            raise BagWriterError(
                f'chunk_messages must be a positive int or None, got {chunk_messages!r}')
        comp = str(compression).lower()
        if comp not in COMPRESSIONS:
            raise BagWriterError(
                f"compression must be one of 'zstd', 'lz4', 'none', got {compression!r}")
        self._directory = Path(directory)
        try:
            _check_new_directory(self._directory)
            name = self._directory.resolve().name or 'bag'
        except OSError as exc:
            raise BagWriterError(f'cannot create the bag directory {self._directory}: '
                                 f'{exc.strerror or exc}') from None
        self._file_name = f'{name}_0.mcap'
        self._compression = 'none' if comp == '' else comp
        self._chunk_size = chunk_size
        self._chunk_messages = chunk_messages or 1 << 62
        self._fsync = bool(fsync)
        self._custom = {str(k): str(v) for k, v in (custom_data or {}).items()}
        self._prefixes = definition_prefixes
        self._lock = threading.RLock()
        self._io = threading.Lock()       # the mcap writer and the file (writer thread too)
        self._batches: Optional[queue.SimpleQueue] = None
        self._thread: Optional[threading.Thread] = None
        self._thread_error: Optional[BaseException] = None
        self._draining = False    # closing: the writer thread writes its queue without pauses

        self._path = self._directory / self._file_name
        try:
            self._directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise BagWriterError(f'cannot create the bag directory {self._directory}: '
                                 f'{exc.strerror or exc}') from None
        try:
            self._stream = open(self._path, 'wb')
        except OSError as exc:
            raise BagWriterError(f'cannot create the bag file {self._path}: '
                                 f'{exc.strerror or exc}') from None
        try:
            self._writer = McapWriter(
                self._stream,
                chunk_size=2 ** 62,  # chunks are cut by this class, see _flush_chunk
                compression=COMPRESSIONS[comp],
                index_types=IndexType.ALL,
                repeat_channels=True,
                repeat_schemas=True,
                use_chunking=True,
                use_statistics=True,
                use_summary_offsets=True,
                enable_crcs=True,
                enable_data_crcs=True,
            )
            self._writer.start(profile='ros2', library=LIBRARY)
            self._sync()
        except Exception as exc:
            self._stream.close()
            raise BagWriterError(f'cannot start MCAP file {self._path}: {exc}') from None

        self._schemas: Dict[str, int] = {}
        self._channels: Dict[str, int] = {}
        self._topics: Dict[str, TopicStats] = {}
        self._qos: Dict[str, str] = {}
        self._hash: Dict[str, str] = {}          # type -> RIHS01 hash
        self._topic_hash: Dict[str, str] = {}    # topic -> hash written in its channel
        self._drop_only: Dict[str, TopicStats] = {}  # drops on topics never declared
        self._pending: List[Tuple[int, int, int, bytes, int, int]] = []
        self._pending_bytes = 0
        self._arrival = 0
        self._written_end: Optional[int] = None  # max log time in finished chunks
        self._start: Optional[int] = None
        self._end: Optional[int] = None
        self._count = 0
        self._late = 0
        self._chunks = 0
        self._closed = False
        self._summary: Optional[BagSummary] = None
        try:
            self._write_metadata_yaml(self._metadata(provisional=True))
        except OSError as exc:
            self._stream.close()
            raise BagWriterError(f'cannot write {self._directory}/metadata.yaml: '
                                 f'{exc.strerror or exc}') from None
        if background:
            self._batches = queue.SimpleQueue()
            self._thread = threading.Thread(target=self._write_batches, daemon=True,
                                            name=f'bag-writer {name}')
            self._thread.start()

    # ------------------------------------------------------------------ properties
    @property
    def directory(self) -> Path:
        """The bag directory."""
        return self._directory

    @property
    def path(self) -> Path:
        """The MCAP file being written."""
        return self._path

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    @property
    def message_counts(self) -> Dict[str, int]:
        """Messages accepted per topic (including ones still buffered)."""
        with self._lock:
            return {t: s.message_count for t, s in self._topics.items()}

    @property
    def drop_counts(self) -> Dict[str, int]:
        """Messages reported lost per topic via :meth:`record_drop`."""
        with self._lock:
            return {t: s.dropped for t, s in self._topics.items() if s.dropped}

    # ------------------------------------------------------------------ API
    def add_topic(self, topic: str, type_name: str, offered_qos_profiles: str = '',
                  type_hash: Optional[str] = None, definition: Optional[str] = None) -> None:
        """Declare a topic (optional: :meth:`write` declares unknown topics itself).

        ``definition`` (the full ``ros2msg`` text, e.g. from another bag) is used for the
        type's schema instead of the installed ``.msg`` files, if the type has none yet.

        Declaring up front records QoS and puts the topic in the bag even if no message
        arrives. Re-declaring a topic with the same type is a no-op; with another type it is an
        error (rosbag2 bags have one type per topic).

        Raises
        ------
        BagWriterError
            Bad topic name, type conflict, or closed writer.
        irs_bag.msg_definitions.MessageDefinitionError
            The type's ``.msg`` definition (or a nested one) cannot be found.
        """
        with self._lock:
            self._check_open()
            self._declare(topic, type_name, offered_qos_profiles, type_hash, definition)

    def write(self, topic: str, type_name: str, data: Union[bytes, bytearray, memoryview],
              log_time_ns: int, publish_time_ns: Optional[int] = None,
              sequence: int = 0) -> None:
        """Append one serialized CDR message, bytes unchanged.

        Parameters
        ----------
        topic, type_name : str
            Topic and its ROS type (``pkg/msg/Type``).
        data : bytes-like
            The CDR serialized message (with its 4-byte encapsulation header).
        log_time_ns : int
            Receive time [ns] (rosbag2 ``recv_timestamp``), >= 0.
        publish_time_ns : int, optional
            Publish time [ns]; defaults to ``log_time_ns``.
        sequence : int
            Optional publisher sequence number (uint32).
        """
        with self._lock:
            if self._closed or self._thread_error is not None:
                self._check_open()
            if not isinstance(data, (bytes, bytearray, memoryview)):
                raise BagWriterError(f'data must be bytes, got {type(data).__name__}')
            # the checks of _check_time, inlined for a plain int (1 kHz x a dozen topics)
            lt = (log_time_ns if type(log_time_ns) is int and 0 <= log_time_ns < _TIME_END
                  else self._check_time(log_time_ns, 'log_time_ns'))
            if publish_time_ns is None:
                pt = lt
            elif type(publish_time_ns) is int and 0 <= publish_time_ns < _TIME_END:
                pt = publish_time_ns
            else:
                pt = self._check_time(publish_time_ns, 'publish_time_ns')
            stats = self._topics.get(topic)
            if stats is None:
                self._declare(topic, type_name, '', None)
                stats = self._topics[topic]
            elif stats.type != type_name:
                raise BagWriterError(
                    f'topic {topic!r} has type {stats.type!r}, cannot write a {type_name!r}')
            self._add(stats, self._channels[topic], bytes(data), lt, pt,
                      int(sequence) & 0xFFFFFFFF)

    def appender(self, topic: str) -> Callable[[bytes, int], None]:
        """``append(data, time_ns)``: :meth:`write` of one declared topic for a caller that
        serialised ``data`` (``bytes``) itself and stamps it with an int time [ns].

        ``append(data, t)`` writes what ``write(topic, type, data, t, t, 0)`` writes, with the
        same counts, with the topic's checks done once, here: the composed recorder hands over
        about 12,000 messages a second (:mod:`irs_common.intra_process`). Other bytes-like data
        is copied, as by :meth:`write`; data that is not bytes-like and a time that is not an
        int in ``[0, 2**64)`` ns raise :class:`BagWriterError`.

        Raises
        ------
        BagWriterError
            ``topic`` not declared (:meth:`add_topic`), or closed writer (also raised by
            ``append`` once the writer is closed).
        """
        with self._lock:
            self._check_open()
            stats = self._topics.get(topic)
            if stats is None:
                raise BagWriterError(f'appender: topic {topic!r} is not declared')
            channel = self._channels[topic]
        lock, add = self._lock, self._add

        def append(data: bytes, t: int) -> None:
            with lock:
                if self._closed or self._thread_error is not None:
                    self._check_open()
                if type(t) is not int or not 0 <= t < _TIME_END:
                    t = self._check_time(t, 'time_ns')
                add(stats, channel, data if type(data) is bytes else self._copy(data), t, t, 0)
        return append

    def record_drop(self, topic: str, n: int = 1) -> None:
        """Count ``n`` messages on ``topic`` that the recorder could not keep.

        Reported in ``metadata.yaml`` ``custom_data`` and in :class:`BagSummary`. The topic
        need not have been declared (its type is then recorded as ``''`` in the summary only).
        """
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise BagWriterError(f'record_drop: n must be an int >= 0, got {n!r}')
        with self._lock:
            self._check_open()
            stats = self._topics.get(topic)
            if stats is None:
                stats = self._drop_only.setdefault(topic, TopicStats(topic, ''))
            stats.dropped += n

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Write an MCAP Metadata record now (e.g. ``experiment``, ``parameters``, ``versions``).

        Keys and values must be strings (MCAP ``map<string,string>``); non-string values raise
        :class:`BagWriterError` rather than being silently converted. The record is flushed to
        the file immediately, so it survives a crash. The name ``rosbag2`` is reserved.
        """
        if not isinstance(name, str) or not name:
            raise BagWriterError(f'metadata name must be a non-empty string, got {name!r}')
        if name == 'rosbag2':
            raise BagWriterError("metadata name 'rosbag2' is reserved for the bag metadata")
        if not isinstance(data, Mapping):
            raise BagWriterError(f'metadata {name!r} must be a mapping of str to str')
        bad = [k for k, v in data.items() if not isinstance(k, str) or not isinstance(v, str)]
        if bad:
            raise BagWriterError(
                f'metadata {name!r}: keys and values must be str (bad keys: {bad[:5]!r})')
        with self._lock:
            self._check_open()
            with self._io:
                self._writer.add_metadata(name, dict(data))
                self._sync()

    def flush(self) -> None:
        """Write the buffered messages as one chunk now and flush the file (no-op if empty)."""
        with self._lock:
            self._check_open()
            self._flush_chunk()

    def summary(self) -> BagSummary:
        """Counters so far (or the final ones after :meth:`close`)."""
        with self._lock:
            if self._summary is not None:
                return self._summary
            return self._make_summary(closed=False)

    def close(self) -> BagSummary:
        """Write remaining messages, the MCAP summary and ``metadata.yaml``; idempotent."""
        with self._lock:
            if self._closed:
                return self._summary  # type: ignore[return-value]
            try:
                self._draining = True
                self._flush_chunk()
                self._stop_thread()
                meta = self._metadata()
                with self._io:
                    self._writer.add_metadata(
                        'rosbag2', {'serialized_metadata': yaml.safe_dump(meta, sort_keys=False)})
                    self._writer.finish()
                    self._stream.truncate()      # no provisional tail beyond the footer
                    self._stream.flush()
                    if self._fsync:
                        os.fsync(self._stream.fileno())
            finally:
                self._stop_thread()
                self._stream.close()
                self._closed = True
            self._write_metadata_yaml(meta)
            self._summary = self._make_summary(closed=True)
            return self._summary

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _check_open(self) -> None:
        if self._closed:
            raise BagWriterError(f'bag {self._directory} is closed')
        if self._thread_error is not None:
            raise BagWriterError(f'bag {self._directory}: the writer thread failed: '
                                 f'{self._thread_error}')

    @staticmethod
    def _check_time(t: int, what: str) -> int:
        if isinstance(t, bool) or not isinstance(t, int):
            try:
                import numpy as np  # local: numpy integers are fine
                if isinstance(t, np.integer):
                    t = int(t)
                else:
                    raise TypeError
            except TypeError:
                raise BagWriterError(f'{what} must be an int of nanoseconds, got {t!r}') from None
        if not 0 <= t < _TIME_END:
            raise BagWriterError(f'{what} must be in [0, 2**64) ns, got {t}')
        return t

    def _declare(self, topic: str, type_name: str, qos: str, type_hash: Optional[str],
                 definition: Optional[str] = None) -> None:
        if not isinstance(topic, str) or not _TOPIC_RE.match(topic):
            raise BagWriterError(f'invalid topic name {topic!r}')
        if topic in self._topics:
            if self._topics[topic].type != type_name:
                raise BagWriterError(
                    f'topic {topic!r} already declared with type {self._topics[topic].type!r}')
            return
        if not isinstance(qos, str):
            raise BagWriterError('offered_qos_profiles must be a YAML string (may be empty)')
        if type_name not in self._schemas:
            if definition is None:
                definition = get_message_definition(type_name, self._prefixes)
                self._hash[type_name] = type_description_hash(type_name, self._prefixes)
            else:
                self._hash[type_name] = str(type_hash or '')
            with self._io:
                self._schemas[type_name] = self._writer.register_schema(
                    name=type_name, encoding='ros2msg', data=definition.encode('utf-8'))
        thash = self._hash[type_name] if type_hash is None else str(type_hash)
        with self._io:
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding='cdr', schema_id=self._schemas[type_name],
                metadata={'offered_qos_profiles': qos, 'topic_type_hash': thash})
        self._qos[topic] = qos
        stats = TopicStats(topic, type_name)
        old = self._drop_only.pop(topic, None)
        if old is not None:
            stats.dropped = old.dropped
        self._topics[topic] = stats
        self._topic_hash[topic] = thash
        self._write_metadata_yaml(self._metadata(provisional=True))

    @staticmethod
    def _copy(data) -> bytes:
        """``bytes(data)`` of a bytes-like ``data``; BagWriterError for anything else."""
        if not isinstance(data, (bytearray, memoryview)):
            raise BagWriterError(f'data must be bytes, got {type(data).__name__}')
        return bytes(data)

    def _add(self, stats: TopicStats, channel: int, payload: bytes, lt: int, pt: int,
             sequence: int) -> None:
        """Buffer one checked message of log time ``lt`` [ns], count it in ``stats`` and the
        bag's totals, and cut the chunk when it is full (the lock is held).
        """
        stats.message_count += 1
        if stats.first_log_time_ns is None or lt < stats.first_log_time_ns:
            stats.first_log_time_ns = lt
        if stats.last_log_time_ns is None or lt > stats.last_log_time_ns:
            stats.last_log_time_ns = lt
        if self._start is None:
            self._start = self._end = lt
        elif lt < self._start:
            self._start = lt
        elif lt > self._end:
            self._end = lt
        self._count += 1
        if self._written_end is not None and lt < self._written_end:
            self._late += 1
        self._pending.append((lt, self._arrival, channel, payload, pt, sequence))
        self._arrival += 1
        self._pending_bytes += len(payload) + 31  # Message record overhead
        if (self._pending_bytes >= self._chunk_size
                or len(self._pending) >= self._chunk_messages):
            self._flush_chunk()

    def _flush_chunk(self) -> None:
        """Cut the buffer as one chunk: written now, or queued for the writer thread."""
        batch, self._pending = self._pending, []   # never hand over the list still filled
        if batch:
            # every message written so far is in this batch or in a finished chunk: the latest
            # log time of the finished chunks is now the latest of all (no pass over the batch)
            self._written_end = self._end
            self._pending_bytes = 0
        if self._batches is None:
            self._write_batch(batch)
        else:
            self._batches.put(batch)

    def _write_batch(self, batch: list) -> None:
        """Sort ``batch`` by (log time, arrival), write it as one chunk, flush the file."""
        with self._io:
            # tuples compare by (log time, arrival), and arrival is unique: a sort in C, no
            # key function called per message under the interpreter lock (0.07 against 0.7 ms
            # for a 1 MiB chunk of 3,168 messages)
            batch.sort()
            added = time.monotonic_ns()
            add = self._writer.add_message
            pause = self._batches is not None and _YIELD_EVERY
            for i, (lt, _, cid, payload, pt, seq) in enumerate(batch):
                add(channel_id=cid, log_time=lt, data=payload, publish_time=pt, sequence=seq)
                if pause and i % _YIELD_EVERY == _YIELD_EVERY - 1 and not self._draining:
                    time.sleep(_YIELD_S)   # let a waiting thread take the GIL
            trace = loop_trace.ACTIVE  # IRS_TRACE: the chunk's end in the loop's timeline
            start = time.monotonic_ns()
            self._writer.flush()  # finishes the chunk (if any) + message indexes, flushes stream
            self._sync()
            if batch:
                self._chunks += 1   # counted once in the file: what a killed writer leaves
            if trace is not None:
                trace.chunk(added, start, time.monotonic_ns(), len(batch))

    def _write_batches(self) -> None:
        """The writer thread: write queued chunks until the ``None`` that ends it."""
        while True:
            batch = self._batches.get()
            if batch is None:
                return
            try:
                self._write_batch(batch)
            except BaseException as exc:   # reported by the next public call
                self._thread_error = exc
                return

    def _stop_thread(self) -> None:
        """Write every queued chunk and end the writer thread (no-op without one)."""
        thread, self._thread = self._thread, None
        if thread is not None:
            self._batches.put(None)
            thread.join()
            if self._thread_error is not None:
                raise BagWriterError(f'bag {self._directory}: the writer thread failed: '
                                     f'{self._thread_error}')

    def _sync(self) -> None:
        """Write the provisional tail after what was written, flush (and fsync if asked)."""
        end = self._stream.tell()
        self._stream.write(_PROVISIONAL_TAIL)
        self._stream.flush()
        self._stream.seek(end)
        if self._fsync:
            os.fsync(self._stream.fileno())

    def _all_drops(self) -> Dict[str, int]:
        d = {t: s.dropped for t, s in self._topics.items() if s.dropped}
        d.update({t: s.dropped for t, s in self._drop_only.items() if s.dropped})
        return d

    def _metadata(self, provisional: bool = False) -> dict:
        """The ``rosbag2_bagfile_information`` of the bag as it is; ``provisional``: the one
        written while the bag is open (topics so far, no counts, :data:`PROVISIONAL_KEY`).
        """
        custom = dict(self._custom)
        if provisional:
            topics = {t: (s.type, self._qos[t], self._topic_hash.get(t, ''), 0)
                      for t, s in self._topics.items()}
            custom[PROVISIONAL_KEY] = PROVISIONAL_TEXT
            return bag_metadata_dict(file_name=self._file_name, topics=topics, start_ns=0,
                                     duration_ns=0, message_count=0, custom_data=custom)
        start = self._start or 0
        duration = (self._end - self._start) if self._count else 0
        topics = {t: (s.type, self._qos[t], self._topic_hash.get(t, ''), s.message_count)
                  for t, s in self._topics.items()}
        drops = self._all_drops()
        custom['irs.dropped_messages'] = str(sum(drops.values()))
        custom['irs.dropped_messages_per_topic'] = json.dumps(drops, sort_keys=True)
        custom['irs.late_messages'] = str(self._late)
        return bag_metadata_dict(file_name=self._file_name, topics=topics, start_ns=start,
                                 duration_ns=duration, message_count=self._count,
                                 custom_data=custom)

    def _write_metadata_yaml(self, meta: dict) -> None:
        """Replace ``metadata.yaml`` atomically (a reader never sees half a file)."""
        tmp = self._directory / 'metadata.yaml.tmp'
        tmp.write_text(yaml.safe_dump({'rosbag2_bagfile_information': meta}, sort_keys=False),
                       encoding='utf-8')
        os.replace(tmp, self._directory / 'metadata.yaml')

    def _make_summary(self, closed: bool) -> BagSummary:
        topics = {t: TopicStats(**vars(s)) for t, s in self._topics.items()}
        for t, s in self._drop_only.items():
            topics[t] = TopicStats(**vars(s))
        return BagSummary(
            directory=str(self._directory), mcap_path=str(self._path),
            message_count=self._count, start_time_ns=self._start or 0,
            end_time_ns=self._end or 0,
            duration_ns=(self._end - self._start) if self._count else 0,
            chunk_count=self._chunks, late_messages=self._late,
            dropped_total=sum(s.dropped for s in topics.values()), topics=topics,
            closed=closed)
