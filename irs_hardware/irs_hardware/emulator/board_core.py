"""The emulated board: IRSL firmware behaviour with the simulated rig behind its pins (no I/O).

The rig's physics is :class:`irs_vehicle_sim.rig.RigSimulation` (servo and linkage, car on the
belt, arm, belt and its encoder), stepped once per sampling interval with:

- steer command ``delta = (p - centre) / us_per_rad`` of the servo pulse ``p`` [us] (the
  emulated servo's own constants :class:`BoardTruth`, which the host knows only through its
  calibration), clipped to the servo's travel; pulse resolution 0.5 us;
- drive voltage: the drive's output (the wire) while the board's enable line is high, else 0 V;
- the car's own speed command from ``driver`` (a function of time; the person on the throttle);
- the torque car (``plant: two_track``, a board with 4 wheel counters): wheel torques
  ``T_j = s_j c_j k_t I_fs / 1000`` [N m] of the motor commands ``c_j`` [per-mille] while the
  enable line is high (the motor drivers' enable is that line), else 0 N m; the emulated motors
  are ideal torque sources with the constants of :class:`BoardTruth`.

Inputs read: the arm angles with the simulated pots' noise but without the simulator's
quantiser, through each pot (340 deg electrical, its mounting) and a 16-bit ADC over 5.12 V,
and the belt encoder's count; the torque car's wheel encoders' counts (the rig's own encoders,
``encoders.counts_per_rev``) through each one's mounting sign, wrapping at 2^32. Firmware
behaviour: ``HELLO`` starts the sampler, free-running (:meth:`BoardEmulator.tick` every
interval) or triggered (one step and one ``SAMPLE`` per ``COMMAND``: lock-step, deterministic;
``lockstep_delay`` D: the command answering sample k drives the servo and the motors from step
k + D, the link's latency); the watchdog puts the outputs in the safe state (the HELLO's safe
pulse, enable line low, motor commands 0) when ``watchdog_ms / interval`` samples in a row went
out without a good command, armed by the first command after HELLO and latched until the next
HELLO: counted in the sampler's ticks, as a firmware counts them in its timer interrupt, so a
stall of the emulator's process is no tick. A bad host frame sets a status bit. Faults on
request: garble or drop outgoing frames.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from irs_common.loop_timing import LoopTiming
from irs_vehicle_sim.rig import RigConfig, RigInputs, RigSimulation
from irs_vehicle_sim.rig_torque_car import ZERO_TORQUE

from .. import protocol as P
from .wire import BELT_SPEED, BOARD_BEAT, DRIVE_VOLTAGE, ENABLE, Wire


@dataclass
class BoardTruth:
    """The emulated devices' true constants (what calibration must find)."""

    adc_bits: int = 16
    adc_range_v: float = 5.12
    pot_excitation_v: float = 5.0
    pot_electrical_deg: float = 340.0
    joint_centre_deg: tuple = (180.0, 100.0, 30.0)   # joint angle at mid travel of each pot
    pot_sign: tuple = (1, -1, 1)
    mount_error_deg: tuple = (1.3, -0.7, 2.1)
    servo_centre_us: float = 1512.0
    servo_us_per_rad: float = 500.0 / math.radians(15.0)
    servo_travel_us: float = 520.0                    # end stops at centre +- this
    interval_us: int = 1000
    firmware: int = 1
    # the torque car's wheels FL, FR, RL, RR: the right side's encoders and motors mirrored
    encoder_sign: tuple = (1, -1, 1, -1)
    motor_sign: tuple = (1, -1, 1, -1)
    motor_constant: float = 0.02     # [N m/A] at the wheel
    driver_full_scale: float = 20.0  # [A] at 1000 per-mille

    def wheel_torques(self, commands) -> tuple:
        """Wheel torques [N m] of four motor commands [per-mille] (module docstring)."""
        full = self.motor_constant * self.driver_full_scale / P.MOTOR_FULL_SCALE
        return tuple(s * c * full for s, c in zip(self.motor_sign, commands))

    def wheel_counters(self, counts) -> tuple:
        """The board's 32-bit counter values of the encoders' forward counts."""
        return tuple(((e * int(n) + 2 ** 31) % 2 ** 32) - 2 ** 31
                     for e, n in zip(self.encoder_sign, counts))

    def adc_counts(self, angles) -> tuple:
        """ADC counts of three joint angles [rad] (NaN: the wiper at 0 V)."""
        full = 2 ** self.adc_bits
        out = []
        for a, c, s, m in zip(angles, self.joint_centre_deg, self.pot_sign, self.mount_error_deg):
            if not math.isfinite(a):
                out.append(0)
                continue
            rel = math.remainder(a - math.radians(c), 2.0 * math.pi)
            phi = math.radians(self.pot_electrical_deg / 2.0 + m) + s * rel
            volts = self.pot_excitation_v * phi / math.radians(self.pot_electrical_deg)
            out.append(int(min(full - 1, max(0, round(volts / self.adc_range_v * full)))))
        return tuple(out)

    def steer(self, pulse_us: float) -> float:
        """Steer command [rad] the servo takes from a pulse [us], within its travel."""
        p = min(self.servo_centre_us + self.servo_travel_us,
                max(self.servo_centre_us - self.servo_travel_us, pulse_us))
        return (p - self.servo_centre_us) / self.servo_us_per_rad


def rig_config(params: dict | None) -> RigConfig:
    """The rig of the emulator: ``params`` as for ``vehicle_sim`` (the ``rig.yaml`` keys), the
    simulator's arm quantiser off (the emulated ADC quantises).
    """
    params = dict(params or {})
    arm = dict(params.pop('arm', {}) or {})
    arm.update({k.split('.', 1)[1]: params.pop(k) for k in list(params) if k.startswith('arm.')})
    arm['enable_quantization'] = False
    return RigConfig.from_dict({**params, 'arm': arm})


@dataclass
class BoardStats:
    """Counters of the emulated board (its status file reports them)."""

    samples: int = 0
    commands: int = 0
    bad_host_frames: int = 0
    dropped: int = 0
    garbled: int = 0
    watchdog_trips: int = 0


class BoardEmulator:
    """See the module docstring. ``wire`` may be None (no drive: 0 V).

    ``timing`` (free-running): per sample, whether the command in force when it is taken answers
    a sample at most ``deadline`` intervals older (the loop's deadline, :data:`DEADLINE`), and
    the latency from taking sample k to applying the command answering it [s].
    """

    #: Samples within which the answer to a sample must be in force: the link's two frames
    #: take 1.36 ms at 1 Mbaud with 0.5 ms of USB latency each, so the answer to sample k is
    #: applied in step k + 1 when the host answers in 0.64 ms; sample k + 2 is the deadline.
    DEADLINE = 2

    def __init__(self, config: RigConfig, truth: BoardTruth | None = None,
                 wire: Wire | None = None, driver=None, lockstep_delay: int = 0):
        self.truth = truth or BoardTruth()
        self.sim = RigSimulation(config)
        self.dt = config.dt
        self.wire = wire
        self.driver = driver
        self.parser = P.FrameParser()
        self.stats = BoardStats()
        self.timing = LoopTiming()
        self.started = False
        self.triggered = False
        self.watchdog_ticks = 25
        self.armed = False
        self.since_command = 0
        self.tick_no = 0
        self.ack = 0
        self.enable = False
        self.safe_pulse = self._centre_ticks()
        self.pulse_ticks = self.safe_pulse
        self.wheels = P.WHEELS if config.plant == 'two_track' else 0
        self.motor = (0, 0, 0, 0)     # motor commands in force [per-mille]
        self.delayed = deque([(self.pulse_ticks, self.motor)] * lockstep_delay)
        self.tripped = False
        self.bad_pending = False
        self.safe_at = 0.0            # time the outputs last turned safe (None while not)
        self.sample_times = {}        # tick & 0xFFFF -> time the sample was taken
        self.garble_next = 0
        self.drop_next = 0
        self.jig = None               # (x, y, psi): the arm held on a calibration jig

    def _centre_ticks(self) -> int:
        return int(round(self.truth.servo_centre_us * 1e-6 / P.PULSE_TICK))

    def _set_outputs(self, pulse_ticks: int, enable: bool, now: float,
                     motor=(0, 0, 0, 0)) -> None:
        """Servo pulse, enable line and motor commands (0 while the enable line is low);
        ``safe_at`` follows the safe state's start.
        """
        self.pulse_ticks, self.enable = pulse_ticks, enable
        self.motor = tuple(motor) if enable and self.wheels else (0, 0, 0, 0)
        safe = not enable and pulse_ticks == self.safe_pulse
        if not safe:
            self.safe_at = None
        elif self.safe_at is None:
            self.safe_at = now

    # ---------------------------------------------------------------- host frames
    def receive(self, data: bytes, now: float) -> list:
        """Feed bytes from the host; returns the frames to send back at once."""
        out = []
        bad = self.parser.bad
        for msg in self.parser.feed(data):
            if isinstance(msg, P.Hello):
                out += self._hello(msg, now)
            elif isinstance(msg, P.Command) and self.started:
                out += self._command(msg, now)
        if self.parser.bad != bad:
            self.stats.bad_host_frames += self.parser.bad - bad
            self.bad_pending = True
        return out

    def _hello(self, msg: P.Hello, now: float) -> list:
        self.started = True
        self.triggered = msg.mode == 1
        self.watchdog_ticks = max(1, round(msg.watchdog_ms * 1000 / self.truth.interval_us))
        self.armed = False
        self.since_command = 0
        self.tripped = False
        self.safe_pulse = msg.safe_pulse
        self._set_outputs(self.safe_pulse, False, now)
        info = P.Info(self.truth.firmware, self.truth.adc_bits, 3, self.truth.interval_us,
                      int(P.PULSE_TICK * 1e9), msg.watchdog_ms, self.wheels)
        out = [P.encode(info)]
        if self.triggered:
            out += self._emit(now)
        return out

    def _command(self, msg: P.Command, now: float) -> list:
        self.stats.commands += 1
        if not self.tripped:
            self._set_outputs(msg.pulse_ticks, bool(msg.flags & P.DRIVE_ENABLE), now,
                              msg.wheels or (0, 0, 0, 0))
        self.ack = msg.seq
        self.armed = True
        self.since_command = 0
        sent = self.sample_times.pop(msg.seq, None)
        if sent is not None:
            self.timing.add_latency(now - sent)
        if self.triggered:
            self._step(now)
            return self._emit(now)
        return []

    # ---------------------------------------------------------------- sampler
    def tick(self, now: float) -> list:
        """Free-running: one sampling interval (watchdog, physics step, SAMPLE)."""
        if not self.started or self.triggered:
            return []
        if self.armed:
            self.since_command += 1
            self.check_watchdog(now)
        self._step(now)
        if self.armed:
            self.timing.step(((self.tick_no - self.ack) & 0xFFFF) <= self.DEADLINE)
        return self._emit(now)

    def check_watchdog(self, now: float) -> bool:
        """Trip (safe outputs, latched) once ``watchdog_ticks`` samples had no command."""
        if not self.tripped and self.since_command >= self.watchdog_ticks:
            self.tripped = True
            self.stats.watchdog_trips += 1
            self._set_outputs(self.safe_pulse, False, now)
            self._publish_wire(now)
        return self.tripped

    def pulse_us(self) -> float:
        """The servo pulse in force [us]."""
        return self.pulse_ticks * P.PULSE_TICK * 1e6

    def drive_voltage(self, now: float) -> float:
        """The drive's output [V] reaching the belt: 0 V while the enable line is low; in
        triggered mode the wire's value as it stands (the host's Modbus write is answered
        before its COMMAND), else 0 V once the drive has stopped beating.
        """
        if not self.enable or self.wire is None:
            return 0.0
        if self.triggered:
            return self.wire.get(DRIVE_VOLTAGE)
        return self.wire.drive_voltage(now)

    def _step(self, now: float):
        t = self.sim.time
        speed = self.driver(t) if self.driver is not None else self.sim.config.u0
        pulse, motor = self.pulse_ticks, self.motor
        if self.triggered and self.delayed:
            self.delayed.append((pulse, motor))
            pulse, motor = self.delayed.popleft()
        steer = self.truth.steer(pulse * P.PULSE_TICK * 1e6)
        torque = self.truth.wheel_torques(motor) if self.wheels and self.enable else ZERO_TORQUE
        self.sim.step(RigInputs(front_steer=steer, drive_voltage=self.drive_voltage(now),
                                speed_cmd=speed, wheel_torque=torque))
        self.tick_no += 1
        self._publish_wire(now)

    def _publish_wire(self, now: float):
        if self.wire is not None:
            self.wire.set(ENABLE, 1.0 if self.enable else 0.0)
            self.wire.set(BELT_SPEED, self.sim.outputs.belt_speed)
            self.wire.set(BOARD_BEAT, now)

    def arm_angles(self) -> tuple:
        """The pots' angles (with their noise): the car's, or the jig's pose while on the jig."""
        if self.jig is None:
            return self.sim.outputs.arm_angles
        return self.sim.arm.measure_tuple(*self.jig)

    def sample(self) -> P.Sample:
        """The SAMPLE of the present instant (clears the bad-host-frame bit)."""
        status = ((P.WATCHDOG_TRIPPED if self.tripped else 0)
                  | (P.BAD_HOST_FRAME if self.bad_pending else 0))
        self.bad_pending = False
        wheels = (self.truth.wheel_counters(self.sim.outputs.encoder_counts) if self.wheels
                  else None)
        return P.Sample(self.tick_no, self.ack, self.truth.adc_counts(self.arm_angles()),
                        int(self.sim.belt.encoder.count), status, wheels)

    def _emit(self, now: float) -> list:
        self.stats.samples += 1
        self.sample_times[self.tick_no & 0xFFFF] = now
        if len(self.sample_times) > 4096:
            self.sample_times.clear()
        data = P.encode(self.sample())
        if self.drop_next > 0:
            self.drop_next -= 1
            self.stats.dropped += 1
            return []
        if self.garble_next > 0:
            self.garble_next -= 1
            self.stats.garbled += 1
            data = data[:8] + bytes([data[8] ^ 0x5A]) + data[9:]
        return [data]
