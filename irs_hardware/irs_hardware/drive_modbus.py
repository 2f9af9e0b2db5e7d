"""The treadmill's drive on Modbus (pymodbus client; no rclpy).

Register map of the drive (a variable-frequency drive's usual set; the emulator serves the same,
:mod:`.emulator.drive_main`). Holding registers (written by the host):

- ``CONTROL`` (0): bit 0 run. A write also clears a communication-loss trip.
- ``SETPOINT`` (1): speed set-point, 0..10000 = 0..100 % of the drive's full scale (the
  voltage of the 15 mph belt speed; :class:`~irs_hardware.calibration.DriveCalibration`).
- ``COMM_TIMEOUT`` (2): [ms], 0 = off. No request for this long: the drive stops itself
  (output 0, ``TRIPPED``) until ``CONTROL`` is written again; the drive's own watchdog.

Input registers (read): ``STATUS`` (0; bit 0 running, bit 1 communication-loss trip, bit 2
enable input low) and ``SPEED`` (1; the belt speed the drive reports [mm/s]).
:class:`ModbusDrive` raises :class:`DriveError` for every failed request (server gone, timeout,
exception response): the caller's safety logic decides. Its requests and :meth:`ModbusDrive.close`
take one lock: the node's drive thread and a reset (close, then start) share the client, and a
close in the middle of another thread's request would end that request, or the reset's first
one, with a bad file descriptor.
"""
from __future__ import annotations

import threading

CONTROL, SETPOINT, COMM_TIMEOUT = 0, 1, 2
STATUS, SPEED = 0, 1
RUN = 0x01
RUNNING, TRIPPED, ENABLE_LOW = 0x01, 0x02, 0x04


class DriveError(IOError):
    """A Modbus request to the drive failed (the message says which and why)."""


class ModbusDrive:
    """The drive over Modbus TCP (a serial RS-485 drive: ``pymodbus.client.ModbusSerialClient``
    with the same calls). ``timeout`` [s] bounds every request.
    """

    def __init__(self, host: str = '127.0.0.1', port: int = 5020, device_id: int = 1,
                 timeout: float = 0.05, comm_timeout_ms: int = 500):
        from pymodbus.client import ModbusTcpClient
        self.client = ModbusTcpClient(host, port=port, timeout=timeout, retries=0)
        self.device_id = device_id
        self.comm_timeout_ms = comm_timeout_ms
        self.where = f'{host}:{port}'
        self.lock = threading.Lock()

    def _call(self, what, fn, *args, **kw):
        with self.lock:
            return self._request(what, fn, *args, **kw)

    def _request(self, what, fn, *args, **kw):
        from pymodbus.exceptions import ModbusException
        try:
            if not self.client.connected and not self.client.connect():
                raise DriveError(f'drive at {self.where}: cannot connect')
            result = fn(*args, device_id=self.device_id, **kw)
        except ModbusException as exc:
            self.client.close()
            raise DriveError(f'drive at {self.where}: {what} failed ({exc})') from None
        except OSError as exc:
            self.client.close()
            raise DriveError(f'drive at {self.where}: {what} failed ({exc})') from None
        if result.isError():
            raise DriveError(f'drive at {self.where}: {what} answered {result}')
        return result

    def start(self) -> None:
        """Set the communication timeout, set-point 0, run."""
        self._call('write comm timeout', self.client.write_register, COMM_TIMEOUT,
                   self.comm_timeout_ms)
        self._call('write set-point', self.client.write_register, SETPOINT, 0)
        self._call('write control', self.client.write_register, CONTROL, RUN)

    def write_setpoint(self, value: int) -> None:
        self._call('write set-point', self.client.write_register, SETPOINT, int(value))

    def stop(self) -> None:
        """Set-point 0 and run bit off."""
        self._call('write set-point', self.client.write_register, SETPOINT, 0)
        self._call('write control', self.client.write_register, CONTROL, 0)

    def read(self) -> tuple:
        """``(status word, belt speed [m/s])``."""
        r = self._call('read status', self.client.read_input_registers, STATUS, count=2)
        return r.registers[0], r.registers[1] * 1e-3

    def close(self) -> None:
        with self.lock:
            self.client.close()
