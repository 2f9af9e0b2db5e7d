"""``drive_emulator``: the treadmill's drive as a Modbus TCP server (pymodbus), a process.

    drive_emulator --port 5020 --wire /dev/shm/irs_wire [--volts-full-scale 12.7]
                   [--rt-priority 60]

Serves the register map of :mod:`irs_hardware.drive_modbus` on 127.0.0.1. Its output voltage
``V = setpoint / 10000 x volts_full_scale`` while running and not tripped goes onto the wire
(:mod:`.wire`) at the moment the register is written (a host that waits for the write's answer
before its next board frame gets a deterministic lock-step), together with a heartbeat every
5 ms; the board reads it while its enable line is high. The drive's communication-loss
watchdog (``COMM_TIMEOUT``) stops the output when no request came for that long.
"""
from __future__ import annotations

import argparse
import asyncio
import signal
import sys
import time
from pathlib import Path

from pymodbus.datastore import (ModbusDeviceContext, ModbusSequentialDataBlock,
                                ModbusServerContext)
from pymodbus.server import ModbusTcpServer

from ..calibration import SETPOINT_FULL_SCALE
from .sched import set_fifo
from ..drive_modbus import (COMM_TIMEOUT, CONTROL, ENABLE_LOW, RUN, RUNNING, SETPOINT, TRIPPED)
from .wire import (BELT_SPEED, BOARD_BEAT, DRIVE_BEAT, DRIVE_VOLTAGE, DRIVE_ZERO_AT, ENABLE,
                   Wire)


class DriveState:
    """The drive's registers and behaviour (no I/O but the wire)."""

    def __init__(self, wire: Wire | None, volts_full_scale: float):
        self.wire = wire
        self.full_scale = volts_full_scale
        self.hr = [0, 0, 0]
        self.tripped = False
        self.last_request = time.monotonic()

    def write(self, address: int, values: list):
        self.last_request = time.monotonic()
        for i, v in enumerate(values):
            if 0 <= address + i < len(self.hr):
                self.hr[address + i] = int(v)
        if address <= CONTROL < address + len(values):
            self.tripped = False
        self.output()

    def touch(self):
        self.last_request = time.monotonic()

    def voltage(self) -> float:
        if self.tripped or not self.hr[CONTROL] & RUN:
            return 0.0
        return min(SETPOINT_FULL_SCALE, self.hr[SETPOINT]) / SETPOINT_FULL_SCALE * self.full_scale

    def output(self):
        """The output on the wire (the communication-loss stop checked first) and the beat."""
        now = time.monotonic()
        timeout = self.hr[COMM_TIMEOUT] * 1e-3
        if timeout > 0 and now - self.last_request > timeout and not self.tripped:
            self.tripped = True
        if self.wire is not None:
            volts = self.voltage()
            if volts == 0.0 and self.wire.get(DRIVE_VOLTAGE) != 0.0:
                self.wire.set(DRIVE_ZERO_AT, now)
            self.wire.set(DRIVE_VOLTAGE, volts)
            self.wire.set(DRIVE_BEAT, now)

    def inputs(self) -> list:
        enable = self.wire is not None and self.wire.alive(BOARD_BEAT) and self.wire.get(ENABLE)
        speed = self.wire.get(BELT_SPEED) if self.wire is not None else 0.0
        status = ((RUNNING if self.voltage() > 0.0 else 0) | (TRIPPED if self.tripped else 0)
                  | (0 if enable else ENABLE_LOW))
        return [status, int(round(max(0.0, speed) * 1000.0))]


class _Holding(ModbusSequentialDataBlock):
    def __init__(self, state: DriveState):
        super().__init__(1, [0, 0, 0])
        self.state = state

    def setValues(self, address, values):
        if not isinstance(values, list):
            values = [values]
        result = super().setValues(address, values)
        if result is None:
            self.state.write(address - 1, values)
        return result

    def getValues(self, address, count=1):
        self.state.touch()
        self.values = list(self.state.hr)
        return super().getValues(address, count)


class _Inputs(ModbusSequentialDataBlock):
    def __init__(self, state: DriveState):
        super().__init__(1, [0, 0])
        self.state = state

    def getValues(self, address, count=1):
        self.state.touch()
        self.values = self.state.inputs()
        return super().getValues(address, count)


async def _serve(state: DriveState, port: int):
    """Serve until SIGINT, SIGTERM or SIGHUP (a clean stop, as a node's: exit 0)."""
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        asyncio.get_running_loop().add_signal_handler(sig, stop.set)
    context = ModbusServerContext(devices=ModbusDeviceContext(hr=_Holding(state),
                                                              ir=_Inputs(state)), single=True)
    server = ModbusTcpServer(context, address=('127.0.0.1', port))

    async def beat():
        while True:
            state.output()
            await asyncio.sleep(0.005)
    task = asyncio.create_task(beat())
    serving = asyncio.create_task(server.serve_forever())
    try:
        await asyncio.wait([serving, asyncio.create_task(stop.wait())],
                           return_when=asyncio.FIRST_COMPLETED)
        if serving.done():
            serving.result()           # the server failed (port taken): raise its error
    finally:
        task.cancel()
        await server.shutdown()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog='drive_emulator', description="The treadmill's drive as a Modbus TCP server on "
        '127.0.0.1; docs/hardware.md.')
    ap.add_argument('--port', type=int, default=5020,
                    help='TCP port of the Modbus server (default %(default)s)')
    ap.add_argument('--wire', type=Path,
                    help='shared-memory file of the belt speed, shared with board_emulator')
    ap.add_argument('--volts-full-scale', type=float, default=12.7,
                    help="the drive's output at full scale [V] (default %(default)s)")
    ap.add_argument('--rt-priority', type=int, default=0, help='SCHED_FIFO priority (0: none)')
    args = ap.parse_args(argv)
    state = DriveState(Wire(args.wire) if args.wire else None, args.volts_full_scale)
    note = set_fifo(args.rt_priority)
    print(f'drive_emulator: Modbus TCP on 127.0.0.1:{args.port}, {note}', flush=True)
    try:
        asyncio.run(_serve(state, args.port))
    except KeyboardInterrupt:
        pass
    finally:
        if state.wire is not None:
            state.wire.set(DRIVE_VOLTAGE, 0.0)
    return 0


if __name__ == '__main__':
    sys.exit(main())
