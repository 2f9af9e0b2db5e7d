"""Dask's and tornado's logged errors in one line each, without their tracebacks.

A sweep stopped by a signal closes its Dask cluster, and the libraries log the races of that
close (a cancelled coroutine, a worker's heartbeat to a scheduler already gone) as ERROR records
with a traceback. The user asked the sweep to stop: one line each says what happened.
:func:`one_line_library_errors` installs :class:`OneLine` on every logger of the two libraries
(a logger's filter sees only the records logged on that logger, not those its children pass
up, so each ``distributed.*`` and ``tornado.*`` logger gets it); the sweep process uses it for
the close (:func:`library_errors_in_one_line`), each local worker for its whole life
(:mod:`.worker_signals`).
"""
from __future__ import annotations

from contextlib import contextmanager
import logging

__all__ = ['OneLine', 'one_line_library_errors', 'library_errors_in_one_line']


class OneLine(logging.Filter):
    """Turns a log record's traceback into one line (``...: NameError: text``)."""

    def filter(self, record):
        if record.exc_info and record.exc_info[1] is not None:
            exc = record.exc_info[1]
            record.msg = (f'{record.getMessage()}: {type(exc).__name__}: '
                          f'{" ".join(str(exc).split())} (traceback not shown)')
            record.args, record.exc_info, record.exc_text = None, None, None
        return True


def one_line_library_errors():
    """Install :class:`OneLine` on every ``distributed`` and ``tornado`` logger there is now;
    returns a function that removes it again.
    """
    names = {'tornado.application', 'distributed', 'distributed.worker'} | {
        n for n in list(logging.root.manager.loggerDict)
        if n.startswith(('distributed.', 'tornado.'))}
    loggers = [logging.getLogger(n) for n in sorted(names)]
    one_line = OneLine()
    for lg in loggers:
        lg.addFilter(one_line)

    def remove():
        for lg in loggers:
            lg.removeFilter(one_line)
    return remove


@contextmanager
def library_errors_in_one_line():
    """:func:`one_line_library_errors` for the ``with`` block.

    A SIGINT that lands inside ``distributed.utils.sync`` before the coroutine has started makes
    its ``cancel`` callback raise ``NameError: cannot access free variable 'future'``
    (distributed 2026.8.0, env/requirements.lock: ``future`` is declared without a value; the
    uninitialised case was handled in https://github.com/dask/distributed/pull/5758), which
    tornado logs with a traceback from the event-loop thread. The sweep keeps the signal out of
    Dask's calls (``runner._run_on_dask``); this is the guard for what is left.
    """
    remove = one_line_library_errors()
    try:
        yield
    finally:
        remove()
