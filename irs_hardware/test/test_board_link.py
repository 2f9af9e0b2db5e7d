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
