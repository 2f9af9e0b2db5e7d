r"""``recorder`` node: record topics off DDS into a rosbag2-compatible MCAP bag (``BagWriter``).

Messages are taken as the serialized CDR bytes DDS delivered (never deserialized and
re-serialized) and written with :class:`irs_bag.writer.BagWriter`.

How messages are drained (and why not with an rclpy executor)
-------------------------------------------------------------
rclpy's executors lose a large share of the messages at 8 topics x 1 kHz in one process here
(each message costs a task, a callback lookup and a future), and
``rclpy.experimental.EventsExecutor`` stalled in our tests. The recorder therefore does not
register its subscriptions with the node at all: it creates bare subscription handles
(``rclpy.impl.implementation_singleton.rclpy_implementation.Subscription``, exactly what
``Node.create_subscription`` creates internally in rclpy 7.1.6) and runs its own loop in the main
thread:

1. build an rclpy ``WaitSet`` (``_rclpy.WaitSet``) over those handles and wait (<= 50 ms);
2. for every ready subscription, call ``handle.take_message(msg_type, True)`` until it returns
   ``None`` (the low-level call rclpy's executor makes in ``_take_subscription``; with
   ``raw=True`` it returns ``(cdr_bytes, message_info)``);
3. write the bytes with log time = ``message_info['received_timestamp']``.

This is internal rclpy API (``rclpy.impl``), checked against rclpy 7.1.6; if it changes, this
module is the one place to adapt. Since the handles are not in ``node.subscriptions``, the node
itself (parameter services, the ``recorder/status`` timer) is spun by an ordinary
``SingleThreadedExecutor`` in a second thread without ever touching the recorded topics.

Log time
--------
Log time = receive time on the **system clock** (``received_timestamp`` from the message info,
which rmw_fastrtps fills with the reception time), as rosbag2 records ``recv_timestamp`` by
default. This is also the case for a recorder run with ``use_sim_time``: sim time is in each
message's ``header.stamp`` (and ``/clock`` can be recorded), and ``bag play --clock-from header``
replays /clock from those stamps. ``publish_time`` = ``source_timestamp``.

Lost messages
-------------
``message_info['publication_sequence_number']`` (rmw_fastrtps: per DataWriter, +1 per write) is
checked per topic while the topic has exactly one publisher: a gap of n counts n drops
(``BagWriter.record_drop`` + a warning). The info carries no publisher id, so with several
publishers on one topic gaps cannot be attributed and detection is off for that topic (logged
once). A sequence number that goes back means the publisher restarted (no drop).

Stopping
--------
SIGINT / SIGTERM set a flag (rclpy's own signal handlers are disabled so the context stays
valid). The loop then drains for a short quiet period (``final_drain`` s without traffic, max
1 s), closes the bag (summary + ``metadata.yaml``), prints one summary line and exits 0.
Metadata
--------
``metadata`` is a JSON object text. On a command line, quote it as a YAML string, or ``-p``
parses it as a mapping: ``-p "metadata:='{\"git_commit\": \"abc\"}'"``; in a params file
write it as a quoted string. It becomes the MCAP metadata record ``irs_experiment`` (written at
start, so it survives a crash) plus ``recorder.topics``.

A small ``recorder/status`` message (std_msgs/String, JSON: bag, messages per topic, drops,
chunks; latched) is published every ``status_period`` s, for supervisors and tests.

The bag is ``flush()``-ed every ``flush_period`` s, so a killed recorder loses at most that much.
"""
from __future__ import annotations

import datetime as _dt
import fnmatch
import importlib
import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from rclpy.type_support import check_is_valid_msg_type
from std_msgs.msg import String

from irs_common.params import declare_table

from .writer import BagWriter, BagWriterError, qos_profiles_yaml
from .msg_definitions import MessageDefinitionError
from .recorder_params import NODE_PARAMS

def _import_type(type_name: str):
    """``'pkg/msg/Type'`` -> the Python message class."""
    parts = type_name.split('/')
    if len(parts) != 3:
        raise ValueError(f'unexpected type name {type_name!r}')
    return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])


def _qos_text(info) -> str:
    """rosbag2-style YAML for one publisher endpoint's QoS."""
    q = info.qos_profile
    rel = 'best_effort' if q.reliability == ReliabilityPolicy.BEST_EFFORT else 'reliable'
    dur = ('transient_local' if q.durability == DurabilityPolicy.TRANSIENT_LOCAL
           else 'volatile')
    hist = 'keep_all' if q.history == HistoryPolicy.KEEP_ALL else 'keep_last'
    return qos_profiles_yaml(rel, dur, hist, depth=q.depth)


def _uncreatable(directory: Path) -> str:
    """Why ``directory`` cannot be created (the writer makes missing parents: the nearest
    existing ancestor must be a writable directory), or '' if it can (or exists).
    """
    ancestor = directory.absolute()
    while not ancestor.exists():
        ancestor = ancestor.parent
    if ancestor == directory.absolute():
        return ''
    if not ancestor.is_dir():
        return f'{ancestor} is not a directory'
    if not os.access(ancestor, os.W_OK | os.X_OK):
        return f'{ancestor} is not writable'
    return ''


def parse_metadata(text: str) -> dict:
    """The ``metadata`` parameter: a JSON object; non-string values are JSON-encoded."""
    try:
        obj = json.loads(text or '{}')
    except json.JSONDecodeError as exc:
        raise ValueError(f'metadata must be a JSON object of string -> string: {exc}') from None
    if not isinstance(obj, dict):
        raise ValueError('metadata must be a JSON object of string -> string')
    return {str(k): v if isinstance(v, str) else json.dumps(v) for k, v in obj.items()}


class _Recorded:
    """One recorded topic: its bare subscription handle and sequence bookkeeping."""

    __slots__ = ('topic', 'type_name', 'msg_type', 'handle', 'last_seq', 'single_pub',
                 'warned_multi')

    def __init__(self, topic, type_name, msg_type, handle):
        self.topic, self.type_name, self.msg_type, self.handle = topic, type_name, msg_type, handle
        self.last_seq = None
        self.single_pub = True
        self.warned_multi = False


class Recorder(Node):
    """The recorder node (see the module docstring)."""

    def __init__(self, **node_options):
        super().__init__('recorder', **node_options)
        self.p = declare_table(self, NODE_PARAMS)
        topics = [t for t in self.p['topics'] if t]
        if not topics:
            raise ValueError("parameter 'topics' is empty: give topic names or ['*']")
        self.patterns = []
        self.explicit = []
        for t in topics:
            if any(c in t for c in '*?['):
                self.patterns.append(t if t.startswith('/') or t == '*' else '/' + t)
            else:
                self.explicit.append(self.resolve_topic_name(t))
        self.exclude = list(self.p['exclude'])
        meta = parse_metadata(self.p['metadata'])
        self.output = Path(self.p['output'] or _dt.datetime.now().strftime(
            'irs_bag_%Y_%m_%d-%H_%M_%S'))
        if self.output.exists() and (not self.output.is_dir() or any(self.output.iterdir())):
            raise ValueError(f'bag directory {self.output} already exists and is not empty')
        problem = _uncreatable(self.output)
        if problem:     # found now, not when the first topic appears
            raise ValueError(f'cannot create the bag directory {self.output}: {problem}')
        if self.p['compression'] not in ('zstd', 'lz4', 'none'):
            raise ValueError(f"compression must be 'zstd', 'lz4' or 'none', "
                             f"got {self.p['compression']!r}")
        meta.setdefault('recorder.topics', json.dumps(topics))
        self.meta = meta
        # The bag is created when the first topic is subscribed (nothing matched -> no bag).
        self.writer = None
        self.recorded: dict[str, _Recorded] = {}
        self.unsupported: set[str] = set()
        self.stop_requested = threading.Event()
        self.status_pub = None
        if self.p['status_period'] > 0:
            self.status_pub = self.create_publisher(
                String, 'recorder/status',
                QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL))
            self.create_timer(self.p['status_period'], self.publish_status)
        self.get_logger().info(
            f"recording {topics} to {self.output} ({self.p['compression']})")

    def _ensure_writer(self) -> BagWriter:
        if self.writer is None:
            # background: the chunks are written by the bag's writer thread, so neither the
            # drain loop nor a composed 1 kHz loop stops for 50-100 ms at every chunk
            self.writer = BagWriter(self.output, chunk_size=int(self.p['chunk_size']),
                                    compression=self.p['compression'], background=True)
            self.writer.add_metadata('irs_experiment', self.meta)
        return self.writer

    # ------------------------------------------------------------ discovery
    def _wanted(self, name: str) -> bool:
        if name in self.explicit:
            return True
        if any(fnmatch.fnmatchcase(name, x) for x in self.exclude):
            return False
        return any(p == '*' or fnmatch.fnmatchcase(name, p) for p in self.patterns)

    def discover(self) -> bool:
        """Subscribe to wanted topics that appeared; True if the subscription set changed."""
        changed = False
        for name, types in self.get_topic_names_and_types():
            if name in self.recorded or name in self.unsupported or not self._wanted(name):
                continue
            if len(types) != 1:
                self.get_logger().warning(f'{name}: several types {types}, not recorded')
                self.unsupported.add(name)
                continue
            pubs = self.get_publishers_info_by_topic(name)
            if not pubs:
                continue  # only subscribers so far: wait for a publisher to know the QoS
            try:
                self._subscribe(name, types[0], pubs)
                changed = True
            except BagWriterError as exc:
                if self.writer is None:   # the bag directory cannot be created
                    raise ValueError(str(exc)) from None
                self.get_logger().error(f'{name}: cannot record type {types[0]}: {exc}')
                self.unsupported.add(name)
            except (ImportError, AttributeError, ValueError, MessageDefinitionError) as exc:
                self.get_logger().error(f'{name}: cannot record type {types[0]}: {exc}')
                self.unsupported.add(name)
        return changed

    def _subscribe(self, name, type_name, pubs):
        msg_type = _import_type(type_name)
        best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
                          for i in pubs)
        latched = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in pubs)
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=int(self.p['qos_depth']),
            reliability=(ReliabilityPolicy.BEST_EFFORT if best_effort
                         else ReliabilityPolicy.RELIABLE),
            durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                        else DurabilityPolicy.VOLATILE))
        self._ensure_writer().add_topic(name, type_name, ''.join(_qos_text(i) for i in pubs))
        check_is_valid_msg_type(msg_type)  # imports the type support
        rec = _Recorded(name, type_name, msg_type, None)
        rec.handle = self._open(rec, qos)
        self.recorded[name] = rec
        self.get_logger().info(
            f"subscribed {name} [{type_name}] ({'best effort' if best_effort else 'reliable'}"
            f"{', transient local' if latched else ''}, depth {self.p['qos_depth']})")

    def _open(self, rec: _Recorded, qos):
        """A bare subscription handle, drained by :meth:`run` (not seen by any executor)."""
        with self.handle:
            return _rclpy.Subscription(self.handle, rec.msg_type, rec.topic,
                                       qos.get_c_qos_profile())

    def update_publisher_counts(self, recs=None):
        """Note, for ``recs`` (default: every recorded topic), whether one publisher is left."""
        for rec in (self.recorded.values() if recs is None else recs):
            single = self.count_publishers(rec.topic) <= 1
            if not single and not rec.warned_multi:
                self.get_logger().warning(
                    f'{rec.topic}: several publishers; loss detection by sequence number is '
                    'off for this topic while they coexist')
                rec.warned_multi = True
            if single != rec.single_pub:
                rec.last_seq = None
            rec.single_pub = single

    # ------------------------------------------------------------ draining
    def take_all(self, rec: _Recorded) -> int:
        """Take every message waiting on ``rec``; return how many were written."""
        n = 0
        writer = self.writer
        while True:
            got = rec.handle.take_message(rec.msg_type, True)
            if got is None:
                return n
            self._write(writer, rec, *got)
            n += 1

    def _write(self, writer, rec: _Recorded, data: bytes, info: dict):
        """Write one message (CDR ``data``) with its receive time; count sequence gaps."""
        recv = info.get('received_timestamp') or time.time_ns()
        src = info.get('source_timestamp') or recv
        seq = info.get('publication_sequence_number')
        if seq is not None and rec.single_pub:
            if rec.last_seq is not None and seq > rec.last_seq + 1:
                lost = seq - rec.last_seq - 1
                writer.record_drop(rec.topic, lost)
                self.get_logger().warning(
                    f'{rec.topic}: {lost} message(s) lost (publication sequence '
                    f'{rec.last_seq} -> {seq})')
            rec.last_seq = seq
        writer.write(rec.topic, rec.type_name, data, recv, src, (seq or 0) & 0xFFFFFFFF)

    def run(self):
        """The drain loop (main thread) until a stop is requested; then close the bag."""
        ctx = self.context
        period_disc = self.p['discovery_period']
        period_flush = self.p['flush_period']
        next_disc = 0.0
        next_flush = time.monotonic() + period_flush
        wait_set = None
        recs: list = []
        quiet_since = None
        stop_deadline = None
        while True:
            now = time.monotonic()
            if not self.stop_requested.is_set() and now >= next_disc:
                next_disc = now + period_disc
                if self.discover() or wait_set is None:
                    recs = list(self.recorded.values())
                    wait_set = _rclpy.WaitSet(len(recs), 0, 0, 0, 0, 0, ctx.handle)
                self.update_publisher_counts()
            if now >= next_flush and self.writer is not None:
                self.writer.flush()
                next_flush = now + period_flush
            got = 0
            if recs:
                wait_set.clear_entities()
                for rec in recs:
                    wait_set.add_subscription(rec.handle)
                wait_set.wait(50_000_000)
                ready = set(wait_set.get_ready_entities('subscription'))
                for rec in recs:
                    if rec.handle.pointer in ready:
                        got += self.take_all(rec)
            elif not self.stop_requested.is_set():
                self.stop_requested.wait(min(0.05, period_disc))
            if self.stop_requested.is_set():
                now = time.monotonic()
                if stop_deadline is None:
                    stop_deadline = now + 1.0
                    quiet_since = now
                if got:
                    quiet_since = now
                if not recs or now - quiet_since >= self.p['final_drain'] or now >= stop_deadline:
                    break

    def publish_status(self):
        if self.status_pub is None:
            return
        if self.writer is None:
            self.status_pub.publish(String(data=json.dumps(
                {'bag': str(self.output), 'messages': {}, 'dropped': {}, 'chunks': 0})))
            return
        if self.writer.closed:
            return
        s = self.writer.summary()
        self.status_pub.publish(String(data=json.dumps({
            'bag': str(self.writer.directory),
            'messages': {t: st.message_count for t, st in s.topics.items()},
            'dropped': {t: st.dropped for t, st in s.topics.items() if st.dropped},
            'chunks': s.chunk_count,
        }, sort_keys=True)))

    def close(self) -> str:
        """Close the bag; return the one-line summary."""
        for rec in self.recorded.values():
            if not isinstance(rec.handle, Subscription):
                rec.handle.destroy_when_not_in_use()
        if self.writer is None:
            return (
                f'recorder: nothing recorded (no topic matched), no bag written at {self.output}'
            )
        s = self.writer.close()
        per = ', '.join(f'{t}: {st.message_count}' for t, st in sorted(s.topics.items())
                        if st.type)
        drops = ', '.join(f'{t}: {st.dropped}' for t, st in sorted(s.topics.items())
                          if st.dropped) or 'none'
        return (f'recorder: closed {s.directory}: {s.message_count} messages in '
                f'{s.duration_ns * 1e-9:.3f} s ({per}); dropped: {s.dropped_total} ({drops})')


class ComposableRecorder(Recorder):
    """The recorder as an ordinary node, for the ``container`` (composition).

    Composed with the nodes it records, the recorder takes their messages inside the process
    (Fast DDS delivers without the network stack or another process to wake), which is what a
    real-time loop at 1 kHz can afford. Its recording subscriptions are rclpy subscriptions with
    ``raw=True`` (the CDR bytes, never deserialised) whose callbacks write to the bag; the
    executor (:class:`irs_common.executor.LeanExecutor`) drains each one completely per wake, as
    :meth:`Recorder.run` does. Discovery and flushing run on timers; destroying the node closes
    the bag and prints the summary line.
    """

    #: Once every explicitly named topic is recorded (and no pattern could match more), the
    #: graph is scanned only on every ``SETTLED_EVERY``-th discovery tick. A scan plus a
    #: publisher count per topic cost 0.5 ms here, a deadline miss each time at 1 kHz.
    SETTLED_EVERY = 10

    def __init__(self, **node_options):
        super().__init__(**node_options)
        self._ticks = 0
        self._next_count = 0
        self.create_timer(self.p['discovery_period'], self._discover)
        self.create_timer(self.p['flush_period'], self._flush)

    def _open(self, rec: _Recorded, qos):
        def on_message(data, info, rec=rec):
            self._write(self.writer, rec, data, info)
        return self.create_subscription(rec.msg_type, rec.topic, on_message, qos, raw=True)

    def _discover(self):
        """Discovery tick: scan the graph (rarely once settled), count one topic's publishers.

        The publisher counts (sequence-gap detection needs a single publisher) are refreshed one
        topic per tick, round robin, so no tick costs more than one graph query plus the scan.
        """
        self._ticks += 1
        settled = (not self.patterns and bool(self.explicit)
                   and all(t in self.recorded for t in self.explicit))
        if not settled or self._ticks % self.SETTLED_EVERY == 0:
            try:
                self.discover()
            except ValueError as exc:      # the bag directory cannot be created
                self.get_logger().error(str(exc))
                raise
        recs = list(self.recorded.values())
        if recs:
            self._next_count %= len(recs)
            self.update_publisher_counts(recs[self._next_count:self._next_count + 1])
            self._next_count += 1

    def _flush(self):
        if self.writer is not None and not self.writer.closed:
            self.writer.flush()

    def destroy_node(self):
        if self.writer is None or not self.writer.closed:
            print(self.close(), flush=True)
        super().destroy_node()


def main(args=None) -> int:
    # Signals are ours from the first instant (rclpy's handlers are off): a Ctrl-C that arrives
    # while the node is still being built must end the run cleanly too.
    stop = threading.Event()
    holder = {}

    def on_signal(signum, frame):
        stop.set()
        if 'node' in holder:
            holder['node'].stop_requested.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    executor = None
    spin_thread = None
    try:
        try:
            node = Recorder()
        except ValueError as exc:
            print(f'[FATAL] recorder: configuration error: {exc}', file=sys.stderr)
            return 2
        holder['node'] = node
        if stop.is_set():
            node.stop_requested.set()
        executor = SingleThreadedExecutor()
        executor.add_node(node)

        def spin():
            while not node.stop_requested.is_set() and rclpy.ok():
                executor.spin_once(timeout_sec=0.1)

        spin_thread = threading.Thread(target=spin, name='recorder-params', daemon=True)
        spin_thread.start()
        try:
            node.run()
        except ValueError as exc:
            print(f'[FATAL] recorder: {exc}', file=sys.stderr)
            return 2
        node.stop_requested.set()
        spin_thread.join(timeout=2.0)
        line = node.close()
        print(line, flush=True)
        return 0
    finally:
        if node is not None:
            node.stop_requested.set()
            if getattr(node, 'writer', None) is not None and not node.writer.closed:
                node.writer.close()
            if spin_thread is not None:
                spin_thread.join(timeout=2.0)
            if executor is not None:
                executor.shutdown(timeout_sec=1.0)
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
