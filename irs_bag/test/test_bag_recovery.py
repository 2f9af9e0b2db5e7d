"""Crash safety: truncated / unclosed / killed recordings give BagError or a recovered prefix."""

import sys


import os
import shutil
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import breakup_chunk
from rosbags.typesys import Stores, get_typestore

from irs_bag import info as bag_info
from irs_bag import BagError, BagReader, recover, validate
from irs_bag.writer import BagWriter

TS = get_typestore(Stores.ROS2_JAZZY)
JS = 'sensor_msgs/msg/JointState'
T0 = 1_750_000_000_000_000_000
N = 3000


def joint_state_bytes(k):
    g = TS.types
    t = T0 + k * 1_000_000
    m = g[JS](header=g['std_msgs/msg/Header'](
        stamp=g['builtin_interfaces/msg/Time'](sec=t // 10**9, nanosec=t % 10**9),
        frame_id='arm'), name=['a', 'b'], position=np.array([0.001 * k, -0.002 * k]),
        velocity=np.array([float(k), 1.0]), effort=np.zeros(0))
    return t, bytes(TS.serialize_cdr(m, JS))


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    """A closed bag of N messages in small chunks, on two topics, plus chunk boundaries."""
    d = tmp_path_factory.mktemp('rec') / 'run'
    written = []
    with BagWriter(d, chunk_size=2048) as w:
        w.add_metadata('experiment', {'file': 'e.yaml'})
        for k in range(N):
            t, b = joint_state_bytes(k)
            topic = '/a/joint_states' if k % 3 else '/b/joint_states'
            w.write(topic, JS, b, t)
            written.append((topic, JS, t, b))
    path = d / 'run_0.mcap'
    with open(path, 'rb') as f:
        s = make_reader(f).get_summary()
        ends = []  # (end offset of chunk record, messages in it)
        for ci in s.chunk_indexes:
            f.seek(ci.chunk_start_offset + 1 + 8)
            chunk = Chunk.read(ReadDataStream(f))
            n = sum(1 for r in breakup_chunk(chunk) if isinstance(r, Message))
            ends.append((ci.chunk_start_offset + ci.chunk_length, n))
    assert sum(n for _, n in ends) == N
    return d, path, written, ends


def _expected_count(ends, cut):
    return sum(n for end, n in ends if end <= cut)


CUTS = [0, 5, 8, 40, 0.05, 0.2, 0.37, 0.5, 0.61, 0.83, 0.97, -200, -40, -1]


def _summary_start(data):
    """Where the summary section starts (= the end of the data section), from the footer."""
    import struct
    return struct.unpack_from('<Q', data, len(data) - 8 - 29 + 9)[0]


@pytest.mark.parametrize('cut', CUTS)
def test_truncated_file(bag, tmp_path, cut):
    d, path, written, ends = bag
    data = path.read_bytes()
    n = cut if isinstance(cut, int) and cut >= 0 else (
        len(data) + cut if isinstance(cut, int) else int(len(data) * cut))
    bad = tmp_path / 'cut.mcap'
    bad.write_bytes(data[:n])
    if n < 8:   # not even the magic: not a bag
        for call in (BagReader, recover):
            with pytest.raises(BagError, match='not an MCAP file'):
                call(bad)
        assert not validate(bad).ok
        return
    expected = _expected_count(ends, n)
    rep = validate(bad)
    assert rep.ok and not rep.complete and rep.message_count == expected, rep
    assert len(rep.warnings) == 1 and 'unfinished' in rep.warnings[0]
    rec = recover(bad)
    if n >= _summary_start(data):
        # cut inside the summary: the data section is whole, read without the summary
        assert rec.complete and rec.error is None and len(rec) == N
        with BagReader(bad) as r:
            assert [m.data for m in r.messages()] == [w[3] for w in written]
            assert len(r.warnings) == 1 and 'unfinished' in r.warnings[0]
        return
    # the default refuses a prefix with a one-line BagError that names the file ...
    with pytest.raises(BagError, match='recover') as ei:
        BagReader(bad)
    assert '\n' not in str(ei.value) and 'cut.mcap' in str(ei.value)
    # ... allow_partial reads it, with one warning line
    with BagReader(bad, allow_partial=True) as r:
        assert r.partial and len(r.warnings) == 1 and 'recovered prefix' in r.warnings[0]
        assert [m.data for m in r.messages()] == [w[3] for w in written[:expected]]
        assert r.message_count == expected
        assert sum(t.message_count for t in r.topics.values()) == expected
    # recovery gives exactly the messages of the complete chunks, as a prefix
    assert not rec.complete and rec.error
    assert len(rec) == expected
    assert [(m.topic, m.type, m.log_time_ns, m.data) for m in rec] == written[:expected]
    assert rec.chunks == sum(1 for end, _ in ends if end <= n)
    if n > 200:
        assert ('experiment', {'file': 'e.yaml'}) in rec.metadata


def test_recover_complete_file(bag):
    d, path, written, _ = bag
    rec = recover(d)
    assert rec.complete and rec.error is None
    assert [(m.topic, m.type, m.log_time_ns, m.data) for m in rec] == written


def test_recover_stops_at_corrupt_chunk(bag, tmp_path):
    d, path, written, ends = bag
    data = bytearray(path.read_bytes())
    k = 5
    data[ends[k][0] - 20] ^= 0x55  # inside chunk k's compressed data
    bad = tmp_path / 'corrupt.mcap'
    bad.write_bytes(bytes(data))
    rec = recover(bad)
    expected = sum(n for _, n in ends[:k])
    assert len(rec) == expected
    assert [m.data for m in rec] == [w[3] for w in written[:expected]]


def test_copy_of_unclosed_bag_is_recoverable(tmp_path):
    """Simulate a crash: copy the file while the writer is still open (no summary)."""
    d = tmp_path / 'live'
    w = BagWriter(d, chunk_size=1024)
    written = []
    for k in range(500):
        t, b = joint_state_bytes(k)
        w.write('/js', JS, b, t)
        written.append(b)
        if k in (0, 137, 499):
            snap = tmp_path / f'snap{k}'
            shutil.copytree(d, snap)
            assert not (snap / 'metadata.yaml').exists()
            rec = recover(snap)
            assert [m.data for m in rec] == written[:len(rec)]
            # nothing buffered beyond one chunk is lost
            unflushed = w._pending_bytes  # noqa: SLF001 - white-box bound
            assert len(rec) >= len(written) - unflushed // 60 - 1
            with pytest.raises(BagError, match='recover'):
                BagReader(snap)
            assert bag_info.main([str(snap)]) == 0   # on the prefix, with a warning
    w.flush()
    snap = tmp_path / 'flushed'
    shutil.copytree(d, snap)
    assert [m.data for m in recover(snap)] == written
    w.close()
    assert validate(d).ok


CHILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
from irs_bag.writer import BagWriter
from rosbags.typesys import Stores, get_typestore
ts = get_typestore(Stores.ROS2_JAZZY)
g = ts.types
w = BagWriter(sys.argv[2], chunk_size=4096)
for k in range(10**7):
    t = 10**18 + k * 10**6
    m = g['std_msgs/msg/Header'](stamp=g['builtin_interfaces/msg/Time'](
        sec=t // 10**9, nanosec=t % 10**9), frame_id=str(k))
    w.write('/h', 'std_msgs/msg/Header', bytes(ts.serialize_cdr(m, 'std_msgs/msg/Header')), t)
    if k == 3000:
        print('ready', flush=True)
"""


def test_sigkill_during_recording(tmp_path):
    pkg_root = str(Path(__file__).resolve().parents[1])
    d = tmp_path / 'killed'
    p = subprocess.Popen([sys.executable, '-c', CHILD, pkg_root, str(d)],
                         stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == 'ready'
    finally:
        os.kill(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    assert p.returncode == -signal.SIGKILL
    with pytest.raises(BagError):
        BagReader(d)
    rec = recover(d)
    assert len(rec) >= 2900 and not rec.complete
    assert [m.topic for m in rec] == ['/h'] * len(rec)
    # consecutive frame ids 0..n-1: a gap-free prefix
    ids = [TS.deserialize_cdr(m.data, 'std_msgs/msg/Header').frame_id for m in rec]
    assert ids == [str(k) for k in range(len(rec))]
