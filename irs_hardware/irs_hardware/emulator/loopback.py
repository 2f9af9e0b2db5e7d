"""A :class:`~irs_hardware.driver.RigIO` wired straight to the emulators' cores in-process:
the board in triggered mode and the drive's registers, no pty, no TCP (tests, offline runs).
``board_alive`` / ``drive_alive`` false make the device fail as a dead one does.
"""
from __future__ import annotations

import time

from .. import protocol as P
from ..driver import DriveError, LinkError, Reading, RigIO
from ..drive_modbus import COMM_TIMEOUT, CONTROL, RUN, SETPOINT
from .board_core import BoardEmulator
from .drive_main import DriveState
from .wire import Wire


class LoopbackIO(RigIO):
    """The board's and the drive's cores behind the :class:`RigIO` calls (module docstring)."""

    def __init__(self, board: BoardEmulator, wire_path=None, safe_pulse_us: float = 1512.0):
        self.board = board
        self.safe_ticks = int(round(safe_pulse_us * 1e-6 / P.PULSE_TICK))
        self.wire = Wire(wire_path)
        board.wire = self.wire
        self.drive = DriveState(self.wire, 12.7)
        self.parser = P.FrameParser()
        self.pending = []
        self.board_alive = True
        self.drive_alive = True
        self.corrupt_next = 0

    def _to_board(self, data: bytes):
        if not self.board_alive:
            raise LinkError('board gone')
        for frame in self.board.receive(data, time.monotonic()):
            if self.corrupt_next:
                self.corrupt_next -= 1
                frame = frame[:8] + bytes([frame[8] ^ 0xFF]) + frame[9:]
            self.pending += self.parser.feed(frame)

    def start(self, triggered: bool) -> None:
        self._to_board(P.encode(P.Hello(1 if triggered else 0, 25, 1000, self.safe_ticks)))
        self.pending = [m for m in self.pending if isinstance(m, P.Sample)]
        self._drive_write(COMM_TIMEOUT, 0)
        self._drive_write(CONTROL, RUN)

    def read(self, timeout: float) -> list:
        if not self.board_alive:
            raise LinkError('board gone')
        now = time.monotonic()
        out = [Reading(m.tick, m.ack, m.adc, m.belt, m.status, now, m.wheels)
               for m in self.pending if isinstance(m, P.Sample)]
        self.pending = []
        return out

    def write_board(self, seq, pulse_us, enable, wheels=None) -> None:
        ticks = int(round(pulse_us * 1e-6 / P.PULSE_TICK))
        self._to_board(P.encode(P.Command(seq & 0xFFFF, ticks, P.DRIVE_ENABLE if enable else 0,
                                          None if wheels is None else tuple(wheels))))

    def _drive_write(self, reg, value):
        if not self.drive_alive:
            raise DriveError('drive gone')
        self.drive.write(reg, [value])

    def write_drive(self, setpoint: int) -> None:
        self._drive_write(SETPOINT, setpoint)

    def drive_status(self) -> tuple:
        if not self.drive_alive:
            raise DriveError('drive gone')
        status, speed = self.drive.inputs()
        return status, speed * 1e-3

    @property
    def bad_frames(self) -> int:
        return self.parser.bad

    def close(self) -> None:
        pass
