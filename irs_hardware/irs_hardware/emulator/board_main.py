"""``board_emulator``: the emulated board on a pseudo-terminal, as a process of its own.

    board_emulator --link /tmp/irs_board [--rig-params rig.yaml] [-p x0=0.3 ...]
                   [--wire /dev/shm/irs_wire] [--control /tmp/irs_board.ctl]
                   [--status /tmp/irs_board.json] [--baud 1000000] [--usb-latency 0.0005]
                   [--driver 0:0,0.5:1.2,4:0.6] [--rt-priority 60] [--lockstep-delay 2]

``--link`` is a symbolic link to the pty's device, made once the emulator serves it and
opened by the host as it opens ``/dev/ttyACM0``. The link's timing is emulated in the
free-running mode: each frame reaches the other side ``bytes x 10 / baud`` (8N1) plus
``usb-latency`` after it is sent; the sampler
runs at SCHED_FIFO ``--rt-priority`` where permitted (a board's timer interrupt is hard real
time; a late wake-up skips the missed intervals, counted as ``loop_misses``, and the emulated
world waits meanwhile). Triggered mode (lock-step) answers at once and applies each command
``--lockstep-delay`` steps later (the link's latency in whole samples). ``--control`` is a
Unix datagram socket taking ``garble N``, ``drop N`` (the next N samples), ``silence S`` (the
cable cut for S seconds: nothing in or out), ``jig X Y PSI`` / ``jig off`` (the arm on a
calibration jig at that pose [m, m, rad]) and ``stop``; ``--status`` is rewritten every 50 ms
with the board's state as JSON (servo pulse, enable line, the torque car's motor commands,
``safe_at``: the ``time.monotonic()`` the outputs last turned safe, watchdog, counts, loop
misses (``recent_misses``: the latest late wake-ups as ``[time, intervals missed]``),
ADC-sample-to-servo latency and deadline misses). With ``-p plant=two_track`` the board
has the torque car's 4 wheel counters and motor outputs.
``--driver`` is the car's speed profile ``t:v,...`` [s:m/s], held between breakpoints.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import select
import signal
import socket
import sys
import time
import tty
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from irs_common import yaml_io
from irs_common.params import flatten

from ..paths import resolve
from .board_core import BoardEmulator, BoardTruth, rig_config
from .sched import set_fifo
from .wire import Wire


def _rig_params(files, overrides) -> dict:
    """The rig's parameters of ``vehicle_sim`` parameter files and ``key=value`` overrides (the
    node's own parameters, clock_mode and the like, left out of the files). An override is
    ``key=value`` or, as ``-p`` of a ROS node, ``key:=value``; a key that is no rig parameter
    is a ``ValueError`` naming the closest ones.
    """
    import difflib
    from irs_vehicle_sim.rig_params import rig_parameter_table
    keys = {p.name for p in rig_parameter_table()}
    values = {}
    for path in files or []:
        doc = yaml_io.safe_load(resolve(path).read_text()) or {}
        for section in doc.values():
            values.update(flatten((section or {}).get('ros__parameters', {})))
    values = {k: v for k, v in values.items() if k in keys}
    for item in overrides or []:
        key, sep, text = item.partition('=')
        key = key.strip().removesuffix(':')
        if not sep or not key:
            raise ValueError(f'-p {item!r}: expected key=value (or key:=value)')
        if key not in keys:
            close = difflib.get_close_matches(key, sorted(keys), n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else ''
            raise ValueError(f'-p {item!r}: {key!r} is not a parameter of the rig{hint}; the '
                             f"rig's parameters: docs/parameters.md#vehicle_sim-irs_vehicle_sim")
        values[key] = yaml_io.safe_load(text)
    return values


def _driver(text):
    if not text:
        return None
    points = sorted((float(a), float(b)) for a, b in
                    (p.split(':') for p in text.split(',')))
    times = [t for t, _ in points]
    speeds = [v for _, v in points]

    def speed(t):
        i = max(0, int(np.searchsorted(times, t, side='right')) - 1)
        return speeds[i]
    return speed


class Link:
    """The pty and its emulated timing (frames delivered after their due time).

    Frames the pty does not take at once (a host that reads late: the pty holds about 4 kB) wait
    in order, never cut; beyond :attr:`BACKLOG` frames the oldest waiting ones are dropped whole,
    as a USB endpoint's packets are (``dropped``): the host sees a gap in the sample ticks, never
    a garbled frame.
    """

    BACKLOG = 64

    def __init__(self, link_path: Path, baud: int, usb_latency: float):
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.slave_name = os.ttyname(slave)
        self.slave = slave                 # kept open: the pty lives while the emulator does
        os.set_blocking(self.master, False)
        self.link_path = link_path
        self.byte_time = 10.0 / baud
        self.usb_latency = usb_latency
        self.outgoing = []                  # (due, bytes)
        self.incoming = []
        self.tx = deque()                   # frames waiting for room in the pty
        self.dropped = 0

    def publish(self) -> None:
        """Make the symbolic link to the pty: the board appears, as a USB device does when it
        enumerates, once the emulator answers (a host that waits for the link then finds a
        board that serves its HELLO).
        """
        if self.link_path.is_symlink() or self.link_path.exists():
            self.link_path.unlink()
        self.link_path.symlink_to(self.slave_name)

    def delay(self, n: int) -> float:
        return n * self.byte_time + self.usb_latency

    def read(self) -> bytes:
        try:
            return os.read(self.master, 4096)
        except (BlockingIOError, OSError):
            return b''

    def write(self, data: bytes) -> None:
        self.tx.append(bytes(data))
        while len(self.tx) > self.BACKLOG + 1:
            del self.tx[1]                  # the head may be half written: keep it whole
            self.dropped += 1
        self.flush()

    def flush(self) -> None:
        """As much of the waiting frames as the pty takes now."""
        while self.tx:
            head = self.tx[0]
            try:
                n = os.write(self.master, head)
            except BlockingIOError:
                return
            except OSError:                 # no reader end: the frames go nowhere
                self.tx.clear()
                return
            if n < len(head):
                self.tx[0] = head[n:]
                return
            self.tx.popleft()

    def close(self):
        if self.link_path.is_symlink():
            self.link_path.unlink()


def _arguments(argv):
    ap = argparse.ArgumentParser(
        prog='board_emulator', description='The emulated arm and servo board (and the torque '
        "car's wheel counters and motor outputs) on a pseudo-terminal; docs/hardware.md.")
    ap.add_argument('--link', required=True, type=Path,
                    help='symbolic link to create to the pty (the host opens it as it opens '
                    '/dev/ttyACM0)')
    ap.add_argument('--rig-params', action='append', default=[], metavar='FILE',
                    help="vehicle_sim parameter file of the emulated rig (repeatable; the "
                    "node's own parameters in it are ignored)")
    ap.add_argument('-p', dest='params', action='append', default=[], metavar='KEY=VALUE',
                    help='a rig parameter, e.g. -p plant=two_track (key:=value too; '
                    'repeatable; after the files)')
    ap.add_argument('--wire', type=Path,
                    help='shared-memory file of the belt speed, shared with drive_emulator')
    ap.add_argument('--control', type=Path,
                    help='Unix datagram socket taking garble N, drop N, silence S, jig X Y PSI, '
                    'jig off, stop')
    ap.add_argument('--status', type=Path,
                    help="JSON file rewritten every 50 ms with the board's state")
    ap.add_argument('--baud', type=int, default=1_000_000,
                    help="the link's emulated rate [bit/s] (default %(default)s)")
    ap.add_argument('--usb-latency', type=float, default=0.0005,
                    help="added to each frame's transfer time [s] (default %(default)s)")
    ap.add_argument('--driver', default='', metavar='T:V,...',
                    help="the car's speed profile [s:m/s], held between breakpoints")
    ap.add_argument('--rt-priority', type=int, default=0,
                    help="the sampler's SCHED_FIFO priority where permitted (0: none)")
    ap.add_argument('--lockstep-delay', type=int, default=0,
                    help='lock-step (triggered) mode: a command applies this many steps later '
                    '(0..1000)')
    return ap.parse_args(argv)


def board_from_args(argv, wire=None) -> BoardEmulator:
    """The emulated board the command line ``argv`` describes (its rig, driver and lock-step
    delay; ``--link`` and the other I/O arguments are parsed but not opened). ``ValueError``
    or ``OSError`` names a bad argument or file. The offline twin builds the board of an
    experiment's ``devices`` entry with this.
    """
    args = _arguments(argv)
    config = rig_config(_rig_params(args.rig_params, args.params))
    if not 0 <= args.lockstep_delay <= 1000:
        raise ValueError(f'--lockstep-delay {args.lockstep_delay}: expected 0..1000 steps')
    return BoardEmulator(config, BoardTruth(), wire, _driver(args.driver), args.lockstep_delay)


def main(argv=None) -> int:
    args = _arguments(argv)
    try:
        board = board_from_args(argv, Wire(args.wire) if args.wire else None)
    except (ValueError, OSError) as exc:
        print(f'board_emulator: {exc}', file=sys.stderr)
        return 2
    config = board.sim.config
    link = Link(args.link, args.baud, args.usb_latency)
    ctl = None
    if args.control:
        if args.control.exists():
            args.control.unlink()
        ctl = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        ctl.bind(str(args.control))
        ctl.setblocking(False)
    loop = BoardLoop(board, link, ctl, args.status)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):   # a clean stop: exit 0
        signal.signal(sig, lambda *_: loop.stop())
    note = set_fifo(args.rt_priority)
    # A full collection then scans only what the loop makes, not ~1e5 objects of numpy and
    # the rig: no pause of tens of ms at 1 kHz.
    gc.collect()
    gc.freeze()
    link.publish()         # the board appears once it serves its pty
    print(f'board_emulator: {args.link} -> {link.slave_name}, rig dt {config.dt} s, {note}',
          flush=True)
    try:
        loop.run()
    finally:
        if args.status:
            loop.write_status()
        link.close()
        if args.control and args.control.exists():
            args.control.unlink()
    return 0


#: How many of the sampler's latest late wake-ups the status lists (``recent_misses``).
RECENT_MISSES = 64


@dataclass
class BoardLoop:
    """The emulator's event loop: the pty, the control socket, the sampler's ticks."""

    board: BoardEmulator
    link: Link
    ctl: socket.socket | None
    status_path: Path | None
    running: bool = True
    silent_until: float = 0.0
    misses: int = 0
    #: the latest late wake-ups of the sampler: (time.monotonic(), intervals missed)
    recent_misses: deque = field(default_factory=lambda: deque(maxlen=RECENT_MISSES))
    ticks: int = 0
    next_tick: float | None = None
    next_status: float = 0.0
    fds: list = field(default_factory=list)

    def stop(self):
        self.running = False

    def run(self):
        self.fds = [self.link.master] + ([self.ctl] if self.ctl else [])
        while self.running:
            ready = self._wait()
            now = time.monotonic()
            if self.ctl in ready:
                self._control(now)
            if self.link.master in ready:
                self._host_bytes(now)
            self._deliver(now)
            self._sample(now)
            if self.status_path and now >= self.next_status:
                self.next_status = now + 0.05
                self.write_status()

    def _wait(self) -> list:
        now = time.monotonic()
        link = self.link
        waits = [now + 0.01] + ([self.next_tick] if self.next_tick is not None else [])
        waits += [d for d, _ in link.outgoing[:1]] + [d for d, _ in link.incoming[:1]]
        return select.select(self.fds, [], [], max(0.0, min(waits) - now))[0]

    def _control(self, now):
        try:
            text = self.ctl.recv(256).decode(errors='replace').split()
        except BlockingIOError:
            return
        if not text:
            return
        verb, arg = text[0], (text[1] if len(text) > 1 else '1')
        if verb == 'garble':
            self.board.garble_next += int(arg)
        elif verb == 'drop':
            self.board.drop_next += int(arg)
        elif verb == 'silence':
            self.silent_until = now + float(arg)
        elif verb == 'jig':
            self.board.jig = None if arg == 'off' else tuple(float(v) for v in text[1:4])
        elif verb == 'stop':
            self.running = False

    def _host_bytes(self, now):
        data = self.link.read()
        if not data or now < self.silent_until:
            return
        if self.board.triggered or not self.board.started:
            for frame in self.board.receive(data, now):
                self._answer(frame)
        else:
            self.link.incoming.append((now + self.link.delay(len(data)), data))

    def _deliver(self, now):
        link = self.link
        while link.incoming and link.incoming[0][0] <= now:
            _, data = link.incoming.pop(0)
            for frame in self.board.receive(data, now):
                self._answer(frame)
        while link.outgoing and link.outgoing[0][0] <= now:
            link.write(link.outgoing.pop(0)[1])
        link.flush()

    def _answer(self, frame: bytes) -> None:
        """An answer to the host (INFO, a triggered SAMPLE): at once, but behind the samples
        still on their way (a serial link keeps its order).
        """
        if self.link.outgoing:
            self.link.outgoing.append((self.link.outgoing[-1][0], frame))
        else:
            self.link.write(frame)

    def _sample(self, now):
        board = self.board
        if not board.started or board.triggered:
            self.next_tick = None
            return
        if self.next_tick is None:
            self.next_tick = now
        if now < self.next_tick:
            return
        interval = board.dt
        late = int((now - self.next_tick) / interval)
        if late:
            self.misses += late
            self.recent_misses.append((now, late))
            board.timing.late_ticks += late
            self.next_tick += late * interval   # the sampler skips what it missed
        self.ticks += 1
        for frame in board.tick(now):
            if now >= self.silent_until:
                self.link.outgoing.append((now + self.link.delay(len(frame)), frame))
        self.next_tick += interval

    def write_status(self):
        """The board's state as JSON (module docstring), replaced atomically."""
        board, s = self.board, self.board.stats
        doc = {'pulse_us': board.pulse_us(), 'enable': board.enable, 'tripped': board.tripped,
               'safe_at': board.safe_at, 'started': board.started,
               'triggered': board.triggered, 'tick': board.tick_no, 'samples': s.samples,
               'commands': s.commands, 'bad_host_frames': s.bad_host_frames,
               'dropped': s.dropped, 'garbled': s.garbled, 'watchdog_trips': s.watchdog_trips,
               'link_dropped': self.link.dropped,
               'loop_misses': self.misses, 'recent_misses': list(self.recent_misses),
               'loop_ticks': self.ticks, 'time': board.sim.time,
               'belt_speed': board.sim.outputs.belt_speed,
               'belt_position': board.sim.belt.position,
               'belt_count': int(board.sim.belt.encoder.count), 'y_s': board.sim.outputs.y_s,
               'x': board.sim.outputs.x,
               'steer_achieved': board.sim.outputs.actuator_front.achieved,
               'wheels': board.wheels, 'motor_commands': list(board.motor),
               'timing': board.timing.summary()}
        tmp = self.status_path.with_suffix('.tmp')
        tmp.write_text(json.dumps(doc))
        os.replace(tmp, self.status_path)


if __name__ == '__main__':
    sys.exit(main())
