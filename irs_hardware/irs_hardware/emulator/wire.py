"""The wires between the emulated board and the emulated drive: a small shared-memory file.

On the rig the board's drive-enable output runs to the drive's enable input, and the drive's
output turns the belt whose encoder the board counts. Two emulator processes share these
signals through a file of eight float64 slots (``mmap`` viewed as a numpy array: each value one
aligned 8-byte store and load, never torn; ``struct.pack_into`` zeroes its bytes before it
writes them, and a reader in between sees 0.0; one writer per slot), with each side's heartbeat
(``time.monotonic``, one clock for all processes on Linux): a slot whose writer has stopped
beating is read as its safe value (drive output 0 V).
``DRIVE_ZERO_AT`` is the ``time.monotonic()`` the drive's output last fell to 0 V (tests time
the safe state with it).
"""
from __future__ import annotations

import mmap
import os
import time
from pathlib import Path

import numpy as np

DRIVE_VOLTAGE, DRIVE_BEAT, ENABLE, BELT_SPEED, BOARD_BEAT, DRIVE_ZERO_AT = range(6)
SLOTS = 8
#: A side silent for longer than this is gone [s].
STALE = 0.2


class Wire:
    """The shared signals; ``Wire(path)`` creates the file if needed, ``Wire()`` is in-process."""

    def __init__(self, path=None):
        if path is None:                   # in-process: anonymous memory
            self.path, self.mm = None, mmap.mmap(-1, 8 * SLOTS)
        else:
            self.path = Path(path)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                if os.fstat(fd).st_size < 8 * SLOTS:
                    os.ftruncate(fd, 8 * SLOTS)
                self.mm = mmap.mmap(fd, 8 * SLOTS)
            finally:
                os.close(fd)
        self.slots = np.frombuffer(self.mm, dtype='<f8', count=SLOTS)

    def get(self, slot: int) -> float:
        return float(self.slots[slot])

    def set(self, slot: int, value: float) -> None:
        self.slots[slot] = value            # one aligned 8-byte store

    def beat(self, slot: int) -> None:
        self.set(slot, time.monotonic())

    def alive(self, beat_slot: int, now: float | None = None) -> bool:
        now = time.monotonic() if now is None else now
        return now - self.get(beat_slot) <= STALE

    def drive_voltage(self, now: float | None = None) -> float:
        """The drive's output [V]; 0 V if the drive has stopped beating."""
        return self.get(DRIVE_VOLTAGE) if self.alive(DRIVE_BEAT, now) else 0.0

    def close(self):
        del self.slots
        self.mm.close()
