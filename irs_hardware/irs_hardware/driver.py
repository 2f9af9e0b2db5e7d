"""The driver interface between the hardware node's core and the rig's devices (no rclpy).

:class:`RigIO` is all the core needs: analog inputs (three pots) and a counter (belt encoder)
in, a servo pulse, an enable line and a drive set-point out; on the torque car also four wheel
encoder counters in and four motor commands out. :class:`SerialModbusRig` is the
rig: the IRSL board on a serial port (:mod:`.protocol`) and the drive on Modbus
(:mod:`.drive_modbus`). Failures surface as :class:`LinkError` (board) or
:class:`~.drive_modbus.DriveError` (drive); the core's supervisor turns them into the safe state.
"""
from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass

from . import protocol as P
from .board_keeper import OFFER_PERIOD, BoardKeeper
from .drive_modbus import DriveError, ModbusDrive

__all__ = ['Reading', 'RigIO', 'LinkError', 'SerialModbusRig', 'DriveError']


class LinkError(IOError):
    """The board's link failed: port gone, wrong firmware, no answer (message says which)."""


@dataclass(frozen=True)
class Reading:
    """One sample of the board: ADC counts of the three pots, the belt counter, the board's
    sample index ``tick``, the sequence number of the last command it applied, status bits, and
    on a board with wheels the four wheel counters (raw, wrapping at 2^32).
    """

    tick: int
    ack: int
    adc: tuple
    belt: int
    status: int
    received: float       # time.monotonic() of arrival
    wheels: tuple | None = None


class RigIO(ABC):
    """The devices of the rig (module docstring)."""

    @abstractmethod
    def start(self, triggered: bool) -> None:
        """Open the devices; start the board's sampler (triggered: one sample per command)."""

    @abstractmethod
    def read(self, timeout: float) -> list:
        """Readings received so far, waiting up to ``timeout`` [s] for the first."""

    @abstractmethod
    def write_board(self, seq: int, pulse_us: float, enable: bool, wheels=None) -> None:
        """Servo pulse [us], drive-enable line and (torque car) four motor commands
        [per-mille] or None; ``seq`` = tick of the sample it answers.
        """

    @abstractmethod
    def write_drive(self, setpoint: int) -> None:
        """Drive set-point register value."""

    @abstractmethod
    def drive_status(self) -> tuple:
        """``(status word, belt speed [m/s])`` the drive reports."""

    @property
    @abstractmethod
    def bad_frames(self) -> int:
        """Frames from the board thrown away (CRC, version, length)."""

    @abstractmethod
    def close(self) -> None:
        """Close the devices."""


class SerialModbusRig(RigIO):
    """IRSL board over pyserial + Modbus drive over pymodbus."""

    def __init__(self, port: str, baud: int, drive: ModbusDrive, watchdog_ms: int = 25,
                 safe_pulse_us: float = 1500.0, wheels: bool = False, stall_grace: float = 0.0):
        self.wheels = wheels       # the torque car: the board must have 4 wheel counters
        # stall_grace > 0: a board keeper bridges the host's stalls (free-running mode)
        self.keeper = BoardKeeper(stall_grace) if stall_grace > 0.0 else None
        self.offered = (-float('inf'), None)     # the last offer to the keeper: time, enable
        self.port_name = port
        self.baud = baud
        self.drive = drive
        self.watchdog_ms = watchdog_ms
        self.safe_ticks = int(round(safe_pulse_us * 1e-6 / P.PULSE_TICK))
        self.serial = None
        self.parser = P.FrameParser()
        self.info = None
        self.early = []            # samples that came with the INFO answer
        self.newest = None         # the newest sample tick of the session

    def start(self, triggered: bool) -> None:
        """Drive: comm timeout, set-point 0, run; board: HELLO, INFO checked (firmware version,
        and the wheel counters the torque car needs). The HELLO is repeated every
        ``P.HELLO_RESEND`` for ``P.HELLO_WAIT`` while no INFO has come (a board reset by the
        port's opening boots first). Samples before the INFO are the board's previous session
        (a reset) and are dropped. The board's watchdog arms with the first command the caller
        sends; free-running with ``stall_grace`` > 0, the board keeper starts
        (:mod:`.board_keeper`).
        """
        import serial
        self.drive.start()
        try:
            self.serial = serial.Serial(self.port_name, self.baud, timeout=0)
            self.serial.reset_input_buffer()
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f'board at {self.port_name}: cannot open ({exc})') from None
        self.parser = P.FrameParser()
        self.info, self.early, self.newest = None, [], None
        hello = P.encode(P.Hello(1 if triggered else 0, self.watchdog_ms, 1000,
                                 self.safe_ticks))
        begin = time.monotonic()
        sent = 0
        while self.info is None:
            now = time.monotonic()
            if now >= begin + P.HELLO_WAIT:
                raise LinkError(f'board at {self.port_name}: no INFO answer to {sent} HELLO '
                                f'in {P.HELLO_WAIT:g} s (not IRSL firmware, or a different '
                                'baud rate)')
            if P.hello_due(sent, now - begin):
                self._write(hello)
                sent += 1
            wait = min(P.HELLO_WAIT, sent * P.HELLO_RESEND) - (now - begin)
            for msg in self._messages(max(0.0, wait)):
                if isinstance(msg, P.Info):
                    self.info = self.info or msg
                elif isinstance(msg, P.Sample) and self.info is not None:
                    self.early.append(msg)     # before the INFO: the board's previous session
        if self.info.firmware != P.VERSION:
            raise LinkError(f'board at {self.port_name}: firmware {self.info.firmware}, the '
                            f'host speaks IRSL {P.VERSION}')
        if self.wheels and self.info.wheel_counters < P.WHEELS:
            raise LinkError(f'board at {self.port_name}: {self.info.wheel_counters} wheel '
                            f'counters, the torque car needs {P.WHEELS} (a board without '
                            'wheels, or the parameter wheels set by mistake)')
        if not triggered and self.keeper is not None:
            self.keeper.attach(self.serial.fileno())
            self.offered = (-float('inf'), None)

    def _write(self, data: bytes) -> None:
        import serial
        try:
            self.serial.write(data)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f'board at {self.port_name}: write failed ({exc})') from None

    def _messages(self, timeout: float) -> list:
        """Messages of the bytes waiting, waiting up to ``timeout`` [s] for the first ones."""
        import select
        import serial
        deadline = time.monotonic() + timeout
        while True:
            try:
                data = self.serial.read(4096)
            except (serial.SerialException, OSError, TypeError) as exc:
                raise LinkError(f'board at {self.port_name}: read failed ({exc})') from None
            msgs = self.parser.feed(data) if data else []
            left = deadline - time.monotonic()
            if msgs or left <= 0.0:
                return msgs
            try:
                select.select([self.serial.fileno()], [], [], left)
            except (OSError, ValueError, TypeError, serial.SerialException) as exc:
                # TypeError: the port closed by another thread (rig/reset) between its read
                # and this wait; pyserial's close() clears the descriptor before it marks
                # the port closed, so fileno() gives None in between
                raise LinkError(f'board at {self.port_name}: read failed ({exc})') from None

    def read(self, timeout: float) -> list:
        """The samples of the session in order; a sample whose tick is not after the newest
        one is an answer to a repeated HELLO and is dropped.
        """
        early, self.early = self.early, []
        msgs = early + self._messages(0.0 if early else timeout)
        now = time.monotonic()
        out = []
        for m in msgs:
            if isinstance(m, P.Sample):
                newest = self.newest
                if newest is None or 0 < (m.tick - newest) % P.TICK_MODULUS < P.TICK_MODULUS // 2:
                    self.newest = m.tick
                    out.append(Reading(m.tick, m.ack, m.adc, m.belt, m.status, now, m.wheels))
        return out

    def write_board(self, seq: int, pulse_us: float, enable: bool, wheels=None) -> None:
        """The COMMAND to the board, offered to the keeper first (:mod:`.board_keeper`) every
        ``OFFER_PERIOD`` and whenever the enable line changes.
        """
        ticks = int(round(pulse_us * 1e-6 / P.PULSE_TICK))
        frame = P.encode(P.Command(seq & 0xFFFF, ticks, P.DRIVE_ENABLE if enable else 0,
                                   None if wheels is None else tuple(wheels)))
        if self.keeper is not None:
            now = time.monotonic()
            # every OFFER_PERIOD, and at once when the enable line changes (a safe frame is
            # never left behind an older live one)
            if now - self.offered[0] >= OFFER_PERIOD or enable != self.offered[1]:
                self.keeper.offer(frame, now)
                self.offered = (now, enable)
        self._write(frame)

    def write_drive(self, setpoint: int) -> None:
        self.drive.write_setpoint(setpoint)

    def drive_status(self) -> tuple:
        return self.drive.read()

    @property
    def bad_frames(self) -> int:
        return self.parser.bad

    def close(self) -> None:
        if self.keeper is not None:       # first: no repeat of this session after the port
            self.keeper.detach()
        if self.serial is not None:
            try:
                self.serial.close()
            except OSError:
                pass
        self.drive.close()
