"""A sweep on Dask stops on a first SIGINT between Dask calls, cancels what it submitted and
raises ``Interrupted``; Dask's and tornado's logged errors on the way out are one line each.
"""
import logging
import os
import signal
import threading
import time
from types import SimpleNamespace

import pytest

from irs_bringup.processes import wait_until
from irs_common import cli
from irs_studies.sweep import runner


def test_library_error_is_logged_in_one_line_inside_the_block_only(caplog):
    log = logging.getLogger('tornado.application')

    def log_name_error():
        try:
            raise NameError("cannot access free variable 'future'")
        except NameError:
            log.error('Exception in callback cancel', exc_info=True)

    with caplog.at_level(logging.ERROR, logger='tornado.application'):
        with runner._library_errors_in_one_line():
            log_name_error()
        inside = caplog.text
        caplog.clear()
        log_name_error()
        outside = caplog.text
    assert 'Traceback' not in inside and len(inside.strip().splitlines()) == 1, inside
    assert "Exception in callback cancel: NameError: cannot access free variable 'future'" \
        in inside
    assert 'Traceback' in outside   # the filter is gone after the block


def test_a_child_logger_of_the_libraries_is_one_line_too(caplog):
    """``distributed.client`` (a child of ``distributed``) logs a cluster's cut close with a
    traceback; a filter on the parent logger alone would not see it.
    """
    import asyncio
    log = logging.getLogger('distributed.client')
    with caplog.at_level(logging.ERROR, logger='distributed'):
        with runner._library_errors_in_one_line():
            try:
                raise asyncio.CancelledError()
            except asyncio.CancelledError:
                log.error('', exc_info=True)
    assert 'Traceback' not in caplog.text and 'CancelledError' in caplog.text, caplog.text
    assert len(caplog.text.strip().splitlines()) == 1, caplog.text


def test_an_interrupted_sweep_command_leaves_whatever_waits_at_exit(tmp_path):
    """As the console script: once interrupted (130), nothing registered for the interpreter's
    exit (here an atexit hook that would wait 10 min, as a cluster's cut close can) holds it.
    """
    import subprocess
    import sys
    code = ('import atexit, time, sys\n'
            'from irs_studies.sweep import sweep_cli\n'
            'from irs_common.cli import Interrupted\n'
            'def _main(argv):\n'
            '    atexit.register(time.sleep, 600)\n'
            '    raise Interrupted(2)\n'
            'sweep_cli._main = _main\n'
            'sys.exit(sweep_cli.main())\n')
    t0 = time.monotonic()
    res = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 130, res.stderr
    assert res.stderr.strip() == 'sweep: interrupted (SIGINT)', res.stderr
    assert time.monotonic() - t0 < 60, 'the atexit hook ran'


def test_a_signal_while_the_cluster_closes_waits_for_the_close(monkeypatch):
    """A Ctrl-C that lands inside ``client.close`` (the sweep's last step) does not cut it: the
    close completes, the workers are killed, and then the interrupt is raised.
    """
    guard = cli.SignalGuard().install()
    monkeypatch.setattr(cli, 'GUARD', guard)
    done = []

    class Client:
        def close(self, timeout):
            os.kill(os.getpid(), signal.SIGINT)     # the handler runs here, in the main thread
            done.append('closed')

    monkeypatch.setattr(runner, '_kill', lambda pids: done.append('killed'))
    try:
        with pytest.raises(cli.Interrupted):
            runner._close(Client(), [12345])
    finally:
        guard.restore()
    assert done == ['closed', 'killed']


def _point(cfg, duration, p, metrics):
    time.sleep(0.02)
    return {'point': p['point'], 'value': cfg * duration}


def test_sigint_during_a_dask_sweep_stops_between_calls_and_cancels(monkeypatch, caplog):
    import distributed
    monkeypatch.setattr(runner, 'run_point', _point)
    guard = cli.SignalGuard().install()
    monkeypatch.setattr(cli, 'GUARD', guard)
    rows = []
    total = 2000
    todo = iter([{'point': k} for k in range(total)])
    sent, returned = threading.Event(), threading.Event()

    def keep(row):
        rows.append(row)
        if len(rows) == 5 and not sent.is_set():
            sent.set()
            os.kill(os.getpid(), signal.SIGINT)   # the handler runs in this (main) thread
            returned.set()   # the signal set a flag and raised nothing here

    client = distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                                dashboard_address=None)
    try:
        with caplog.at_level(logging.ERROR):
            with pytest.raises(cli.Interrupted):
                runner._run_on_dask(client, SimpleNamespace(cfg=2.0, duration=0.5), todo,
                                    [], keep, in_flight=4)
        assert returned.is_set() and guard.on_first is None   # the flag handler is gone again
        assert 5 <= len(rows) < total and all(r['value'] == 1.0 for r in rows)
        assert not [r for r in caplog.records if r.exc_info], caplog.text
        # what was submitted and not kept is cancelled: the scheduler forgets it (at once: nothing
        # new is submitted; a point already running on the worker thread ends within 0.02 s)
        assert wait_until(lambda: not any(client.processing().values()), 10.0), \
            client.processing()
    finally:
        guard.restore()
        client.close()


def test_a_signal_the_guard_took_before_the_sweep_submits_nothing(monkeypatch):
    """A signal whose ``Interrupted`` Python ignored (raised inside a weakref callback) is in
    the guard only: the sweep must still stop at once.
    """
    import distributed
    monkeypatch.setattr(runner, 'run_point', _point)
    guard = cli.SignalGuard()
    monkeypatch.setattr(cli, 'GUARD', guard)
    guard.signum = signal.SIGINT
    kept = []
    client = distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                                dashboard_address=None)
    try:
        with pytest.raises(cli.Interrupted):
            runner._run_on_dask(client, SimpleNamespace(cfg=2.0, duration=0.5),
                                iter([{'point': k} for k in range(50)]), [], kept.append,
                                in_flight=4)
        assert kept == [] and not any(client.processing().values())
    finally:
        client.close()


WORKER = """
import logging, sys
from distributed.comm.core import CommClosedError
from irs_studies.sweep.worker_signals import dask_setup
logging.basicConfig(stream=sys.stderr)
dask_setup(None)
try:
    raise CommClosedError('in <TCP (closed) ConnectionPool.heartbeat_worker>: Stream is closed')
except CommClosedError:
    logging.getLogger('distributed.worker').exception(
        'Failed to communicate with scheduler during heartbeat.')
"""


def test_a_worker_logs_the_heartbeat_to_a_closed_scheduler_in_one_line():
    """A local worker (after its preload, ``worker_signals.dask_setup``) logs the heartbeat that
    met the scheduler closed (the sweep's cluster closing) in one line, not with a traceback on
    the terminal it shares with the sweep.
    """
    import subprocess
    import sys
    err = subprocess.run([sys.executable, '-c', WORKER], capture_output=True, text=True,
                         timeout=60).stderr
    assert 'Traceback' not in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert 'heartbeat.: CommClosedError: in <TCP (closed)' in err, err
