"""Dask worker preload of the local sweep cluster: the worker ignores SIGINT.

The workers are children of the sweep process in its process group, so a Ctrl-C at the terminal
reaches them as well; each would print its own ``KeyboardInterrupt`` traceback. With SIGINT
ignored, only the sweep process handles it: it closes the cluster, and kills what is left after
5 s (``runner._close``). SIGTERM and SIGKILL still end a worker. A Ctrl-C in the second or two
while a worker imports (ahead of this preload) still reaches it.
"""
import signal


def dask_setup(worker) -> None:  # noqa: ARG001 -- the preload hook's signature
    """Run by Dask in the worker's main thread at its start."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
