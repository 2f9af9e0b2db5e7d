"""The emulated board: IRSL firmware behaviour with the simulated rig behind its pins (no I/O).

The rig's physics is :class:`irs_vehicle_sim.rig.RigSimulation` (servo and linkage, car on the
belt, arm, belt and its encoder), stepped once per sampling interval with:

- steer command ``delta = (p - centre) / us_per_rad`` of the servo pulse ``p`` [us] (the
  emulated servo's own constants :class:`BoardTruth`, which the host knows only through its
  calibration), clipped to the servo's travel; pulse resolution 0.5 us;
- drive voltage: the drive's output (the wire) while the board's enable line is high, else 0 V;
- the car's own speed command from ``driver`` (a function of time; the person on the throttle).

Inputs read: the arm angles with the simulated pots' noise but without the simulator's
quantiser, through each pot (340 deg electrical, its mounting) and a 16-bit ADC over 5.12 V,
and the belt encoder's count. Firmware behaviour: ``HELLO`` starts the sampler, free-running
(:meth:`BoardEmulator.tick` every interval) or triggered (one step and one ``SAMPLE`` per
``COMMAND``: lock-step, deterministic); the watchdog centres the servo and drops the enable
line when no good command came for ``watchdog_ms`` (latched until the next ``HELLO``); a bad
host frame sets a status bit. Faults on request: garble or drop outgoing frames.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from irs_vehicle_sim.rig import RigConfig, RigInputs, RigSimulation

from .. import protocol as P
from .wire import ENABLE, BELT_SPEED, BOARD_BEAT, Wire


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
    samples: int = 0
    commands: int = 0
    bad_host_frames: int = 0
    dropped: int = 0
    garbled: int = 0
    watchdog_trips: int = 0
    latencies: list = field(default_factory=list)   # ADC sample -> command applied [s]


class BoardEmulator:
    """See the module docstring. ``wire`` may be None (no drive: 0 V)."""

    def __init__(self, config: RigConfig, truth: BoardTruth | None = None,
                 wire: Wire | None = None, driver=None):
        self.truth = truth or BoardTruth()
        self.sim = RigSimulation(config)
        self.dt = config.dt
        self.wire = wire
        self.driver = driver
        self.parser = P.FrameParser()
        self.stats = BoardStats()
        self.started = False
        self.triggered = False
        self.watchdog_s = 0.025
        self.tick_no = 0
        self.ack = 0
        self.enable = False
        self.pulse_ticks = self._centre_ticks()
        self.tripped = False
        self.first_tick = 0
        self.bad_pending = False
        self.last_command = 0.0
        self.sample_times = {}        # tick -> time the sample was taken
        self.garble_next = 0
        self.drop_next = 0
        self.jig = None               # (x, y, psi): the arm held on a calibration jig

    def _centre_ticks(self) -> int:
        return int(round(self.truth.servo_centre_us * 1e-6 / P.PULSE_TICK))

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
        self.watchdog_s = msg.watchdog_ms * 1e-3
        self.tripped = False
        self.last_command = now
        self.first_tick = self.tick_no
        info = P.Info(self.truth.firmware, self.truth.adc_bits, 3, self.truth.interval_us,
                      int(P.PULSE_TICK * 1e9), msg.watchdog_ms, 0)
        out = [P.encode(info)]
        if self.triggered:
            out += self._emit(now)
        return out

    def _command(self, msg: P.Command, now: float) -> list:
        self.stats.commands += 1
        self.pulse_ticks = msg.pulse_ticks
        self.enable = bool(msg.flags & P.DRIVE_ENABLE) and not self.tripped
        self.ack = msg.seq
        self.last_command = now
        sent = self.sample_times.pop(msg.seq, None)
        if sent is not None:
            self.stats.latencies.append(now - sent)
        if self.triggered:
            self._step(now)
            return self._emit(now)
        return []

    # ---------------------------------------------------------------- sampler
    def tick(self, now: float) -> list:
        """Free-running: one sampling interval (watchdog, physics step, SAMPLE)."""
        if not self.started or self.triggered:
            return []
        if self.tick_no == self.first_tick:
            self.last_command = max(self.last_command, now)   # the watchdog runs from sample 1
        self.check_watchdog(now)
        self._step(now)
        return self._emit(now)

    def check_watchdog(self, now: float) -> bool:
        if self.started and not self.tripped and now - self.last_command > self.watchdog_s:
            self.tripped = True
            self.stats.watchdog_trips += 1
            self.pulse_ticks = self._centre_ticks()
            self.enable = False
            self._publish_wire(now)
        return self.tripped

    def pulse_us(self) -> float:
        return self.pulse_ticks * P.PULSE_TICK * 1e6

    def drive_voltage(self, now: float) -> float:
        if not self.enable or self.wire is None:
            return 0.0
        return self.wire.drive_voltage(now)

    def _step(self, now: float):
        t = self.sim.time
        speed = self.driver(t) if self.driver is not None else self.sim.config.u0
        self.sim.step(RigInputs(front_steer=self.truth.steer(self.pulse_us()),
                                drive_voltage=self.drive_voltage(now), speed_cmd=speed))
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
        status = ((P.WATCHDOG_TRIPPED if self.tripped else 0)
                  | (P.BAD_HOST_FRAME if self.bad_pending else 0))
        self.bad_pending = False
        return P.Sample(self.tick_no, self.ack, self.truth.adc_counts(self.arm_angles()),
                        int(self.sim.belt.encoder.count), status)

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
