"""IRSL v1: the framing between the host and the rig's board (no rclpy, no I/O).

Every frame, both directions::

    0xA5 0x5A | version u8 | type u8 | length u8 | payload (length bytes) | crc16 u16

little-endian; ``crc16`` is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF; ``binascii.crc_hqx``)
over version, type, length and payload. A receiver scans for the sync bytes, checks version,
length and CRC, and counts every frame it throws away (:class:`FrameParser`): one garbled byte
costs one frame, never the stream. Types (host -> board: 0x0*, board -> host: 0x8*):

- ``HELLO`` (mode u8: 0 free-running sampler, 1 triggered; watchdog u16 [ms], counted in
  sampling intervals and armed by the first COMMAND; interval u16 [us]; safe pulse u16 [ticks of
  0.5 us]: the servo's calibrated centre) -> ``INFO`` (firmware u16, adc_bits u8, channels u8,
  interval u16 [us], pulse tick u16 [ns], watchdog u16 [ms], wheel counters u8: 4 on the torque
  car's board, 0 without wheels; the host refuses a board short of the wheels it needs).
- ``COMMAND`` (seq u16, servo pulse u16 [ticks of 0.5 us], flags u8: bit 0 drive enable; to a
  board with wheels 4 x i16 motor commands [per-mille of the drivers' full scale, FL, FR, RL,
  RR], which the board applies only while the enable line is high and sets to 0 in its safe
  state; a COMMAND without them commands 0).
- ``SAMPLE`` (tick u32 [sampling intervals], ack u16 = seq of the last command applied,
  adc 3 x u16 [counts], belt i32 [counts], status u8: bit 0 watchdog tripped, bit 1 a bad host
  frame since the last sample, bit 2 sampler overrun; a board with wheels adds 4 x i32 wheel
  encoder counts, wrapping at 2^32).

A host repeats its HELLO every ``HELLO_RESEND`` until the INFO comes, for ``HELLO_WAIT``: a
board that resets when its port is opened (an Arduino's DTR auto-reset) runs its bootloader
first and loses what comes meanwhile. A board answers every HELLO it reads; an answer to a
repeated HELLO in the triggered mode carries a sample of the same tick again, which the host
drops (a tick is never older than the newest of the session).

At 1 kHz a SAMPLE is 24 bytes (40 with wheels) and a COMMAND 12 (20) (:mod:`.link_budget`).
Own firmware instead of Firmata: docs/hardware.md (16-bit ADC, CRC, sequence numbers, a
watchdog, 1 kHz).
"""
from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

VERSION = 1
SYNC = b'\xa5\x5a'
HELLO, COMMAND = 0x01, 0x02
INFO, SAMPLE = 0x81, 0x82
#: Servo pulse resolution: Timer1 of a 16 MHz ATmega at prescaler 8 [s per tick].
PULSE_TICK = 0.5e-6
#: Status bits of a SAMPLE.
WATCHDOG_TRIPPED, BAD_HOST_FRAME, OVERRUN = 0x01, 0x02, 0x04
#: Flag bits of a COMMAND.
DRIVE_ENABLE = 0x01
FRAME_OVERHEAD = 7           # sync 2 + version + type + length + crc 2
MAX_PAYLOAD = 64
#: How often a host repeats its HELLO while no INFO has come, and for how long [s]: an
#: Arduino's bootloader after the DTR reset of opening the port takes 0.5-2 s.
HELLO_RESEND, HELLO_WAIT = 0.25, 3.0


def hello_due(sent: int, elapsed: float) -> bool:
    """Whether a host that has sent ``sent`` HELLOs without an answer sends the next now,
    ``elapsed`` [s] after its first: one every ``HELLO_RESEND`` within ``HELLO_WAIT``.
    """
    return sent * HELLO_RESEND <= elapsed < HELLO_WAIT


#: Ticks of a SAMPLE wrap at 2^32.
TICK_MODULUS = 2 ** 32
#: Wheels of the torque car (FL, FR, RL, RR) and the motor command's full scale [per-mille].
WHEELS, MOTOR_FULL_SCALE = 4, 1000

_HELLO = struct.Struct('<BHHH')
_INFO = struct.Struct('<HBBHHHB')
_COMMAND = struct.Struct('<HHB')
_WHEELS_CMD = struct.Struct('<4h')
_SAMPLE = struct.Struct('<IH3HiB')
_WHEELS_SAMPLE = struct.Struct('<4i')
#: Payload lengths each type may have: a header with another (a garbled length byte) is
#: refused at once instead of waiting for bytes that belong to the next frames.
LENGTHS = {HELLO: {_HELLO.size}, INFO: {_INFO.size},
           COMMAND: {_COMMAND.size, _COMMAND.size + _WHEELS_CMD.size},
           SAMPLE: {_SAMPLE.size, _SAMPLE.size + _WHEELS_SAMPLE.size}}


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of b'123456789': 0x29B1)."""
    return binascii.crc_hqx(data, 0xFFFF)


def frame(kind: int, payload: bytes) -> bytes:
    """One complete frame of type ``kind`` around ``payload``."""
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f'payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}')
    body = bytes((VERSION, kind, len(payload))) + payload
    return SYNC + body + struct.pack('<H', crc16(body))


@dataclass(frozen=True)
class Hello:
    """Host -> board: start the sampler (module docstring)."""

    mode: int = 0              # 0 free-running, 1 triggered (one sample per command)
    watchdog_ms: int = 25
    interval_us: int = 1000
    safe_pulse: int = 3000     # [ticks of PULSE_TICK] the pulse of the safe state


@dataclass(frozen=True)
class Info:
    """Board -> host: the answer to HELLO (module docstring)."""

    firmware: int
    adc_bits: int
    channels: int
    interval_us: int
    pulse_tick_ns: int
    watchdog_ms: int
    wheel_counters: int


@dataclass(frozen=True)
class Command:
    """Host -> board: the outputs, answering the sample ``seq`` (module docstring)."""

    seq: int
    pulse_ticks: int
    flags: int = 0
    wheels: tuple | None = None      # 4 x per-mille, a board with wheels only


@dataclass(frozen=True)
class Sample:
    """Board -> host: one sampling instant's inputs (module docstring)."""

    tick: int
    ack: int
    adc: tuple                   # 3 x counts
    belt: int                    # counts
    status: int = 0
    wheels: tuple | None = None  # 4 x counts, a board with wheels only


def encode(msg) -> bytes:
    """The frame of a :class:`Hello`, :class:`Info`, :class:`Command` or :class:`Sample`."""
    if isinstance(msg, Hello):
        return frame(HELLO, _HELLO.pack(msg.mode, msg.watchdog_ms, msg.interval_us,
                                        msg.safe_pulse))
    if isinstance(msg, Info):
        return frame(INFO, _INFO.pack(msg.firmware, msg.adc_bits, msg.channels, msg.interval_us,
                                      msg.pulse_tick_ns, msg.watchdog_ms, msg.wheel_counters))
    if isinstance(msg, Command):
        payload = _COMMAND.pack(msg.seq & 0xFFFF, msg.pulse_ticks, msg.flags)
        if msg.wheels is not None:
            payload += _WHEELS_CMD.pack(*msg.wheels)
        return frame(COMMAND, payload)
    if isinstance(msg, Sample):
        payload = _SAMPLE.pack(msg.tick & 0xFFFFFFFF, msg.ack & 0xFFFF, *msg.adc, msg.belt,
                               msg.status)
        if msg.wheels is not None:
            payload += _WHEELS_SAMPLE.pack(*msg.wheels)
        return frame(SAMPLE, payload)
    raise TypeError(f'cannot encode {type(msg).__name__}')


def decode(kind: int, payload: bytes):
    """The message of a checked frame; ``ValueError`` for a length its type does not have."""
    n = len(payload)
    if kind == HELLO and n == _HELLO.size:
        return Hello(*_HELLO.unpack(payload))
    if kind == INFO and n == _INFO.size:
        return Info(*_INFO.unpack(payload))
    if kind == COMMAND and n in (_COMMAND.size, _COMMAND.size + _WHEELS_CMD.size):
        wheels = _WHEELS_CMD.unpack(payload[_COMMAND.size:]) if n > _COMMAND.size else None
        return Command(*_COMMAND.unpack(payload[:_COMMAND.size]), wheels=wheels)
    if kind == SAMPLE and n in (_SAMPLE.size, _SAMPLE.size + _WHEELS_SAMPLE.size):
        tick, ack, a0, a1, a2, belt, status = _SAMPLE.unpack(payload[:_SAMPLE.size])
        wheels = _WHEELS_SAMPLE.unpack(payload[_SAMPLE.size:]) if n > _SAMPLE.size else None
        return Sample(tick, ack, (a0, a1, a2), belt, status, wheels)
    raise ValueError(f'type 0x{kind:02x} with a payload of {n} bytes')


class FrameParser:
    """Byte stream -> messages; bad frames are counted (``bad``) and skipped.

    ``feed(data)`` returns the messages completed by ``data``. A frame with a wrong version, a
    wrong CRC, an unknown type or a length its type does not have (checked on the header, before
    waiting for the rest) counts as one bad frame; the
    scan resumes one byte after its sync, so a sync pattern inside a garbled frame cannot hide
    the next good one. ``skipped`` counts bytes outside frames.
    """

    def __init__(self):
        self.buf = bytearray()
        self.bad = 0
        self.skipped = 0

    def feed(self, data: bytes) -> list:
        self.buf += data
        out = []
        buf = self.buf
        while True:
            start = buf.find(SYNC)
            if start < 0:
                keep = 1 if buf[-1:] == SYNC[:1] else 0
                self.skipped += len(buf) - keep
                del buf[:len(buf) - keep]
                return out
            if start:
                self.skipped += start
                del buf[:start]
            if len(buf) < 5:
                return out
            length = buf[4]
            if buf[2] != VERSION or length not in LENGTHS.get(buf[3], ()):
                self.bad += 1
                del buf[:1]
                continue
            end = 5 + length + 2
            if len(buf) < end:
                return out
            body = bytes(buf[2:5 + length])
            (crc,) = struct.unpack_from('<H', buf, 5 + length)
            try:
                if crc != crc16(body):
                    raise ValueError('crc')
                out.append(decode(body[1], body[3:]))
            except ValueError:
                self.bad += 1
                del buf[:1]
                continue
            del buf[:end]
