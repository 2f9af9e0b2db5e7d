"""``board_emulator``: the emulated board on a pseudo-terminal, as a process of its own.

    board_emulator --link /tmp/irs_board [--rig-params rig.yaml] [-p x0=0.3 ...]
                   [--wire /dev/shm/irs_wire] [--control /tmp/irs_board.ctl]
                   [--status /tmp/irs_board.json] [--baud 1000000] [--usb-latency 0.0005]
                   [--driver 0:0,0.5:1.2,4:0.6]

``--link`` is a symbolic link to the pty's device, opened by the host as it opens
``/dev/ttyACM0``. The link's timing is emulated in the free-running mode: each frame reaches
the other side ``bytes x 10 / baud`` (8N1) plus ``usb-latency`` after it is sent. Triggered
mode (lock-step) answers at once. ``--control`` is a Unix datagram socket taking ``garble N``,
``drop N`` (the next N samples), ``silence S`` (the cable cut for S seconds: nothing in or out),
``jig X Y PSI`` / ``jig off`` (the arm on a calibration jig at that pose [m, m, rad]) and
``stop``; ``--status`` is rewritten every 50 ms with the board's state as JSON (servo pulse,
enable line, watchdog, counts, loop timing, ADC-sample-to-command latency percentiles).
``--driver`` is the car's speed profile ``t:v,...`` [s:m/s], held between breakpoints.
"""
from __future__ import annotations

import argparse
import json
import os
import select
import signal
import socket
import sys
import time
import tty
from pathlib import Path

import numpy as np
import yaml

from irs_common.params import flatten

from ..paths import resolve
from .board_core import BoardEmulator, BoardTruth, rig_config
from .wire import Wire


def _rig_params(files, overrides) -> dict:
    values = {}
    for path in files or []:
        doc = yaml.safe_load(resolve(path).read_text()) or {}
        for section in doc.values():
            values.update(flatten((section or {}).get('ros__parameters', {})))
    for item in overrides or []:
        key, sep, text = item.partition('=')
        if not sep:
            raise ValueError(f'-p {item!r}: expected key=value')
        values[key.strip()] = yaml.safe_load(text)
    for key in [k for k in values if k not in _RIG_KEYS]:
        values.pop(key)       # the node's own parameters (clock_mode, ...) are not the rig's
    return values


_RIG_KEYS = None


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
    """The pty and its emulated timing (frames delivered after their due time)."""

    def __init__(self, link_path: Path, baud: int, usb_latency: float):
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.slave_name = os.ttyname(slave)
        self.slave = slave                 # kept open: the pty lives while the emulator does
        os.set_blocking(self.master, False)
        self.link_path = link_path
        if link_path.is_symlink() or link_path.exists():
            link_path.unlink()
        link_path.symlink_to(self.slave_name)
        self.byte_time = 10.0 / baud
        self.usb_latency = usb_latency
        self.outgoing = []                  # (due, bytes)
        self.incoming = []

    def delay(self, n: int) -> float:
        return n * self.byte_time + self.usb_latency

    def read(self) -> bytes:
        try:
            return os.read(self.master, 4096)
        except (BlockingIOError, OSError):
            return b''

    def write(self, data: bytes) -> None:
        try:
            os.write(self.master, data)
        except OSError:
            pass

    def close(self):
        if self.link_path.is_symlink():
            self.link_path.unlink()


def main(argv=None) -> int:
    global _RIG_KEYS
    ap = argparse.ArgumentParser(prog='board_emulator', description=__doc__.split('\n')[0])
    ap.add_argument('--link', required=True, type=Path)
    ap.add_argument('--rig-params', action='append', default=[])
    ap.add_argument('-p', dest='params', action='append', default=[])
    ap.add_argument('--wire', type=Path)
    ap.add_argument('--control', type=Path)
    ap.add_argument('--status', type=Path)
    ap.add_argument('--baud', type=int, default=1_000_000)
    ap.add_argument('--usb-latency', type=float, default=0.0005)
    ap.add_argument('--driver', default='')
    args = ap.parse_args(argv)
    try:
        from irs_vehicle_sim.rig_params import rig_parameter_table
        _RIG_KEYS = {p.name for p in rig_parameter_table()}
        config = rig_config(_rig_params(args.rig_params, args.params))
        driver = _driver(args.driver)
    except (ValueError, OSError) as exc:
        print(f'board_emulator: {exc}', file=sys.stderr)
        return 2
    wire = Wire(args.wire) if args.wire else None
    board = BoardEmulator(config, BoardTruth(), wire, driver)
    link = Link(args.link, args.baud, args.usb_latency)
    ctl = None
    if args.control:
        if args.control.exists():
            args.control.unlink()
        ctl = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        ctl.bind(str(args.control))
        ctl.setblocking(False)
    running = [True]
    signal.signal(signal.SIGTERM, lambda *_: running.__setitem__(0, False))
    signal.signal(signal.SIGINT, lambda *_: running.__setitem__(0, False))
    print(f'board_emulator: {args.link} -> {link.slave_name}, rig dt {config.dt} s', flush=True)
    try:
        _loop(board, link, ctl, args.status, running)
    finally:
        if args.status:
            _write_status(board, args.status, {})
        link.close()
        if args.control and args.control.exists():
            args.control.unlink()
    return 0


def _control(board, ctl, state, now):
    try:
        text = ctl.recv(256).decode(errors='replace').split()
    except BlockingIOError:
        return
    if not text:
        return
    verb, arg = text[0], (text[1] if len(text) > 1 else '1')
    if verb == 'garble':
        board.garble_next += int(arg)
    elif verb == 'drop':
        board.drop_next += int(arg)
    elif verb == 'silence':
        state['silent_until'] = now + float(arg)
    elif verb == 'jig':
        board.jig = None if arg == 'off' else tuple(float(v) for v in text[1:4])
    elif verb == 'stop':
        state['stop'] = True


def _loop(board: BoardEmulator, link: Link, ctl, status_path, running):
    interval = board.dt
    state = {'silent_until': 0.0, 'misses': 0, 'ticks': 0}
    next_tick = None
    next_status = 0.0
    fds = [link.master] + ([ctl] if ctl else [])
    while running[0] and not state.get('stop'):
        now = time.monotonic()
        waits = [now + 0.01]
        if next_tick is not None:
            waits.append(next_tick)
        waits += [d for d, _ in link.outgoing[:1]] + [d for d, _ in link.incoming[:1]]
        timeout = max(0.0, min(waits) - now)
        ready, _, _ = select.select(fds, [], [], timeout)
        now = time.monotonic()
        silent = now < state['silent_until']
        if ctl in ready:
            _control(board, ctl, state, now)
        if link.master in ready:
            data = link.read()
            if data and not silent:
                if board.triggered or not board.started:
                    for frame in board.receive(data, now):
                        link.write(frame)
                else:
                    link.incoming.append((now + link.delay(len(data)), data))
        while link.incoming and link.incoming[0][0] <= now:
            _, data = link.incoming.pop(0)
            for frame in board.receive(data, now):
                link.write(frame)
        if board.started and not board.triggered:
            if next_tick is None:
                next_tick = now
            if now >= next_tick:
                late = int((now - next_tick) / interval)
                if late:
                    state['misses'] += late
                    next_tick += late * interval    # the sampler skips what it missed
                state['ticks'] += 1
                for frame in board.tick(now):
                    if not silent:
                        link.outgoing.append((now + link.delay(len(frame)), frame))
                next_tick += interval
        while link.outgoing and link.outgoing[0][0] <= now:
            link.write(link.outgoing.pop(0)[1])
        if status_path and now >= next_status:
            next_status = now + 0.05
            _write_status(board, status_path, state)


def _write_status(board: BoardEmulator, path: Path, state: dict):
    lat = np.array(board.stats.latencies[-100000:]) * 1e3
    s = board.stats
    doc = {'pulse_us': board.pulse_us(), 'enable': board.enable, 'tripped': board.tripped,
           'started': board.started, 'triggered': board.triggered, 'tick': board.tick_no,
           'samples': s.samples, 'commands': s.commands, 'bad_host_frames': s.bad_host_frames,
           'dropped': s.dropped, 'garbled': s.garbled, 'watchdog_trips': s.watchdog_trips,
           'loop_misses': state.get('misses', 0), 'loop_ticks': state.get('ticks', 0),
           'time': board.sim.time, 'belt_speed': board.sim.outputs.belt_speed,
           'y_s': board.sim.outputs.y_s, 'x': board.sim.outputs.x,
           'steer_achieved': board.sim.outputs.actuator_front.achieved,
           'latency_ms': ({f'p{q}': float(np.percentile(lat, q)) for q in (50, 99, 100)}
                          if lat.size else {})}
    tmp = path.with_suffix('.tmp')
    tmp.write_text(json.dumps(doc))
    os.replace(tmp, path)


if __name__ == '__main__':
    sys.exit(main())
