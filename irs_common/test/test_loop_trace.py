"""IRS_TRACE's timeline (irs_common.loop_trace) and the executor that records it."""
import time

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
import rclpy
from rclpy.node import Node

from irs_common import loop_trace
from irs_common.executor import TracedLeanExecutor
from irs_common.loop_trace import LoopTrace, _overlaps, main, report, summarise

MS = 1_000_000


def _synthetic(tmp_path, max_spins=100):
    trace = LoopTrace(str(tmp_path / 't.npz'), max_spins)
    trace.spin(0, 1 * MS, 1 * MS + MS // 10, 2 * MS)           # on time (0.1 ms)
    trace.spin(9 * MS, 10 * MS, 12 * MS, 12 * MS + 5)          # 2 ms late, a chunk's end inside
    trace.spin(19 * MS, 20 * MS, 21 * MS, 23 * MS)             # 1 ms late, a collection inside
    trace.spin(29 * MS, 30 * MS, 30 * MS + 8 * MS // 10, 31 * MS)   # 0.8 ms late, nothing
    trace.spin(39 * MS, -1, 45 * MS, 46 * MS)                  # no due time: not judged
    trace.chunk(10 * MS + MS // 2, 11 * MS, 512)
    trace.chunk(40 * MS, 41 * MS, 100)
    trace.gcs.extend((20 * MS + MS // 5, 20 * MS + 2 * MS // 5, 0))
    trace.call(1 * MS, 1 * MS + 3 * MS // 10, 'Node._tick')
    trace.call(5 * MS, 5 * MS + MS // 2, 'Node._tick')
    trace.call(6 * MS, 6 * MS + MS, 'Recorder.publish_status')
    return trace


def test_late_waits_are_found_and_attributed_to_what_overlapped_them(tmp_path):
    path = _synthetic(tmp_path).save()
    with np.load(path) as data:
        s = summarise(data)
    assert (s.spins, s.timer_wakes, s.late) == (5, 4, 3)
    assert (s.late_in_chunk, s.late_in_gc) == (1, 1)
    assert s.late_p50 == pytest.approx(1.0) and s.late_max == pytest.approx(2.0)
    assert s.long_dispatches == 1 and s.longest_dispatch == pytest.approx(2.0)  # the third spin
    assert s.slowest_calls == [('Recorder.publish_status', 1, pytest.approx(1.0)),
                               ('Node._tick', 2, pytest.approx(0.5))]
    assert (s.chunks, s.chunk_max, s.gcs, s.truncated) == (2, pytest.approx(1.0), 1, False)
    assert summarise(np.load(path), late_ms=1.5).late == 1
    text = report(path)
    assert '3 of 4 (75.00 %)' in text and "during a bag chunk's end: 1" in text
    assert 'neither (the operating system, another thread): 1' in text


def test_a_trace_stops_recording_at_its_limit_and_says_so(tmp_path):
    trace = _synthetic(tmp_path, max_spins=2)
    assert len(trace.spins) == 8 and trace.truncated
    assert '(truncated at IRS_TRACE_SPINS)' in report(trace.save())


@settings(max_examples=300, deadline=None)
@given(spans=st.lists(st.tuples(st.integers(0, 100), st.integers(0, 20)), max_size=8),
       queries=st.lists(st.tuples(st.integers(0, 100), st.integers(0, 20)), min_size=1,
                        max_size=8))
def test_overlaps_equals_the_pairwise_check(spans, queries):
    starts = np.array([a for a, _ in spans], dtype=np.int64)
    ends = np.array([a + d for a, d in spans], dtype=np.int64)
    lo = np.array([a for a, _ in queries], dtype=np.int64)
    hi = np.array([a + d for a, d in queries], dtype=np.int64)
    expected = [any(s <= h and e >= q for s, e in zip(starts, ends)) for q, h in zip(lo, hi)]
    assert _overlaps(starts, ends, lo, hi).tolist() == expected


def test_the_command_reads_traces_and_refuses_a_bad_file_in_one_line(tmp_path, capsys):
    good = _synthetic(tmp_path).save()
    bad = tmp_path / 'bad.npz'
    bad.write_text('not a trace')
    assert main([good]) == 0
    assert 'waits that returned over 0.5 ms after due: 3 of 4' in capsys.readouterr().out
    assert main([str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f'loop_trace: error: {bad}:') and '\n' not in err


def test_the_traced_executor_records_its_waits_and_a_long_timer_callback(context, tmp_path):
    trace = loop_trace.start(str(tmp_path / 'x'))
    try:
        node = Node('trace_probe', context=context)
        calls = []

        def tick():
            calls.append(time.monotonic_ns())
            if len(calls) == 5:
                time.sleep(0.002)           # one long callback: recorded
        node.create_timer(0.001, tick)
        executor = TracedLeanExecutor(trace, context=context)
        executor.add_node(node)
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
        executor.shutdown()
        node.destroy_node()
    finally:
        assert loop_trace.stop() is trace
    spins = np.frombuffer(trace.spins, dtype=np.int64).reshape(-1, 4)
    assert len(spins) >= len(calls) >= 50
    assert (spins[:, 0] <= spins[:, 2]).all() and (spins[:, 2] <= spins[:, 3]).all()
    # every wait had a due time, within the timer's period of its start
    assert (spins[:, 1] >= spins[:, 0]).all() and (spins[:, 1] - spins[:, 0] <= MS).all()
    assert trace.names == ['test_the_traced_executor_records_its_waits_and_a_long_timer_'
                           'callback.<locals>.tick']
    long_calls = np.frombuffer(trace.calls, dtype=np.int64).reshape(-1, 3)
    assert (long_calls[:, 1] - long_calls[:, 0] >= 2 * MS).any()
    assert rclpy.ok(context=context)
