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
    trace.spin(49 * MS, 50 * MS, 51 * MS, 51 * MS + 5)          # 1 ms late, messages being added
    trace.chunk(8 * MS, 10 * MS + MS // 2, 11 * MS, 512)       # its end overlaps the second
    trace.chunk(50 * MS + MS // 2, 52 * MS, 53 * MS, 100)      # adding overlaps the sixth
    trace.nodes = ['/vehicle_sim', '/recorder']
    trace.gcs.extend((20 * MS + MS // 5, 20 * MS + 2 * MS // 5, 0))
    trace.call(1 * MS, 1 * MS + 3 * MS // 10, 'Node._tick')
    trace.call(5 * MS, 5 * MS + MS // 2, 'Node._tick')
    trace.call(6 * MS, 6 * MS + MS, 'Recorder.publish_status')
    return trace


def test_late_waits_are_found_and_attributed_to_what_overlapped_them(tmp_path):
    path = _synthetic(tmp_path).save()
    with np.load(path) as data:
        s = summarise(data)
    assert (s.spins, s.timer_wakes, s.late) == (6, 5, 4)
    assert (s.late_in_chunk, s.late_in_adding, s.late_in_gc) == (1, 1, 1)
    assert s.late_p50 == pytest.approx(1.0) and s.late_max == pytest.approx(2.0)
    assert s.long_dispatches == 1 and s.longest_dispatch == pytest.approx(2.0)  # the third spin
    assert s.slowest_calls == [('Recorder.publish_status', 1, pytest.approx(1.0)),
                               ('Node._tick', 2, pytest.approx(0.5))]
    assert (s.chunks, s.chunk_max, s.gcs, s.truncated) == (2, pytest.approx(1.0), 1, False)
    assert summarise(np.load(path), late_ms=1.5).late == 1
    text = report(path)
    assert text.startswith(f'{path} (/vehicle_sim, /recorder): ')
    assert '4 of 5 (80.00 %)' in text and "during a bag chunk's end: 1;" in text
    assert "while the writer added a chunk's messages: 1;" in text
    assert 'none of these (another thread, another process, the VM): 1' in text


def test_a_trace_on_simulated_time_is_not_judged(tmp_path):
    trace = _synthetic(tmp_path)
    trace.sim_time = True
    path = trace.save()
    s = summarise(np.load(path))
    assert (s.timer_wakes, s.late, s.spins) == (0, 0, 6)
    text = report(path)
    assert 'simulated time: the waits are not judged' in text and 'after due' not in text


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


def _bad_files(tmp_path, good):
    """Files that are not traces, each with what the refusal names."""
    text = tmp_path / 'text.npz'
    text.write_text('not a trace')
    single = tmp_path / 'single.npy'
    np.save(single, np.zeros(3))
    cut = tmp_path / 'cut.npz'
    cut.write_bytes(open(good, 'rb').read()[:200])
    flat = tmp_path / 'flat.npz'
    arrays = dict(np.load(good))
    np.savez(flat, **{**arrays, 'spins': np.zeros(8, dtype=np.int64)})
    partial = tmp_path / 'partial.npz'
    np.savez(partial, spins=arrays['spins'])
    return [(text, 'not an IRS_TRACE file'), (single, 'a single numpy array'),
            (cut, 'not an IRS_TRACE file'), (flat, "'spins' has shape (8,)"),
            (partial, "no 'calls' array"), (tmp_path / 'missing.npz', 'No such file'),
            (tmp_path, 'Is a directory')]


def test_the_command_reads_traces_and_refuses_a_bad_file_in_one_line(tmp_path, capsys):
    good = _synthetic(tmp_path).save()
    assert main([good]) == 0
    assert 'waits that returned over 0.5 ms after due: 4 of 5' in capsys.readouterr().out
    for bad, named in _bad_files(tmp_path, good):
        assert main([str(bad)]) == 2, bad
        err = capsys.readouterr().err.strip()
        assert err.startswith(f'loop_trace: error: {bad}: ') and '\n' not in err, err
        assert named in err and 'pickle' not in err, err


@pytest.mark.parametrize('value', ['-1', '0', 'nan', 'inf', 'abc'])
def test_a_threshold_that_is_no_positive_time_is_refused(tmp_path, capsys, value):
    good = _synthetic(tmp_path).save()
    with pytest.raises(SystemExit) as stop:
        main([good, '--late-ms', value])
    assert stop.value.code == 2
    assert 'expected a finite number of ms > 0' in capsys.readouterr().err


@pytest.mark.parametrize('spins, named', [('-5', "IRS_TRACE_SPINS='-5'"),
                                          ('abc', "IRS_TRACE_SPINS='abc'")])
def test_a_bad_spin_limit_or_a_missing_folder_is_refused_before_tracing(tmp_path, monkeypatch,
                                                                        spins, named):
    monkeypatch.setenv('IRS_TRACE_SPINS', spins)
    with pytest.raises(ValueError, match=named):
        loop_trace.start(str(tmp_path / 't'))
    monkeypatch.delenv('IRS_TRACE_SPINS')
    with pytest.raises(ValueError, match='does not exist'):
        loop_trace.start(str(tmp_path / 'no' / 't'))
    assert loop_trace.ACTIVE is None


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
