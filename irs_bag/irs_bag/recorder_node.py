r"""``recorder`` node: record topics off DDS into a rosbag2-compatible MCAP bag (``BagWriter``).

Messages are taken as the serialized CDR bytes DDS delivered (subscriptions with ``raw=True``,
never deserialized and re-serialized) and written with :class:`irs_bag.writer.BagWriter`. The
node runs on the lean executor (:func:`irs_common.node_main.run_node`, or composed with the
nodes it records in the ``container``), which hands every waiting message of a ready
subscription straight to its callback. The bag is created at start-up: an output that cannot
be created (or is not empty) is one line and exit code 2 before anything is subscribed, and
its provisional ``metadata.yaml`` is there from the first instant (:mod:`irs_bag.writer`).

Discovery and flushing run on timers: every ``discovery_period`` s the graph is scanned for
wanted topics (rarely, once every named topic is recorded: ``SETTLED_EVERY``), and one topic's
publisher count is refreshed; the bag is ``flush()``-ed every ``flush_period`` s, so a killed
recorder loses at most that much.

Log time
--------
Log time = receive time on the **system clock** (``received_timestamp`` from the message info,
which rmw_fastrtps fills with the reception time), as rosbag2 records ``recv_timestamp`` by
default, also with ``use_sim_time``: sim time is in each message's ``header.stamp`` (and
``/clock`` can be recorded). ``publish_time`` = ``source_timestamp``. Composed with the nodes
it records, the recorder receives their messages handed over in the process
(:mod:`irs_common.intra_process`): log time = publish time = the time of the handover, and no
sequence number (a handover loses nothing).

Lost messages
-------------
``message_info['publication_sequence_number']`` (rmw_fastrtps: per DataWriter, +1 per write) is
checked per topic while the topic has exactly one publisher: a gap of n counts n drops
(``BagWriter.record_drop`` + a warning). The info carries no publisher id, so with several
publishers on one topic gaps cannot be attributed and detection is off for that topic (logged
once). A sequence number that goes back means the publisher restarted (no drop).

Stopping
--------
SIGINT / SIGTERM stop the executor (:func:`~irs_common.node_main.run_nodes`); destroying the
node takes what is still waiting on its subscriptions until ``final_drain`` s pass without a
message (at most 1 s), closes the bag (summary + ``metadata.yaml``), prints one summary line;
exit code 0.

Metadata
--------
``metadata`` is a JSON object text. On a command line, quote it as a YAML string, or ``-p``
parses it as a mapping: ``-p "metadata:='{\"git_commit\": \"abc\"}'"``; in a params file
write it as a quoted string. It becomes the MCAP metadata record ``irs_experiment`` (written at
start, so it survives a crash) plus ``recorder.topics``. With ``node_parameters`` (default),
every other node of the graph is asked once for its parameters, and each answer becomes a
metadata record ``irs_node_parameters`` (:mod:`irs_bag.node_parameters`; asked every
``POLL_PERIOD`` s), so that a bag recorded by hand says what the nodes ran with.
A small ``recorder/status`` message (std_msgs/String, JSON: bag, messages per topic, drops,
chunks; latched) is published every ``status_period`` s, for supervisors and tests.
"""
from __future__ import annotations

import datetime as _dt
import fnmatch
import importlib
import json
import time
from pathlib import Path

from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from irs_common.cli import held_signals
from irs_common.intra_process import HANDOVER_SINK
from irs_common.node_main import run_node
from irs_common.params import declare_table

from .writer import BagWriter, BagWriterError, qos_profiles_yaml
from .msg_definitions import MessageDefinitionError
from .node_parameters import POLL_PERIOD, RECORD, ParameterAsker
from .recorder_params import NODE_PARAMS

#: Where a recorder without ``output`` writes, relative to the working directory.
DEFAULT_OUTPUT = 'runs/bags/irs_bag_%Y_%m_%d-%H_%M_%S'
#: Longest final drain on shutdown [s] (``final_drain`` is the quiet time that ends it).
FINAL_DRAIN_MAX_S = 1.0


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


def parse_metadata(text: str) -> dict:
    """The ``metadata`` parameter: a JSON object; non-string values are JSON-encoded."""
    try:
        obj = json.loads(text or '{}')
    except json.JSONDecodeError as exc:
        raise ValueError(f'metadata must be a JSON object of string -> string: {exc}') from None
    if not isinstance(obj, dict):
        raise ValueError('metadata must be a JSON object of string -> string')
    return {str(k): v if isinstance(v, str) else json.dumps(v) for k, v in obj.items()}


def output_directory(output: str, now=None) -> Path:
    """The bag directory: ``output``, or ``DEFAULT_OUTPUT`` with the date if it is '' (with
    ``-2``, ``-3``, ... appended while that exists: two recorders started in one second).
    """
    if output:
        return Path(output)
    path = base = Path((now or _dt.datetime.now()).strftime(DEFAULT_OUTPUT))
    n = 1
    while path.exists():
        n += 1
        path = base.with_name(f'{base.name}-{n}')
    return path


class _Recorded:
    """One recorded topic: its subscription and sequence bookkeeping."""

    __slots__ = ('topic', 'type_name', 'msg_type', 'sub', 'last_seq', 'single_pub',
                 'warned_multi')

    def __init__(self, topic, type_name, msg_type):
        self.topic, self.type_name, self.msg_type = topic, type_name, msg_type
        self.sub = None
        self.last_seq = None
        self.single_pub = True
        self.warned_multi = False


class Recorder(Node):
    """The recorder node (see the module docstring)."""

    #: Once every explicitly named topic is recorded (and no pattern could match more), the
    #: graph is scanned only on every ``SETTLED_EVERY``-th discovery tick. A scan plus a
    #: publisher count per topic cost 0.5 ms here, a deadline miss each time at 1 kHz.
    SETTLED_EVERY = 10

    def __init__(self, **node_options):
        super().__init__('recorder', **node_options)
        self.p = declare_table(self, NODE_PARAMS)
        topics = [t for t in self.p['topics'] if t]
        if not topics:
            raise ValueError("parameter 'topics' is empty: give topic names or ['*']")
        self.patterns, self.explicit = [], []
        for t in topics:
            if any(c in t for c in '*?['):
                self.patterns.append(t if t.startswith('/') or t == '*' else '/' + t)
            else:
                self.explicit.append(self.resolve_topic_name(t))
        self.exclude = list(self.p['exclude'])
        meta = parse_metadata(self.p['metadata'])
        meta.setdefault('recorder.topics', json.dumps(topics))
        if self.p['compression'] not in ('zstd', 'lz4', 'none'):
            raise ValueError(f"compression must be 'zstd', 'lz4' or 'none', "
                             f"got {self.p['compression']!r}")
        self.recorded: dict[str, _Recorded] = {}
        self.unsupported: set[str] = set()
        self._ticks = 0
        self._next_count = 0
        self.status_pub = None
        self.output = output_directory(self.p['output'])
        # a signal while the bag is created is held until the writer is ours to close
        with held_signals() as held:
            try:
                # background: the chunks are written by the bag's writer thread, so a composed
                # 1 kHz loop does not stop for the 50-100 ms of writing a chunk; chunk_messages
                # bounds the one call of that thread that holds the interpreter lock throughout
                # (a recorder composed with the loop)
                self.writer = BagWriter(self.output, chunk_size=int(self.p['chunk_size']),
                                        chunk_messages=int(self.p['chunk_messages']) or None,
                                        compression=self.p['compression'], background=True)
            except BagWriterError as exc:
                raise ValueError(str(exc)) from None
        try:
            held.deliver()
            self._start(meta, topics)
        except BaseException:
            # a signal or an error before the node is handed to the executor: nobody will
            # destroy it, so the bag is closed here (summary, metadata.yaml, the closing line)
            print(self.close(), flush=True)
            raise

    def _start(self, meta: dict, topics: list) -> None:
        """The metadata record, the status publisher and the timers (after the bag exists)."""
        self.writer.add_metadata('irs_experiment', meta)
        if self.p['status_period'] > 0:
            self.status_pub = self.create_publisher(
                String, 'recorder/status',
                QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL))
            self.create_timer(self.p['status_period'], self.publish_status)
        self.create_timer(self.p['discovery_period'], self._discover)
        self.create_timer(self.p['flush_period'], self._flush)
        self.asker = None
        if self.p['node_parameters']:
            self.asker = ParameterAsker(self, self._write_node_parameters,
                                        parameter_value_to_python)
            self.create_timer(POLL_PERIOD, self.asker.poll)
        self.get_logger().info(
            f"recording {topics} to {self.output} ({self.p['compression']})")

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
            except (BagWriterError, ImportError, AttributeError, ValueError,
                    MessageDefinitionError) as exc:
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
        self.writer.add_topic(name, type_name, ''.join(_qos_text(i) for i in pubs))
        rec = _Recorded(name, type_name, msg_type)

        def on_message(data, info, rec=rec):
            self._write(rec, data, info)
        rec.sub = self.create_subscription(msg_type, name, on_message, qos, raw=True)
        # composed: the handovers of the nodes beside it go straight to the bag
        setattr(rec.sub, HANDOVER_SINK, self.writer.appender(name))
        self.recorded[name] = rec
        self.get_logger().info(
            f"subscribed {name} [{type_name}] ({'best effort' if best_effort else 'reliable'}"
            f"{', transient local' if latched else ''}, depth {self.p['qos_depth']})")

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

    def _discover(self):
        """Discovery tick: scan the graph (rarely once settled), count one topic's publishers.

        The publisher counts (sequence-gap detection needs a single publisher) are refreshed one
        topic per tick, round robin, so no tick costs more than one graph query plus the scan.
        """
        self._ticks += 1
        settled = (not self.patterns and bool(self.explicit)
                   and all(t in self.recorded for t in self.explicit))
        if not settled or self._ticks % self.SETTLED_EVERY == 0:
            self.discover()
        recs = list(self.recorded.values())
        if recs:
            self._next_count %= len(recs)
            self.update_publisher_counts(recs[self._next_count:self._next_count + 1])
            self._next_count += 1

    # ------------------------------------------------------------ writing
    def _write(self, rec: _Recorded, data: bytes, info: dict):
        """Write one message (CDR ``data``) with its receive time; count sequence gaps."""
        recv = info.get('received_timestamp') or time.time_ns()
        src = info.get('source_timestamp') or recv
        seq = info.get('publication_sequence_number')
        if seq is not None and rec.single_pub:
            if rec.last_seq is not None and seq > rec.last_seq + 1:
                lost = seq - rec.last_seq - 1
                self.writer.record_drop(rec.topic, lost)
                self.get_logger().warning(
                    f'{rec.topic}: {lost} message(s) lost (publication sequence '
                    f'{rec.last_seq} -> {seq})')
            rec.last_seq = seq
        self.writer.write(rec.topic, rec.type_name, data, recv, src, (seq or 0) & 0xFFFFFFFF)

    def _write_node_parameters(self, node: str, params: dict) -> None:
        if self.writer.closed:
            return
        self.writer.add_metadata(RECORD, {'node': node,
                                          'parameters': json.dumps(params, sort_keys=True)})
        self.get_logger().info(f'{node}: its {len(params)} parameters are in the bag')

    def _flush(self):
        if not self.writer.closed:
            self.writer.flush()

    def publish_status(self):
        if self.status_pub is None or self.writer.closed:
            return
        s = self.writer.summary()
        self.status_pub.publish(String(data=json.dumps({
            'bag': str(self.writer.directory),
            'messages': {t: st.message_count for t, st in s.topics.items()},
            'dropped': {t: st.dropped for t, st in s.topics.items() if st.dropped},
            'chunks': s.chunk_count,
        }, sort_keys=True)))

    # ------------------------------------------------------------ stopping
    def _take_waiting(self) -> int:
        """Write every message waiting on the subscriptions (no executor); how many."""
        n = 0
        for rec in self.recorded.values():
            handle = rec.sub.handle
            while True:
                taken = handle.take_message(rec.msg_type, True)
                if taken is None:
                    break
                self._write(rec, *taken)
                n += 1
        return n

    def final_drain(self) -> None:
        """Take what is still in flight until ``final_drain`` s pass without a message."""
        quiet = self.p['final_drain']
        start = last = time.monotonic()
        while quiet > 0:
            try:
                got = self._take_waiting()
            except Exception as exc:   # the context is gone: nothing more to take
                self.get_logger().warning(f'final drain stopped: {exc}')
                return
            now = time.monotonic()
            if got:
                last = now
            if now - last >= quiet or now - start >= FINAL_DRAIN_MAX_S:
                return
            time.sleep(0.002)

    def close(self) -> str:
        """Close the bag; return the one-line summary."""
        s = self.writer.close()
        per = ', '.join(f'{t}: {st.message_count}' for t, st in sorted(s.topics.items())
                        if st.type)
        drops = ', '.join(f'{t}: {st.dropped}' for t, st in sorted(s.topics.items())
                          if st.dropped) or 'none'
        return (f'recorder: closed {s.directory}: {s.message_count} messages in '
                f'{s.duration_ns * 1e-9:.3f} s ({per or "no topic matched"}); dropped: '
                f'{s.dropped_total} ({drops})')

    def destroy_node(self):
        if getattr(self, 'asker', None) is not None:
            self.asker.close()
        if not self.writer.closed:
            self.final_drain()
            print(self.close(), flush=True)
        super().destroy_node()


def main(args=None) -> int:
    """The ``recorder`` executable: :class:`Recorder` on the lean executor until SIGINT."""
    return run_node(Recorder, args)


if __name__ == '__main__':
    import sys
    sys.exit(main())
