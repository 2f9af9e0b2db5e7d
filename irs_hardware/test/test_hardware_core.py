"""The hardware core against the in-process emulators: measurements agree with the rig's truth
within the ADC and calibration, commands reach the servo and the drive, and every fault puts
the outputs in the safe state (centre pulse, enable low, set-point 0) and latches.
"""
import math

import pytest

from irs_hardware.calibration import load_calibration
from irs_hardware.emulator.board_core import BoardEmulator, rig_config
from irs_hardware.emulator.loopback import LoopbackIO
from irs_hardware.hardware_rig import HardwareRig
from pathlib import Path

CAL = Path(__file__).resolve().parents[1] / 'config' / 'calibration_emulated.yaml'


@pytest.fixture
def rig(tmp_path):
    board = BoardEmulator(rig_config({'x0': 0.3}))
    io = LoopbackIO(board, tmp_path / 'wire')
    hw = HardwareRig(io, load_calibration(CAL))
    io.start(True)
    return hw, io, board


def step(hw, io, steer=0.0, volts=2.27, now=0.0):
    hw.command_steer(steer, now)
    hw.command_drive(volts, now)
    hw.write_outputs(hw.last_tick or 0, now)
    return [hw.measure(r) for r in io.read(0.0)]


def test_measured_angles_match_the_rig_within_adc_and_calibration(rig):
    hw, io, board = rig
    errors = []
    for k in range(200):
        m = step(hw, io, steer=0.05 * math.sin(k / 30))
        truth = board.sim.arm.true_angles(board.sim.outputs.x, board.sim.outputs.y,
                                          board.sim.outputs.psi)
        errors += [abs(a - b) for a, b in zip(m[-1].angles, truth)]
    # pot noise 0.153 mrad rms (4.5 sigma), ADC half step 0.046 mrad, calibration < 0.05 mrad
    assert max(errors) < 4.5 * 0.1534e-3 + 0.046e-3 + 0.05e-3
    assert hw.ok


def test_steer_and_drive_commands_reach_the_devices(rig):
    hw, io, board = rig
    for _ in range(5):
        step(hw, io, steer=math.radians(5.0), volts=3.0)
    assert board.truth.steer(board.pulse_us()) == pytest.approx(math.radians(5.0), abs=3e-4)
    assert board.enable
    assert io.drive.voltage() == pytest.approx(3.0, abs=12.7e-4)


def test_steer_beyond_the_limit_is_clipped_not_refused(rig):
    hw, io, board = rig
    step(hw, io, steer=math.radians(20.0))
    assert hw.ok
    assert board.truth.steer(board.pulse_us()) == pytest.approx(math.radians(15.0), abs=3e-4)


def _assert_safe(hw, io, board, reason):
    assert not hw.ok and reason in hw.fault
    assert board.pulse_us() == pytest.approx(hw.cal.servo.centre_us, abs=0.5)
    assert not board.enable
    assert io.drive.voltage() == 0.0


@pytest.mark.parametrize('steer, volts, reason', [
    (math.nan, 2.0, 'steer command nan'), (0.0, math.inf, 'drive command inf'),
    (1.0, 2.0, 'steer command 1.0'), (0.0, -0.1, 'drive command -0.1'),
    (0.0, 13.0, 'drive command 13.0')])
def test_a_bad_command_latches_the_safe_state(rig, steer, volts, reason):
    hw, io, board = rig
    step(hw, io, steer=0.1, volts=3.0)
    step(hw, io, steer=steer, volts=volts)
    _assert_safe(hw, io, board, reason)
    step(hw, io, steer=0.1, volts=3.0)                 # good commands do not clear it
    _assert_safe(hw, io, board, reason)
    assert hw.reset(True, 0.0) == ''
    step(hw, io, steer=0.1, volts=3.0)
    assert hw.ok and board.enable


def test_a_garbled_board_frame_latches(rig):
    hw, io, board = rig
    step(hw, io)
    io.corrupt_next = 1
    step(hw, io)
    step(hw, io)
    _assert_safe(hw, io, board, 'garbled frame')


def test_the_drive_gone_latches_and_the_servo_is_centred(rig):
    hw, io, board = rig
    step(hw, io, steer=0.1, volts=3.0)
    io.drive_alive = False
    step(hw, io, steer=0.1, volts=3.5)
    assert not hw.ok and 'drive gone' in hw.fault
    assert board.pulse_us() == pytest.approx(hw.cal.servo.centre_us, abs=0.5)
    assert not board.enable                      # the enable line cuts the dead drive's output
    assert board.drive_voltage(0.0) == 0.0


def test_the_link_silent_latches_within_the_timeout(rig):
    hw, io, board = rig
    step(hw, io)
    t_last = hw.last_reading_time
    assert hw.check_link(t_last + 0.019)
    assert not hw.check_link(t_last + 0.021)
    assert 'link lost' in hw.fault
