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


class _BootingBoard:
    """A board on a pty that ignores what comes for ``boot`` seconds (its bootloader after the
    DTR reset of the port's opening, or a stalled emulator when ``keep`` is set: the bytes wait
    and are answered afterwards) and then answers every HELLO with an INFO and, triggered, a
    sample of its current tick; every COMMAND steps the tick and sends the next sample.
    """

    def __init__(self, boot: float, keep: bool):
        import os
        import threading
        self.master, self.slave = os.openpty()
        import tty
        tty.setraw(self.slave)
        self.name = os.ttyname(self.slave)
        self.boot, self.keep = boot, keep
        self.hellos, self.tick, self.running = 0, 1000, True
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        import os
        import select
        parser, begin = P.FrameParser(), time.monotonic()
        while self.running:
            if not select.select([self.master], [], [], 0.01)[0]:
                continue
            if time.monotonic() - begin < self.boot and not self.keep:
                os.read(self.master, 4096)              # lost in the bootloader
                continue
            if time.monotonic() - begin < self.boot:
                time.sleep(0.01)                          # stalled: the bytes wait
                continue
            out = b''
            for msg in parser.feed(os.read(self.master, 4096)):
                if isinstance(msg, P.Hello):
                    self.hellos += 1
                    out += P.encode(P.Info(P.VERSION, 16, 3, 1000, 500, msg.watchdog_ms, 0))
                    if msg.mode == 1:
                        out += P.encode(P.Sample(self.tick, 0, (1, 2, 3), 0))
                elif isinstance(msg, P.Command):
                    self.tick += 1
                    out += P.encode(P.Sample(self.tick, msg.seq, (1, 2, 3), 0))
            os.write(self.master, out)

    def close(self):
        import os
        self.running = False
        self.thread.join(timeout=2.0)
        os.close(self.master)
        os.close(self.slave)


class _NoDrive:
    def start(self):
        pass

    def close(self):
        pass


def test_a_board_that_boots_after_the_port_opens_answers_a_repeated_hello():
    """An Arduino resets when its port is opened and its bootloader loses the first HELLO: the
    host repeats it until the INFO comes.
    """
    from irs_hardware.driver import SerialModbusRig
    board = _BootingBoard(boot=4 * P.HELLO_RESEND, keep=False)
    rig = SerialModbusRig(board.name, 115200, drive=_NoDrive())
    try:
        rig.start(triggered=False)
        assert rig.info.firmware == P.VERSION
        assert board.hellos >= 1
    finally:
        rig.close()
        board.close()


def test_answers_to_repeated_hellos_give_each_tick_once():
    """A board stalled while three HELLOs wait answers each (triggered: an INFO and a sample of
    the same tick); the host reads that tick once, then the next one after its command.
    """
    from irs_hardware.driver import SerialModbusRig
    board = _BootingBoard(boot=2.5 * P.HELLO_RESEND, keep=True)
    rig = SerialModbusRig(board.name, 115200, drive=_NoDrive())
    try:
        rig.start(triggered=True)
        ticks = [r.tick for r in rig.read(0.5)]
        deadline = time.monotonic() + 2.0
        while board.hellos < 3 and time.monotonic() < deadline:
            ticks += [r.tick for r in rig.read(0.05)]
        assert board.hellos == 3, board.hellos
        rig.write_board(ticks[-1], 1500.0, False)
        while len(ticks) < 2 and time.monotonic() < deadline:
            ticks += [r.tick for r in rig.read(0.05)]
        ticks += [r.tick for r in rig.read(0.1)]
    finally:
        rig.close()
        board.close()
    assert ticks == [1000, 1001], ticks


def test_no_answer_to_hello_is_one_line_after_the_wait():
    from irs_hardware.driver import LinkError, SerialModbusRig
    board = _BootingBoard(boot=60.0, keep=False)
    rig = SerialModbusRig(board.name, 115200, drive=_NoDrive())
    begin = time.monotonic()
    try:
        rig.start(triggered=False)
    except LinkError as exc:
        message = str(exc)
    else:
        raise AssertionError('a board that never answers was accepted')
    finally:
        rig.close()
        board.close()
    assert time.monotonic() - begin >= P.HELLO_WAIT
    import re
    assert re.search(rf'no INFO answer to \d+ HELLO in {P.HELLO_WAIT:g} s', message), message
    assert '\n' not in message
