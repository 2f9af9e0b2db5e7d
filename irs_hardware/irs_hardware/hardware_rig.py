"""The hardware node's core: readings to measurements, commands to outputs, and the safety
supervisor (no rclpy).

Measurements of a board reading ``k`` (its ``tick``): the joint angles through the pot
calibration (NaN where a pot reads a rail: wiper off its track or broken), the belt travel
``s_k = n_k / counts_per_metre`` and its speed over the last ``belt_window`` samples,
``(s_k - s_{k-w}) / (w dt)`` [m/s]; the torque car (``wheels``): each wheel's forward count
``n_k`` (unwrapped from the board's 32-bit counter) and its speed over the last ``wheel_window``
samples, ``2 pi (n_k - n_{k-w}) / (N w dt)`` [rad/s] (fewer samples until the window is full),
as ``vehicle_sim``'s encoders.

Commands: the steer angle [rad] is clipped to the +-15 deg limit and turned into a pulse by the
servo calibration; the drive voltage [V] into the drive's set-point, sent on a change and every
``drive_keepalive`` (the drive's communication-loss stop); the wheel torques [N m], clipped to
``wheel_torque_limit``, into the motor commands [per-mille]. A command that is not finite, a steer
beyond ``steer_reject``, a voltage outside [0, u_max], a wheel torque beyond
``wheel_torque_reject`` or a wheel lock (the rig's wheels have no brake) is refused.

Supervisor: the first of these latches a fault (:attr:`HardwareRig.fault`, its reason kept):
a refused command; the link silent for ``link_timeout`` (real time) or a read or write error;
a garbled frame from the board (CRC), or the board reporting a bad host frame or its own
watchdog; a stale steering or wheel command (real time, ``command_timeout`` after the first);
the drive's Modbus failing or reporting a trip; a board without the wheel counts the torque car
needs. While latched, every output is the safe one: servo at the calibrated centre, enable line
low and motor commands 0 (the board first: it stops the belt whatever the drive does), drive
set-point 0 (:meth:`HardwareRig.outputs`), and :meth:`HardwareRig.reset` clears it only once
the devices answer again.
"""
from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass

from irs_models.constants import STEER_LIMIT_DEG

from .calibration import Calibration
from .driver import DriveError, LinkError, Reading, RigIO
from .drive_modbus import TRIPPED
from . import protocol as P

STEER_LIMIT = math.radians(STEER_LIMIT_DEG)
ZERO_TORQUE = (0.0, 0.0, 0.0, 0.0)


@dataclass
class HardwareConfig:
    """The core's constants (SI; :mod:`.hardware_params` documents each)."""

    dt: float = 1e-3                       # [s] the board's sampling interval
    link_timeout: float = 0.02             # [s] no sample for this long: link lost
    command_timeout: float = 0.1           # [s] steering older than this: stale (real time)
    steer_reject: float = math.radians(30.0)   # [rad]
    u_max: float = 12.7                    # [V] drive range
    belt_window: int = 10                  # [samples]
    drive_keepalive: float = 0.1           # [s] rewrite the set-point at least this often
    adc_full_scale: int = 65535            # [counts] a pot at 0 or this reads a rail
    wheels: bool = False                   # the torque car's wheel channels
    wheel_window: int = 5                  # [samples]
    wheel_torque_limit: float = 0.3        # [N m] clipped (the motors' limit)
    wheel_torque_reject: float = 0.6       # [N m] refused beyond


@dataclass(frozen=True)
class Measurement:
    """What one board reading measures (module docstring)."""

    tick: int
    angles: tuple          # [rad], NaN where the pot reads a rail
    belt_speed: float      # [m/s]
    belt_count: int
    wheel_counts: tuple = ()       # torque car: forward counts FL, FR, RL, RR
    wheel_velocity: tuple = ()     # torque car: [rad/s]


class HardwareRig:
    """See the module docstring. ``io`` is a :class:`~irs_hardware.driver.RigIO`."""

    def __init__(self, io: RigIO, cal: Calibration, config: HardwareConfig | None = None):
        self.io = io
        self.cal = cal
        self.cfg = config or HardwareConfig()
        self.fault = ''
        self.fault_time = math.nan
        self.faults = 0
        self.refused = {'steering': 0, 'drive': 0, 'wheels': 0}
        self.counts = deque(maxlen=self.cfg.belt_window + 1)
        if self.cfg.wheels and cal.wheels is None:
            raise ValueError('wheels: the calibration has no wheels section (the torque car '
                             "needs the encoders' counts per revolution and the motors' "
                             'constants; docs/hardware.md)')
        self.wheel_counts = deque(maxlen=self.cfg.wheel_window + 1)
        self.wheel_raw = None              # the last raw counter values (unwrapping)
        self.wheel_total = [0] * 4         # unwrapped forward counts
        self.torque = ZERO_TORQUE
        self.last_tick = None
        self.lost_samples = 0
        self.steer = 0.0
        self.voltage = 0.0
        self.setpoint_sent = None
        self.setpoint_time = -math.inf
        self.bad_seen = 0
        self.last_reading_time = None
        self.board_time = -math.inf        # last write to the board
        self.answered = 0                  # seq of the sample the last steering answered
        self.stopped = False
        self.commands_sent = 0
        self.drive_io = threading.RLock()  # one request at a time on the drive's link

    # ---------------------------------------------------------------- supervisor
    @property
    def ok(self) -> bool:
        return not self.fault

    def trip(self, reason: str, now: float) -> None:
        """Latch ``reason`` (the first one is kept) and put the outputs in the safe state: the
        board first (its enable line stops the belt whatever the drive does), then the drive.
        """
        if not self.fault:
            self.fault, self.fault_time = reason, now
            self.faults += 1
        self.steer, self.voltage, self.torque = 0.0, 0.0, ZERO_TORQUE
        self.write_board(None, now)
        self.send_drive(0, now)            # an error here changes nothing: already latched

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
        self.wheel_counts.clear()
        self.wheel_raw = None
        self.last_tick = None
        self.bad_seen = self.io.bad_frames
        self.last_reading_time = now
        return ''

    # ---------------------------------------------------------------- inputs
    def measure(self, reading: Reading) -> Measurement:
        """Measurement of one reading; a garbled frame or a board fault bit trips the fault."""
        now = reading.received
        if self.last_reading_time is None or now > self.last_reading_time:
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
        if not self.cfg.wheels:
            return Measurement(reading.tick, angles, speed, reading.belt)
        counts, velocity = self.measure_wheels(reading)
        return Measurement(reading.tick, angles, speed, reading.belt, counts, velocity)

    def measure_wheels(self, reading: Reading) -> tuple:
        """``(forward counts, velocities [rad/s])`` of the wheels (module docstring); a reading
        without wheel counts trips the fault (and measures 0).
        """
        if reading.wheels is None or len(reading.wheels) != 4:
            self.trip('the board sent no wheel counts (a board without wheels?)',
                      reading.received)
            return (0, 0, 0, 0), (0.0, 0.0, 0.0, 0.0)
        raw = reading.wheels
        if self.wheel_raw is not None:
            for j, (a, b) in enumerate(zip(self.wheel_raw, raw)):
                self.wheel_total[j] += ((b - a + 2 ** 31) % 2 ** 32) - 2 ** 31
        else:
            self.wheel_total = list(raw)
        self.wheel_raw = raw
        counts = self.cal.wheels.counts(self.wheel_total)
        self.wheel_counts.append((reading.tick, counts))
        (k0, n0), (k1, n1) = self.wheel_counts[0], self.wheel_counts[-1]
        scale = (2.0 * math.pi / (self.cal.wheels.counts_per_rev * (k1 - k0) * self.cfg.dt)
                 if k1 > k0 else 0.0)
        return counts, tuple(scale * (b - a) for a, b in zip(n0, n1))

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

    def command_wheels(self, torques, locked, now: float) -> None:
        """Wheel torques [N m] FL, FR, RL, RR and lock flags; refused (the fault) unless four
        finite torques within ``wheel_torque_reject`` and no wheel locked.
        """
        values = tuple(float(t) for t in torques)
        bad = (len(values) != 4 or not all(math.isfinite(t) for t in values)
               or any(abs(t) > self.cfg.wheel_torque_reject for t in values))
        if bad or any(locked):
            self.refused['wheels'] += 1
            why = ("a wheel lock (the rig's wheels have no brake)" if not bad else
                   f'not 4 finite torques within +-{self.cfg.wheel_torque_reject:g} N m')
            self.trip(f'wheel torque command {list(values)!r} N m refused ({why})', now)
            return
        if self.ok:
            lim = self.cfg.wheel_torque_limit
            self.torque = tuple(min(lim, max(-lim, t)) for t in values)

    def stop(self, now: float) -> None:
        """The run is over: the safe outputs from now on, without a fault."""
        self.stopped = True
        self.write_board(None, now)
        self.send_drive(0, now)

    def outputs(self) -> tuple:
        """``(pulse [us], enable, set-point, motor commands [per-mille] or None)`` now: the safe
        ones (centre, low, 0, zeros) while a fault is latched or once stopped.
        """
        wheels = None if not self.cfg.wheels else (0, 0, 0, 0)
        if not self.ok or self.stopped:
            return self.cal.servo.centre_us, False, 0, wheels
        if wheels is not None:
            wheels = self.cal.wheels.command(self.torque)
        return (self.cal.servo.pulse_us(self.steer), True,
                self.cal.drive.setpoint(self.voltage), wheels)

    def write_outputs(self, seq, now: float) -> None:
        """Lock-step: the drive's set-point (when due, :meth:`drive_due`), then the board; the
        drive answers before the board steps, so the step is deterministic. An error trips.
        """
        setpoint = self.drive_due(now)
        if setpoint is not None:
            error = self.send_drive(setpoint, now)
            if error:
                self.trip(error, now)
        self.write_board(seq, now)

    def write_board(self, seq, now: float) -> None:
        """Servo pulse and enable line to the board, answering sample ``seq`` (None: the last
        answered one, a keep-alive); a link error trips the fault.
        """
        pulse, enable, _, wheels = self.outputs()
        if seq is None:
            seq = self.answered
        else:
            self.answered = seq
        try:
            self.io.write_board(seq, pulse, enable, wheels)
            self.board_time = now
            self.commands_sent += 1
        except LinkError as exc:
            if not self.fault:
                self.trip(str(exc), now)

    def drive_due(self, now: float):
        """The set-point to send now (changed, or ``drive_keepalive`` since the last), or None."""
        setpoint = self.outputs()[2]
        if setpoint != self.setpoint_sent or now - self.setpoint_time >= self.cfg.drive_keepalive:
            return setpoint
        return None

    def send_drive(self, setpoint: int, now: float) -> str:
        """Write the set-point, one request at a time (threads may share the drive); '' or the
        error, for the caller to trip on.
        """
        with self.drive_io:
            try:
                self.io.write_drive(setpoint)
            except DriveError as exc:
                return str(exc)
            self.setpoint_sent, self.setpoint_time = setpoint, now
            return ''

    def read_drive(self):
        """``(status word, belt speed [m/s])`` of the drive, or the error's text."""
        with self.drive_io:
            try:
                return self.io.drive_status()
            except DriveError as exc:
                return str(exc)

    def drive_verdict(self, answer, now: float) -> tuple:
        """Trip on :meth:`read_drive`'s error or a drive trip; ``(status, speed)``."""
        if isinstance(answer, str):
            if self.ok:
                self.trip(answer, now)
            return None, math.nan
        status, speed = answer
        if status & TRIPPED and self.ok:
            self.trip('the drive tripped (communication loss)', now)
        return status, speed

    def check_drive(self, now: float) -> tuple:
        """Poll the drive: ``(status, belt speed)``; trip on an error or a drive trip."""
        return self.drive_verdict(self.read_drive(), now)
