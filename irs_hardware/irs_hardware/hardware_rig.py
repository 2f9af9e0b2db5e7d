"""The hardware node's core: readings to measurements, commands to outputs, and the safety
supervisor (no rclpy).

Measurements of a board reading ``k`` (its ``tick``): the joint angles through the pot
calibration (NaN where a pot reads a rail: wiper off its track or broken), the belt travel
``s_k = n_k / counts_per_metre`` and its speed over the last ``belt_window`` samples,
``(s_k - s_{k-w}) / (w dt)`` [m/s].

Commands: the steer angle [rad] is clipped to the +-15 deg limit and turned into a pulse by the
servo calibration; the drive voltage [V] into the drive's set-point. A command that is not
finite, a steer beyond ``steer_reject`` or a voltage outside [0, u_max] is refused.

Supervisor: the first of these latches a fault (:attr:`HardwareRig.fault`, its reason kept):
a refused command; the link silent for ``link_timeout`` (real time) or a read or write error;
a garbled frame from the board (CRC), or the board reporting a bad host frame or its own
watchdog; a stale steering command (real time, ``command_timeout`` after the first); the
drive's Modbus failing or reporting a trip. While latched, every output is the safe one: servo
at the calibrated centre, enable line low, drive set-point 0 (:meth:`HardwareRig.outputs`), and
:meth:`HardwareRig.reset` clears it only once the devices answer again.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from irs_models.constants import STEER_LIMIT_DEG

from .calibration import Calibration
from .driver import DriveError, LinkError, Reading, RigIO
from .drive_modbus import TRIPPED
from . import protocol as P

STEER_LIMIT = math.radians(STEER_LIMIT_DEG)


@dataclass
class HardwareConfig:
    dt: float = 1e-3                       # board sampling interval [s]
    link_timeout: float = 0.02             # [s] no sample for this long: link lost
    command_timeout: float = 0.1           # [s] steering older than this: stale (real time)
    steer_reject: float = math.radians(30.0)
    u_max: float = 12.7                    # [V] drive range
    belt_window: int = 10                  # [samples]
    drive_keepalive: float = 0.1           # [s] rewrite the set-point at least this often
    adc_full_scale: int = 65535            # a pot at 0 or this reads a rail


@dataclass(frozen=True)
class Measurement:
    tick: int
    angles: tuple          # [rad], NaN where the pot reads a rail
    belt_speed: float      # [m/s]
    belt_count: int


class HardwareRig:
    """See the module docstring. ``io`` is a :class:`~irs_hardware.driver.RigIO`."""

    def __init__(self, io: RigIO, cal: Calibration, config: HardwareConfig | None = None):
        self.io = io
        self.cal = cal
        self.cfg = config or HardwareConfig()
        self.fault = ''
        self.fault_time = math.nan
        self.faults = 0
        self.refused = {'steering': 0, 'drive': 0}
        self.counts = deque(maxlen=self.cfg.belt_window + 1)
        self.last_tick = None
        self.lost_samples = 0
        self.steer = 0.0
        self.voltage = 0.0
        self.setpoint_sent = None
        self.setpoint_time = -math.inf
        self.bad_seen = 0
        self.last_reading_time = None
        self.board_time = -math.inf        # last write to the board

    # ---------------------------------------------------------------- supervisor
    @property
    def ok(self) -> bool:
        return not self.fault

    def trip(self, reason: str, now: float) -> None:
        """Latch ``reason`` (the first one is kept) and put the outputs in the safe state."""
        if not self.fault:
            self.fault, self.fault_time = reason, now
            self.faults += 1
        self.steer, self.voltage = 0.0, 0.0
        self.write_outputs(None, now)

    def reset(self, triggered: bool, now: float) -> str:
        """Clear the latched fault after restarting the devices; '' or why it cannot."""
        try:
            self.io.close()
            self.io.start(triggered)
        except (LinkError, DriveError) as exc:
            return str(exc)
        self.fault = ''
        self.setpoint_sent = None
        self.counts.clear()
        self.last_tick = None
        self.bad_seen = self.io.bad_frames
        self.last_reading_time = now
        return ''

    # ---------------------------------------------------------------- inputs
    def measure(self, reading: Reading) -> Measurement:
        """Measurement of one reading; a garbled frame or a board fault bit trips the fault."""
        now = reading.received
        self.last_reading_time = now
        if self.io.bad_frames != self.bad_seen:
            self.bad_seen = self.io.bad_frames
            self.trip('garbled frame from the board (CRC)', now)
        if reading.status & P.BAD_HOST_FRAME:
            self.trip('the board received a garbled frame', now)
        if reading.status & P.WATCHDOG_TRIPPED:
            self.trip('board watchdog tripped (no command in time)', now)
        if self.last_tick is not None and reading.tick != self.last_tick + 1:
            self.lost_samples += max(0, reading.tick - self.last_tick - 1)
        self.last_tick = reading.tick
        full = self.cfg.adc_full_scale
        raw = self.cal.pots.angles(reading.adc)
        angles = tuple(math.nan if n <= 0 or n >= full else a for n, a in zip(reading.adc, raw))
        self.counts.append((reading.tick, reading.belt))
        (k0, c0), (k1, c1) = self.counts[0], self.counts[-1]
        speed = ((c1 - c0) / self.cal.belt.counts_per_metre / ((k1 - k0) * self.cfg.dt)
                 if k1 > k0 else 0.0)
        return Measurement(reading.tick, angles, speed, reading.belt)

    def check_link(self, now: float) -> bool:
        """Real time: trip if no reading for ``link_timeout``; True while the link is fine."""
        last = self.last_reading_time
        if last is not None and now - last > self.cfg.link_timeout and self.ok:
            self.trip(f'link lost: no sample for {1e3 * (now - last):.1f} ms '
                      f'(> {1e3 * self.cfg.link_timeout:.0f} ms)', now)
        return self.ok

    # ---------------------------------------------------------------- commands
    def command_steer(self, value: float, now: float) -> None:
        if not math.isfinite(value) or abs(value) > self.cfg.steer_reject:
            self.refused['steering'] += 1
            self.trip(f'steer command {value!r} rad refused (not finite or beyond '
                      f'+-{self.cfg.steer_reject:.3f} rad)', now)
            return
        if self.ok:
            self.steer = min(STEER_LIMIT, max(-STEER_LIMIT, value))

    def command_drive(self, value: float, now: float) -> None:
        if not math.isfinite(value) or not 0.0 <= value <= self.cfg.u_max:
            self.refused['drive'] += 1
            self.trip(f'drive command {value!r} V refused (not finite or outside '
                      f'[0, {self.cfg.u_max}] V)', now)
            return
        if self.ok:
            self.voltage = value

    def outputs(self) -> tuple:
        """``(pulse [us], enable, set-point)`` now: the safe ones while a fault is latched."""
        if not self.ok:
            return self.cal.servo.centre_us, False, 0
        return (self.cal.servo.pulse_us(self.steer), True,
                self.cal.drive.setpoint(self.voltage))

    def write_outputs(self, seq, now: float, drive: bool = True) -> None:
        """Send the outputs (drive: only on a change or every ``drive_keepalive``); a device
        error trips the fault (and the other device still gets its safe output).
        """
        pulse, enable, setpoint = self.outputs()
        errors = []
        if drive and (setpoint != self.setpoint_sent
                      or now - self.setpoint_time >= self.cfg.drive_keepalive):
            try:
                self.io.write_drive(setpoint)
                self.setpoint_sent, self.setpoint_time = setpoint, now
            except DriveError as exc:
                errors.append(str(exc))
        if seq is None:
            seq = self.last_tick if self.last_tick is not None else 0
        try:
            self.io.write_board(seq, pulse, enable)
            self.board_time = now
        except LinkError as exc:
            errors.append(str(exc))
        if errors and not self.fault:
            self.trip(errors[0], now)

    def keep_drive_alive(self, now: float) -> None:
        """Write the current set-point again (the drive's own watchdog); an error trips."""
        try:
            self.io.write_drive(self.outputs()[2])
            self.setpoint_time = now
        except DriveError as exc:
            self.trip(str(exc), now)

    def check_drive(self, now: float) -> tuple:
        """Poll the drive: ``(status, belt speed)`` or trip on an error or a drive trip."""
        try:
            status, speed = self.io.drive_status()
        except DriveError as exc:
            self.trip(str(exc), now)
            return None, math.nan
        if status & TRIPPED and self.ok:
            self.trip('the drive tripped (communication loss)', now)
        return status, speed
