"""The ``calibrate`` command on the emulated board (its pty, a process) and drive (Modbus): the
belt procedure as an operator runs it, the board kept alive while the operator works, and a
file written section by section.
"""
import json
import math
import socket
import subprocess
import sys
import threading
import time

import pytest
import yaml

from irs_hardware.calibrate_cli import main
from irs_hardware.calibration import DriveCalibration
from irs_hardware.drive_modbus import ModbusDrive


#: [s] for an emulator to come up: its imports at a tenth of a core under a CPU hog.
START_TIMEOUT = 240.0


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


def wait_for(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.02)


@pytest.fixture
def devices(tmp_path):
    port = free_port()
    procs = [subprocess.Popen(
        [sys.executable, '-m', 'irs_hardware.emulator.board_main', '--link', tmp_path / 'board',
         '--wire', tmp_path / 'wire', '--status', tmp_path / 'board.json', '--rig-params',
         'pkg://irs_vehicle_sim/config/rig.yaml', '-p', 'belt_speed0=0.0', '-p', 'u0=0.0']),
        subprocess.Popen([sys.executable, '-m', 'irs_hardware.emulator.drive_main', '--port',
                          str(port), '--wire', tmp_path / 'wire'])]
    try:
        wait_for(lambda: (tmp_path / 'board').is_symlink() and (tmp_path / 'board.json').exists(),
                 START_TIMEOUT, 'the board emulator did not come up')
        panel = ModbusDrive(port=port, comm_timeout_ms=0, timeout=1.0)
        wait_for(lambda: _try(panel.start), START_TIMEOUT, 'the drive emulator did not come up')
        yield tmp_path, panel
    finally:
        for proc in procs:
            proc.terminate()
            proc.wait(timeout=10)


def _try(fn):
    try:
        fn()
        return True
    except OSError:
        return False


def status(tmp_path) -> dict:
    return json.loads((tmp_path / 'board.json').read_text())


class Calibrate:
    """``calibrate`` as an operator runs it: a process of its own, its prompts read from its
    output, Enter written to its input.
    """

    def __init__(self, argv):
        self.proc = subprocess.Popen([sys.executable, '-u', '-m', 'irs_hardware.calibrate_cli',
                                      *argv], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        self.out = ''
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for chunk in iter(lambda: self.proc.stdout.read(1), ''):
            self.out += chunk

    def prompted(self, text: str, timeout: float = 120.0) -> None:
        wait_for(lambda: text in self.out or self.proc.poll() is not None, timeout,
                 f'no prompt {text!r}')
        assert text in self.out, self.out

    def enter(self) -> None:
        self.proc.stdin.write('\n')
        self.proc.stdin.flush()

    def finish(self, timeout: float = 60.0) -> int:
        try:
            self.proc.wait(timeout)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(10.0)
        return self.proc.returncode


#: Samples of the board (1 ms each) for which the operator keeps a prompt open: twice the
#: 200 ms watchdog that ``calibrate`` asks for, counted on the board's own clock.
HOLD_TICKS = 400


def test_belt_counts_are_read_at_the_marks_with_the_belt_at_rest(devices):
    """The operator keeps each prompt open for HOLD_TICKS samples of the board (the board kept
    alive meanwhile: no watchdog trip), runs the belt from the drive's panel between the marks
    and stops it: the counts per metre are those of the counter difference at rest.
    """
    tmp_path, panel = devices
    out = tmp_path / 'cal.yaml'
    cal = Calibrate(['belt', '--port', str(tmp_path / 'board'), '--travel', '0.35',
                     '--out', str(out)])
    try:
        cal.prompted('at rest at the start mark: press Enter')
        opened = status(tmp_path)['tick']
        wait_for(lambda: status(tmp_path)['tick'] > opened + HOLD_TICKS, 60.0,
                 'the board stopped sampling')
        start = status(tmp_path)
        cal.enter()
        cal.prompted('at rest at the end mark: press Enter')
        opened = status(tmp_path)['tick']
        panel.write_setpoint(DriveCalibration(volts_full_scale=12.7).setpoint(1.0))
        wait_for(lambda: status(tmp_path)['belt_position'] > start['belt_position'] + 0.3,
                 60.0, 'the belt does not run from the drive panel (enable line low?)')
        panel.write_setpoint(0)
        wait_for(lambda: status(tmp_path)['belt_speed'] == 0.0, 60.0, 'the belt does not stop')
        wait_for(lambda: status(tmp_path)['tick'] > opened + HOLD_TICKS, 60.0,
                 'the board stopped sampling')
        at_rest = status(tmp_path)     # a later report of the board: the count holds at rest
        wait_for(lambda: status(tmp_path)['tick'] > at_rest['tick'], 10.0,
                 'the board stopped reporting')
        end = status(tmp_path)
        assert end['belt_count'] == at_rest['belt_count']
        cal.enter()
    finally:
        code = cal.finish()
    assert code == 0, cal.out
    assert 'calibrate: belt written to' in cal.out
    assert not end['tripped'] and end['watchdog_trips'] == 0, end
    read = yaml.safe_load(out.read_text())['belt']['counts_per_metre'] * 0.35
    assert read == pytest.approx(end['belt_count'] - start['belt_count'], abs=1e-6)
    # the section is written alone; the drive's next to it, and the file keeps both
    assert main(['drive', '--volts-full-scale', '12.5', '--base', str(out),
                 '--out', str(out)]) == 0
    doc = yaml.safe_load(out.read_text())
    assert set(doc) == {'belt', 'drive'} and math.isclose(doc['drive']['volts_full_scale'], 12.5)


def test_a_belt_that_did_not_move_is_one_line(devices, monkeypatch, capsys):
    tmp_path, _panel = devices
    monkeypatch.setattr('builtins.input', lambda prompt: '')
    assert main(['belt', '--port', str(tmp_path / 'board'), '--travel', '2.0',
                 '--out', str(tmp_path / 'cal.yaml')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('calibrate: error: ') and 'needs a travel > 0 m and counts' in err
    assert err.count('\n') == 1


@pytest.mark.parametrize('case', ['bad base', 'no board'])
def test_bad_input_is_one_error_line_and_exit_2(tmp_path, capsys, case):
    base = tmp_path / 'base.yaml'
    base.write_text('- not\n- a mapping\n')
    argv = (['drive', '--base', str(base)] if case == 'bad base'
            else ['belt', '--port', str(tmp_path / 'absent'), '--travel', '1.0'])
    assert main([*argv, '--out', str(tmp_path / 'cal.yaml')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('calibrate: error: ') and err.count('\n') == 1, err
    assert not (tmp_path / 'cal.yaml').exists()
