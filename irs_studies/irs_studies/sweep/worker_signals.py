"""Dask worker preload of the local sweep cluster: the worker ignores SIGINT, and logs the
libraries' errors in one line each.

The workers are children of the sweep process in its process group, so a Ctrl-C at the terminal
reaches them as well; each would print its own ``KeyboardInterrupt`` traceback. With SIGINT
ignored, only the sweep process handles it: it closes the cluster, and kills what is left after
5 s (``runner._close``). SIGTERM and SIGKILL still end a worker. A Ctrl-C in the second or two
while a worker imports (ahead of this preload) still reaches it.

When the sweep closes its cluster, a worker's heartbeat may meet the scheduler already gone, and
``distributed.worker`` logs that with a traceback on the terminal the worker shares with the
sweep. The worker logs such errors in one line (:mod:`.log_lines`).
"""
import signal

from .log_lines import one_line_library_errors


def dask_setup(worker) -> None:  # noqa: ARG001 -- the preload hook's signature
    """Run by Dask in the worker's main thread at its start."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    one_line_library_errors()
