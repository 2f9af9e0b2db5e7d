"""A node that does not stop on SIGINT shows where it waits, and is ended all the same.

Every IRS node prints the Python stack of each thread on SIGUSR1 (``run_node``; faulthandler,
which writes from the C signal handler, so a main thread blocked in C is shown too) and runs on.
:func:`irs_bringup.processes.stop_processes` sends SIGUSR1 to a process still running after its
grace, before the SIGTERM, and records how the process ended (``escalated_to``); with
``IRS_NATIVE_STACKS`` and gdb it has gdb write the stacks instead.
"""
import shutil
import signal
import sys
import textwrap

import pytest

from irs_bringup.processes import NodeProcess, NodeSpec, catches_signal, stop_processes, wait_until

START_TIMEOUT = 120.0

#: A process that catches SIGUSR1 as a node does, ignores SIGINT and SIGTERM, and blocks in a
#: lock forever: only SIGKILL ends it.
STUCK = textwrap.dedent("""
    import signal, threading
    from irs_common.node_main import register_stack_dump
    register_stack_dump()
    signal.signal(signal.SIGINT, lambda *_: None)
    signal.signal(signal.SIGTERM, lambda *_: None)

    def wait_for_a_lock_nobody_releases():
        lock = threading.Lock()
        lock.acquire()
        print('ready', flush=True)
        lock.acquire()

    wait_for_a_lock_nobody_releases()
""")


class ScriptSpec(NodeSpec):
    """A :class:`NodeSpec` that runs a Python script instead of a package's executable."""

    def __init__(self, script: str):
        super().__init__('irs_system_tests', 'stuck')
        self.script = script

    def command(self, overrides_file=None) -> list:
        return [sys.executable, '-c', self.script]


def _dump_shows(proc, text: str) -> bool:
    """Ask ``proc`` for its stacks (SIGUSR1); whether its log shows ``text`` in a dump."""
    if text in proc.output() or proc.poll() is not None:
        return True
    proc.popen.send_signal(signal.SIGUSR1)
    return False


def test_a_node_prints_its_stacks_on_sigusr1_and_goes_on(tmp_path):
    proc = NodeProcess(NodeSpec('irs_sensing', 'arm_pose_estimator'), tmp_path)
    try:
        assert wait_until(lambda: catches_signal(proc.pid, signal.SIGUSR1) or
                          proc.poll() is not None, START_TIMEOUT), proc.tail()
        assert proc.poll() is None, proc.tail()
        # a dump every 0.5 s until one shows the main thread in the executor's spin (the
        # first ones may come while the node is still being built)
        assert wait_until(lambda: _dump_shows(proc, 'in spin_once'), START_TIMEOUT, 0.5), \
            proc.tail(40)
        assert proc.poll() is None, proc.tail()             # and the node runs on
    finally:
        code = proc.stop(5.0)
    assert code == 0, proc.tail()
    assert proc.escalated_to is None and not proc.stacks_dumped


def _stop_stuck(tmp_path):
    proc = NodeProcess(ScriptSpec(STUCK), tmp_path, label='stuck')
    try:
        assert wait_until(lambda: 'ready' in proc.output() or proc.poll() is not None,
                          START_TIMEOUT), proc.tail()
        assert proc.poll() is None, proc.tail()
        codes = stop_processes([proc], grace=1.0, term_grace=1.0)
    finally:
        proc.signal_group(signal.SIGKILL)
    assert codes == {'stuck': -signal.SIGKILL}
    assert proc.escalated_to == 'SIGKILL'
    return proc


def test_a_process_that_ignores_the_stop_signals_is_killed_after_printing_its_stacks(
        tmp_path, monkeypatch):
    monkeypatch.delenv('IRS_NATIVE_STACKS', raising=False)
    proc = _stop_stuck(tmp_path)
    assert proc.stacks_dumped and proc.native_stacks is None
    assert 'in wait_for_a_lock_nobody_releases' in proc.output(), proc.tail(40)


@pytest.mark.skipif(shutil.which('gdb') is None, reason='needs gdb')
def test_with_native_stacks_gdb_writes_them_and_no_sigusr1_is_sent(tmp_path, monkeypatch):
    """The suite's setting: gdb reads the stacks of the paused process, instead of the
    SIGUSR1 dump that can crash a process whose other threads run (module docstring of
    irs_bringup.processes).
    """
    monkeypatch.setenv('IRS_NATIVE_STACKS', '1')
    proc = _stop_stuck(tmp_path)
    assert not proc.stacks_dumped and 'Thread 0x' not in proc.output(), proc.tail(40)
    assert proc.native_stacks == tmp_path / 'stuck.native_stacks.txt'
    text = proc.native_stacks.read_text()
    assert 'Thread 1' in text and '#0 ' in text, text[-2000:]     # native frames
    if 'Undefined command: "py-bt"' not in text:                   # the interpreter's extension
        assert 'in wait_for_a_lock_nobody_releases' in text, text[-3000:]


@pytest.mark.skipif(shutil.which('gdb') is None, reason='needs gdb')
def test_a_gdb_that_does_not_finish_leaves_what_it_wrote_and_says_so(tmp_path, monkeypatch):
    """A gdb that does not finish within the timeout (it can hang after attaching) leaves its
    file, with a last line saying so.
    """
    import irs_bringup.processes as processes
    monkeypatch.setenv('IRS_NATIVE_STACKS', '1')
    monkeypatch.setattr(processes, 'NATIVE_STACKS_TIMEOUT', 0.001)    # gdb needs ~0.7 s
    proc = _stop_stuck(tmp_path)
    assert proc.native_stacks == tmp_path / 'stuck.native_stacks.txt'
    assert proc.native_stacks.read_text().endswith('[gdb did not finish within 0.001 s]\n')


@pytest.mark.skipif(shutil.which('gdb') is None, reason='needs gdb')
def test_a_running_process_shows_where_it_waits_for_a_failure_report(tmp_path, monkeypatch):
    """``write_native_stacks`` on a process that still runs (a test about to fail on it): the
    stacks as text, the process left running; after it exited, a line saying so.
    """
    monkeypatch.setenv('IRS_NATIVE_STACKS', '1')
    proc = NodeProcess(ScriptSpec(STUCK), tmp_path, label='stuck')
    try:
        assert wait_until(lambda: 'ready' in proc.output() or proc.poll() is not None,
                          START_TIMEOUT), proc.tail()
        text = proc.write_native_stacks()
        assert 'Thread 1' in text and '#0 ' in text, text[-2000:]
        if 'Undefined command: "py-bt"' not in text:
            assert 'in wait_for_a_lock_nobody_releases' in text, text[-3000:]
        assert proc.poll() is None
    finally:
        proc.signal_group(signal.SIGKILL)
        proc.popen.wait(10)
    assert proc.write_native_stacks() == f'stuck: no stacks, it has exited ({-signal.SIGKILL})'
