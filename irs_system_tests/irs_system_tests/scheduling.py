"""What scheduling policy the node processes of a test got (``IRS_RT_PRIORITY``, SCHED_FIFO).

A node asks for SCHED_FIFO when ``IRS_RT_PRIORITY`` is set (:func:`irs_common.node_main
.set_realtime_priority`) and logs either ``SCHED_FIFO priority <p>`` or that it was refused
(it needs root or CAP_SYS_NICE). :func:`check_fifo` makes a test that asks for it say which it
got, never take it silently: every process runs SCHED_FIFO exactly when its log says so, and as
root every one does. A node says it once its nodes are built, after its imports: a process
still starting is waited for (``timeout``).
"""
import os

from irs_bringup.processes import wait_until


def check_fifo(procs, priority: int, timeout: float = 60.0) -> str:
    """Assert the above for ``procs`` (:class:`irs_bringup.processes.NodeProcess`); a report."""
    got, refused = [], []
    for proc in procs:
        assert wait_until(lambda: proc.poll() is not None or any(
            s in proc.output() for s in (f'SCHED_FIFO priority {priority}',
                                         f'SCHED_FIFO {priority} refused')), timeout), \
            (proc.label, 'said nothing about SCHED_FIFO', proc.tail(5))
        fifo = os.sched_getscheduler(proc.pid) == os.SCHED_FIFO
        said = f'SCHED_FIFO priority {priority}' in proc.output()
        assert fifo == said, (proc.label, fifo, proc.tail(5))
        assert fifo or f'SCHED_FIFO {priority} refused' in proc.output(), (proc.label,
                                                                            proc.tail(5))
        (got if fifo else refused).append(proc.label)
    if os.geteuid() == 0:
        assert not refused, f'SCHED_FIFO refused to root: {refused}'
    report = (f'SCHED_FIFO {priority}: granted to {len(got)} of {len(procs)} processes'
              + (f'; refused to {", ".join(refused)} (needs root or CAP_SYS_NICE)'
                 if refused else ''))
    print(report)
    return report
