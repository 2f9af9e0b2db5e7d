"""The emulated board's link (its pty, a process): a host that stops reading for a while finds
whole frames when it reads again, a gap in the sample ticks and no garbled frame.
"""
import subprocess
import sys
import time

import serial

from irs_hardware import protocol as P


def test_a_host_reading_late_loses_whole_frames_not_bytes(tmp_path):
    link = tmp_path / 'board'
    proc = subprocess.Popen([sys.executable, '-m', 'irs_hardware.emulator.board_main',
                             '--link', str(link), '--rig-params',
                             'pkg://irs_vehicle_sim/config/rig.yaml'])
    try:
        deadline = time.monotonic() + 30.0
        while not link.is_symlink():
            assert time.monotonic() < deadline and proc.poll() is None, 'no board'
            time.sleep(0.05)
        port = serial.Serial(str(link), 1_000_000, timeout=0.05)
        port.write(P.encode(P.Hello(0, 1000, 1000)))      # no command: the watchdog stays unarmed
        parser, ticks = P.FrameParser(), []
        stall_end = time.monotonic() + 6.0     # 6 s unread: ~140 kB, more than the pty holds
        time.sleep(6.0)
        while time.monotonic() < stall_end + 1.0:
            ticks += [m.tick for m in parser.feed(port.read(65536)) if isinstance(m, P.Sample)]
        port.close()
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    gaps = [b - a for a, b in zip(ticks, ticks[1:]) if b - a != 1]
    assert parser.bad == 0, f'{parser.bad} garbled frames'
    assert len(ticks) > 500 and gaps, (len(ticks), gaps)     # whole frames lost in the stall


def test_a_port_closed_by_another_thread_mid_read_is_a_link_error(tmp_path):
    """``rig/reset`` closes the port while the node's read thread waits on it. pyserial's
    ``close()`` clears the descriptor before it marks the port closed; a wait that starts in
    between must end in a :class:`LinkError` (which the read thread expects after a reset), not
    a ``TypeError`` that ends the thread.
    """
    import os

    from irs_hardware.driver import LinkError, SerialModbusRig
    master, slave = os.openpty()
    try:
        rig = SerialModbusRig(os.ttyname(slave), 115200, drive=None)
        rig.serial = serial.Serial(os.ttyname(slave), 115200, timeout=0)
        assert rig._messages(0.01) == []          # open: nothing waiting, no error
        port, fd = rig.serial, rig.serial.fd

        def read_then_closed(n):
            data = serial.Serial.read(port, n)    # the read finds nothing waiting ...
            port.fd = None                         # ... then close() is between its steps
            return data
        port.read = read_then_closed
        try:
            rig._messages(0.05)
        except LinkError as exc:
            assert 'read failed' in str(exc), exc
        else:
            raise AssertionError('no LinkError for a port closed mid-read')
        finally:
            port.fd = fd
            port.close()
    finally:
        os.close(master)
        os.close(slave)
