"""Children that a test signals start with the default signal dispositions.

A process inherits ignored signals and its signal mask through ``fork`` and ``exec``; only
handlers return to the default. A test run started as a background job of a non-interactive
shell (``make test &``), under ``nohup`` or by a CI runner that does the same, has SIGINT (and
SIGQUIT, SIGHUP) ignored, and so has every child it starts: a program that relies on the
default action (rerun's server, a plain Python script) then never acts on the test's SIGINT.
:func:`default_signals` as ``preexec_fn`` gives the child SIG_DFL and an unblocked mask for
the signals a test sends, whatever the test run inherited. The IRS commands install their own
handlers (:mod:`irs_common.cli`) and need none of this.
"""
import signal

#: The signals a test sends to stop a child.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


def default_signals() -> None:
    """In the child between ``fork`` and ``exec``: SIG_DFL and unblocked for STOP_SIGNALS."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def ignored_signals(pid: int) -> set:
    """The signals ``pid`` ignores (``SigIgn`` of ``/proc/<pid>/status``), for messages."""
    for line in open(f'/proc/{pid}/status'):
        if line.startswith('SigIgn:'):
            mask = int(line.split()[1], 16)
            return {signal.Signals(n).name for n in range(1, 32) if mask >> (n - 1) & 1}
    return set()
