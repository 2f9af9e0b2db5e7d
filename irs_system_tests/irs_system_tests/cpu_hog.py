"""A CPU hog for tests of behaviour under load: processes spinning at a higher priority than ours.

``with cpu_hog():`` starts one busy loop per core (``sh -c 'while :; do :; done'``) at nice -10
(as root), so that a process at the normal nice 0 gets about a tenth of a core (CFS weights 9548
against 1024). SCHED_FIFO hogs would leave the rest of the machine 5 % of every core (the kernel's
real-time throttling) for as long as they run: on a machine shared with other work that is not
a test but an outage, so the hog stays at nice -10. The body starts once every hog has run
(its CPU time, :func:`irs_bringup.processes.cpu_seconds`), and every hog is killed when the
block ends.

Also :func:`descendants` (every process below a pid, from ``/proc``) and
:func:`wait_handling_signals` (the moment a process has installed its SIGTERM handler: what the
IRS commands do first, :mod:`irs_common.cli`), for tests that signal processes.
"""
from contextlib import contextmanager
import os
from pathlib import Path
import signal
import subprocess
import time

HOG_NICE = -10


@contextmanager
def cpu_hog(processes: int | None = None, nice: int = HOG_NICE):
    """One busy loop per core (or ``processes``) at ``nice``, for the ``with`` body."""
    n = processes or os.cpu_count() or 1
    hogs = [subprocess.Popen(['sh', '-c', 'while :; do :; done'], start_new_session=True,
                             preexec_fn=lambda: os.nice(nice)) for _ in range(n)]
    try:
        from irs_bringup.processes import cpu_seconds, wait_until
        wait_until(lambda: all(cpu_seconds(h.pid) > 0.0 for h in hogs), 10.0)
        yield [h.pid for h in hogs]
    finally:
        for h in hogs:
            try:
                os.killpg(h.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            h.wait()


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (children, their children, ...), from ``/proc``."""
    parents = {}
    for d in Path('/proc').iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / 'stat').read_text().rsplit(')', 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            parents.setdefault(ppid, []).append(int(d.name))
    out, todo = [], [pid]
    while todo:
        kids = parents.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def alive(pid: int) -> bool:
    """Whether ``pid`` exists and is not a zombie."""
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != 'Z'


def wait_handling_signals(pid: int, timeout: float) -> bool:
    """Wait until ``pid`` handles SIGTERM (its own handler installed) or ``timeout`` s pass."""
    from irs_bringup.processes import handles_sigterm
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if handles_sigterm(pid):
            return True
        time.sleep(0.005)
    return False
