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


def _point(cfg, duration, p, metrics):
    time.sleep(0.02)
    return {'point': p['point'], 'value': cfg * duration}


def test_sigint_during_a_dask_sweep_stops_between_calls_and_cancels(monkeypatch, caplog):
    distributed = pytest.importorskip('distributed')
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

