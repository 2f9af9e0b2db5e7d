"""SCHED_FIFO for the emulated devices: the hardware they stand for is real time by nature (a
board's timer interrupt, a drive's controller), so an emulator on a loaded machine asks for a
real-time priority where the machine grants it (root or ``CAP_SYS_NICE``).
"""
import os


def set_fifo(priority: int) -> str:
    """SCHED_FIFO at ``priority`` (0: leave the scheduling as it is); a note for the log."""
    if priority <= 0:
        return 'normal scheduling'
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError) as exc:
        return f'SCHED_FIFO {priority} refused ({exc}); normal scheduling'
    return f'SCHED_FIFO {priority}'
