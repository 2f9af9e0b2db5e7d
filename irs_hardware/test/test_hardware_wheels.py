"""The torque car's wheels through the hardware core and the in-process emulated board: the
encoders' counts and velocities are the rig's own, the torques reach the wheels within one
motor-command step, and every fault (a NaN, too large or locking torque command, the board
gone, the link silent, a garbled frame, the board's own watchdog) puts the motor commands at 0
and latches. The wheels' calibration: its conversions, its fit, and the shipped file is the
procedure on the emulated car.
"""
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_hardware import protocol as P
from irs_hardware.calibrate_cli import calibrate_wheels
from irs_hardware.calibration import (CalibrationError, WheelCalibration, fit_wheel_encoders,
                                      load_calibration)
from irs_hardware.emulator.board_core import BoardEmulator, BoardTruth, rig_config
from irs_hardware.emulator.jig import board_reader, calibrate_emulated_wheels, wheel_operator
from irs_hardware.driver import RigIO
from irs_hardware.emulator.loopback import LoopbackIO
from irs_hardware.hardware_rig import HardwareConfig, HardwareRig

CONFIG = Path(__file__).resolve().parents[1] / 'config'
CAL = CONFIG / 'calibration_emulated_torque_car.yaml'
TORQUE_CAR = {'plant': 'two_track', 'x0': 0.3, 'u0': 1.2, 'belt_speed0': 1.2}
ZERO = (0, 0, 0, 0)


@pytest.fixture
def rig(tmp_path):
    board = BoardEmulator(rig_config(TORQUE_CAR))
    io = LoopbackIO(board, tmp_path / 'wire')
    hw = HardwareRig(io, load_calibration(CAL), HardwareConfig(wheels=True))
    io.start(True)
    return hw, io, board


def step(hw, io, torque=(0.05,) * 4, locked=(False,) * 4, steer=0.0, volts=2.27):
    hw.command_steer(steer, 0.0)
    hw.command_drive(volts, 0.0)
    hw.command_wheels(torque, locked, 0.0)
    hw.write_outputs(hw.last_tick or 0, 0.0)
    return [hw.measure(r) for r in io.read(0.0)]


def test_the_encoders_are_the_rigs_own_counts_and_velocities(rig):
    hw, io, board = rig
    window = hw.cfg.wheel_window
    for k in range(300):
        m = step(hw, io, torque=(0.05, 0.05, 0.04, 0.06))[-1]
        sim = board.sim.outputs
        assert m.wheel_counts == sim.encoder_counts          # mirrored mountings undone
        if k >= window:        # the window full: vehicle_sim's velocity (its dt sum aside)
            assert np.allclose(m.wheel_velocity, sim.encoder_velocity, rtol=1e-12, atol=1e-9)
    assert hw.ok and min(m.wheel_velocity) > 30.0            # rolling forward at ~1.2 m/s


def test_the_counters_wrap_at_32_bits_without_a_jump(rig):
    hw, io, board = rig
    enc = board.sim.torque_car.encoders
    enc.theta = enc.theta + 2.0 * math.pi * (2 ** 31 - 300) / enc.params.counts_per_rev
    for _ in range(60):            # ~12 counts per step: every counter wraps on the way
        m = step(hw, io)[-1]
    assert any(abs(c) >= 2 ** 31 for c in m.wheel_counts), m.wheel_counts
    assert hw.ok and 30.0 < min(m.wheel_velocity) and max(m.wheel_velocity) < 45.0


def test_wheel_torques_reach_the_wheels_within_one_command_step(rig):
    hw, io, board = rig
    cal = hw.cal.wheels
    torque = (0.1234, -0.05, 0.29, -0.2)
    for _ in range(4):                    # the board's lock-step delay is 0 here
        step(hw, io, torque=torque)
    applied = board.sim.outputs.applied_inputs.wheel_torque
    assert np.allclose(applied, torque, atol=0.5 * cal.torque_full_scale / 1000)
    assert board.motor == tuple(round(1000 * t * s / cal.torque_full_scale)
                                for t, s in zip(torque, cal.motor_sign))
    step(hw, io, torque=(0.5, -0.5, 0.3, 0.0))     # within the reject bound: clipped to 0.3
    step(hw, io, torque=(0.5, -0.5, 0.3, 0.0))
    assert np.allclose(board.sim.outputs.applied_inputs.wheel_torque, (0.3, -0.3, 0.3, 0.0),
                       atol=0.5 * cal.torque_full_scale / 1000)
    assert hw.ok


def _assert_motors_off(hw, board, reason):
    assert not hw.ok and reason in hw.fault, hw.fault
    assert hw.outputs()[3] == ZERO
    assert board.motor == ZERO and not board.enable
    assert board.sim.outputs.applied_inputs.wheel_torque == (0.0,) * 4


@pytest.mark.parametrize('torque, locked, reason', [
    ((math.nan, 0.1, 0.1, 0.1), (False,) * 4, 'wheel torque command [nan'),
    ((0.1, math.inf, 0.1, 0.1), (False,) * 4, 'not 4 finite torques'),
    ((0.1, 0.1, 0.7, 0.1), (False,) * 4, 'within +-0.6 N m'),
    ((0.1, 0.1, 0.1), (False,) * 4, 'not 4 finite torques'),
    ((0.0,) * 4, (True, False, False, False), 'no brake')])
def test_a_bad_torque_command_latches_with_the_motors_off(rig, torque, locked, reason):
    hw, io, board = rig
    step(hw, io, torque=(0.1,) * 4)
    assert board.motor != ZERO
    step(hw, io, torque=torque, locked=locked)
    step(hw, io, torque=(0.1,) * 4)               # good commands do not clear it
    _assert_motors_off(hw, board, reason)
    assert hw.refused['wheels'] == 1
    assert hw.reset(True, 0.0) == ''
    step(hw, io, torque=(0.1,) * 4)
    assert hw.ok and board.motor != ZERO


def test_the_board_gone_latches_and_the_host_commands_zero(rig):
    hw, io, board = rig
    step(hw, io, torque=(0.1,) * 4)
    io.board_alive = False
    hw.command_wheels((0.1,) * 4, (False,) * 4, 0.0)
    hw.write_outputs(hw.last_tick, 0.0)            # the write fails: the fault
    assert not hw.ok and 'board gone' in hw.fault
    assert hw.outputs()[3] == ZERO and hw.torque == (0.0,) * 4


def test_the_link_silent_latches_and_the_motors_get_zero(rig):
    hw, io, board = rig
    step(hw, io, torque=(0.1,) * 4)
    assert not hw.check_link(hw.last_reading_time + 0.021)
    _assert_motors_off(hw, board, 'link lost')


def test_a_garbled_frame_latches_with_the_motors_off(rig):
    hw, io, board = rig
    step(hw, io, torque=(0.1,) * 4)
    io.corrupt_next = 1
    step(hw, io, torque=(0.1,) * 4)
    step(hw, io, torque=(0.1,) * 4)
    _assert_motors_off(hw, board, 'garbled frame')


def test_the_boards_watchdog_turns_the_motors_off_on_its_own():
    board = BoardEmulator(rig_config(TORQUE_CAR))
    board.receive(P.encode(P.Hello(0, 25, 1000, 3024)), 0.0)
    board.receive(P.encode(P.Command(0, 3100, P.DRIVE_ENABLE, (100, -100, 100, -100))), 0.0)
    assert board.motor == (100, -100, 100, -100)
    for k in range(1, 25):
        board.tick(k * 1e-3)
    assert board.motor != ZERO and not board.tripped
    board.tick(0.025)
    assert board.tripped and board.motor == ZERO and not board.enable
    board.receive(P.encode(P.Command(1, 3100, P.DRIVE_ENABLE, (100,) * 4)), 0.026)
    assert board.motor == ZERO                    # latched until the next HELLO


def test_a_board_without_wheel_counters_latches(tmp_path):
    board = BoardEmulator(rig_config({'x0': 0.3}))          # the lateral car's board
    io = LoopbackIO(board, tmp_path / 'wire')
    hw = HardwareRig(io, load_calibration(CAL), HardwareConfig(wheels=True))
    io.start(True)
    step(hw, io)
    assert not hw.ok and 'no wheel counts' in hw.fault


def test_wheels_without_a_wheels_calibration_is_one_sentence(tmp_path):
    board = BoardEmulator(rig_config(TORQUE_CAR))
    with pytest.raises(ValueError, match='the calibration has no wheels section'):
        HardwareRig(LoopbackIO(board, tmp_path / 'wire'),
                    load_calibration(CONFIG / 'calibration_emulated.yaml'),
                    HardwareConfig(wheels=True))


def test_wheel_calibration_conversions_round_trip():
    cal = WheelCalibration(counts_per_rev=2048, encoder_sign=[1, -1, 1, -1], motor_constant=0.02,
                           driver_full_scale=20.0, motor_sign=[1, -1, 1, -1])
    assert cal.torque_full_scale == pytest.approx(0.4)
    assert cal.command((0.1, 0.1, -0.4, 0.9)) == (250, -250, -1000, -1000)    # clipped
    assert cal.torque((250, -250, -1000, -1000)) == pytest.approx((0.1, 0.1, -0.4, 0.4))
    assert cal.counts((5, 5, -7, -7)) == (5, -5, -7, 7)


def test_fit_wheel_encoders_and_its_refusals():
    assert fit_wheel_encoders([20480, -20481, 20479, -20480], 10.0) == (2048, [1, -1, 1, -1])
    with pytest.raises(CalibrationError, match='differ by more than 0.5'):
        fit_wheel_encoders([20480, -20480, 20480, -10240], 10.0)
    with pytest.raises(CalibrationError, match='4 non-zero'):
        fit_wheel_encoders([20480, 0, 20480, 20480], 10.0)


def test_the_wheel_procedure_finds_the_emulated_encoders():
    truth = BoardTruth()
    board = BoardEmulator(rig_config({'plant': 'two_track', 'u0': 0.0, 'belt_speed0': 0.0}),
                          truth)
    cal = calibrate_wheels(board_reader(board), wheel_operator(board, 7.0), 7.0, 0.02, 20.0,
                           [1, -1, 1, -1])
    assert cal.counts_per_rev == board.sim.config.encoders['counts_per_rev']
    assert cal.encoder_sign == list(truth.encoder_sign)


def test_the_shipped_torque_car_calibration_is_the_procedure_on_the_emulators():
    shipped = load_calibration(CAL)
    assert shipped.wheels == calibrate_emulated_wheels()
    # the rest is the lateral car's file (test_calibration: the procedure on the emulators)
    lateral = load_calibration(CONFIG / 'calibration_emulated.yaml')
    assert shipped.model_copy(update={'wheels': None}) == lateral


class RecordingIO(RigIO):
    """The devices as the core sees them, recording what it writes to the board."""

    def __init__(self):
        self.writes = []

    def start(self, triggered):
        pass

    def read(self, timeout):
        return []

    def write_board(self, seq, pulse_us, enable, wheels=None):
        self.writes.append((pulse_us, enable, wheels))

    def write_drive(self, setpoint):
        pass

    def drive_status(self):
        return 0, 0.0

    @property
    def bad_frames(self):
        return 0

    def close(self):
        pass


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(width=64), min_size=4, max_size=4),
       st.lists(st.booleans(), min_size=4, max_size=4))
def test_any_torque_command_gives_bounded_motor_commands_or_the_latch(torques, locked):
    cal = load_calibration(CAL)
    io = RecordingIO()
    hw = HardwareRig(io, cal, HardwareConfig(wheels=True))
    hw.command_wheels(torques, locked, 0.0)
    _pulse, enable, _setpoint, wheels = hw.outputs()
    fine = all(math.isfinite(t) and abs(t) <= 0.6 for t in torques) and not any(locked)
    if fine:
        assert hw.ok
        limit = round(1000 * 0.3 / cal.wheels.torque_full_scale)          # 750 per-mille
        assert all(isinstance(c, int) and abs(c) <= limit for c in wheels), wheels
        applied = cal.wheels.torque(wheels)
        assert all(abs(a - min(0.3, max(-0.3, t))) <= 0.5 * cal.wheels.torque_full_scale / 1000
                   + 1e-15 for a, t in zip(applied, torques))
    else:
        assert not hw.ok and 'wheel torque command' in hw.fault
        assert wheels == ZERO and not enable
        assert io.writes[-1][1:] == (False, ZERO)          # the safe command went to the board
