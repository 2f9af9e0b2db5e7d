"""Calibration: fits recover known constants, the belt procedure finds the emulated encoder's
counts per metre, the shipped emulated calibration is what the procedure gives on the
emulators, bad files get one sentence.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from irs_hardware.calibrate_cli import calibrate_belt
from irs_hardware.calibration import (CalibrationError, fit_belt, fit_pots, fit_servo,
                                      load_calibration)
from irs_hardware.emulator.board_core import BoardEmulator, BoardTruth, rig_config
from irs_hardware.emulator.jig import belt_operator, board_reader, calibrate_emulated

CAL = Path(__file__).resolve().parents[1] / 'config' / 'calibration_emulated.yaml'


def test_fit_pots_recovers_gain_and_zero_across_the_wrap():
    angles = np.array([[3.0, 0.1, -0.2], [-3.0, 0.5, 0.4], [2.5, -0.3, 0.0]])
    gain, zero = np.array([1e-4, -2e-4, 1.5e-4]), np.array([30000.0, 2000.0, 40000.0])
    rel = angles.copy()
    rel[:, 0] = 3.0 + (np.mod(angles[:, 0] - 3.0 + np.pi, 2 * np.pi) - np.pi)
    counts = rel / gain + zero
    cal = fit_pots(counts, angles)
    assert np.allclose(cal.gain, gain) and np.allclose(cal.zero, zero)
    assert np.allclose(cal.angles(counts[1]), angles[1])


def test_fit_servo_refuses_a_servo_short_of_the_limit():
    with pytest.raises(CalibrationError, match='outside the travel'):
        fit_servo([1300, 1450, 1500, 1550, 1700], np.radians([-7, -2, 0, 2, 7]))


def test_fit_belt():
    assert fit_belt(12833, 1.0).counts_per_metre == 12833
    with pytest.raises(CalibrationError):
        fit_belt(0, 1.0)


def _leaves(tree, path=''):
    """``[(path, value)]`` of the numbers and Nones of a nested dict/list, in order."""
    if isinstance(tree, dict):
        return [leaf for k in sorted(tree) for leaf in _leaves(tree[k], f'{path}.{k}')]
    if isinstance(tree, list):
        return [leaf for i, v in enumerate(tree) for leaf in _leaves(v, f'{path}[{i}]')]
    return [(path, tree)]


def test_the_shipped_calibration_is_the_procedure_on_the_emulators():
    shipped = load_calibration(CAL)
    fresh = calibrate_emulated()
    # to 1e-12 of each value: the least-squares fits round differently under each OpenBLAS
    # kernel, by about 2e-15 (docs/testing.md, "The same bits on every machine")
    mine_leaves, their_leaves = _leaves(fresh.model_dump()), _leaves(shipped.model_dump())
    assert [k for k, _ in mine_leaves] == [k for k, _ in their_leaves]
    for (key, mine), (_, theirs) in zip(mine_leaves, their_leaves):
        expected = theirs if theirs is None else pytest.approx(theirs, rel=1e-12, abs=0.0)
        assert mine == expected, key
    truth = BoardTruth()
    k = 2 ** 16 * truth.pot_excitation_v / truth.adc_range_v / math.radians(340.0)
    assert np.allclose(np.abs(shipped.pots.gain), 1.0 / k, rtol=2e-4)
    assert shipped.servo.centre_us == pytest.approx(truth.servo_centre_us, abs=0.1)
    assert shipped.servo.us_per_rad == pytest.approx(truth.servo_us_per_rad, rel=2e-3)


@pytest.mark.parametrize('text, words', [
    ('pots: {gain: [1, 1], zero: [0, 0, 0]}', 'pots.gain'),
    ('[1, 2', 'not YAML'),
    ('pots: {gain: [1.0, 1.0, 1.0], zero: [0.0, 0.0, 0.0]}\nservo: {centre_us: 1500.0, '
     'us_per_rad: 1900.0, min_us: 1200.0, max_us: 1800.0}\nbelt: {counts_per_metre: 1.0}\n'
     'drive: {volts_full_scale: 12.7}', 'outside the travel')])
def test_a_bad_file_is_one_sentence(tmp_path, text, words):
    path = tmp_path / 'cal.yaml'
    path.write_text(text)
    with pytest.raises(CalibrationError, match=words) as err:
        load_calibration(path)
    assert '\n' not in str(err.value)


def test_the_belt_procedure_finds_the_encoders_counts_per_metre():
    board = BoardEmulator(rig_config({}))
    mark, travel = belt_operator(board, travel=1.5)
    cal = calibrate_belt(board_reader(board), mark, travel)
    truth = 1.0 / board.sim.belt.params.distance_per_count
    # the belt at rest at both marks: the counts differ from travel x truth by under one count
    assert abs(cal.counts_per_metre - truth) <= 1.0 / travel()
    assert travel() > 1.5


def test_the_belt_procedure_refuses_a_belt_that_did_not_move():
    board = BoardEmulator(rig_config({'belt_speed0': 0.0}))
    with pytest.raises(CalibrationError, match='needs a travel > 0 m and counts'):
        calibrate_belt(board_reader(board), lambda which: None, 2.0)
