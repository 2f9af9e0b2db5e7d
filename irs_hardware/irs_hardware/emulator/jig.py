"""The calibration procedure of docs/hardware.md run on the emulated devices (in-process).

``config/calibration_emulated.yaml`` is :func:`calibrate_emulated` of the default rig, written
by ``python -m irs_hardware.emulator.jig <out.yaml>``: the pots from the arm on the jig at
:data:`JIG_POSES` (500 readings each, the pots' noise included); the servo from the wheel's
settled angle at each of :data:`SERVO_PULSES`, approached from 100 us below and above and
averaged (the middle of the play); the belt encoder's counts per metre by the procedure's
:func:`~irs_hardware.calibrate_cli.calibrate_belt` (the belt run 2 m from the drive's panel and
left to coast to rest, :func:`belt_operator`); the drive's full scale 12.7 V.
``config/calibration_emulated_torque_car.yaml`` adds the wheels' section
(:func:`calibrate_emulated_wheels`: each wheel of the lifted torque car turned 10 turns forward
by hand, :func:`wheel_operator`; the motors' constants of :class:`BoardTruth` as from their
data sheets): ``python -m irs_hardware.emulator.jig <out.yaml> torque_car``.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from irs_vehicle_sim.rig import RigInputs, RigSimulation

from .. import protocol as P
from ..calibrate_cli import calibrate_belt, calibrate_pots, calibrate_wheels
from ..calibration import (BeltCalibration, Calibration, DriveCalibration, fit_servo,
                           save_calibration)
from .board_core import BoardEmulator, BoardTruth, rig_config

#: Jig poses (x, y, psi) [m, m, rad]: the belt's corners and middle, headings of both signs.
JIG_POSES = [[0.3, 0.0, 0.0], [0.9, 0.4, 0.3], [-0.9, 0.4, -0.3], [0.9, -0.5, -0.3],
             [-0.9, -0.5, 0.3], [0.0, 0.3, 0.0]]
#: Servo pulses [us] of the procedure: the end stops, +-100/200/400/50 us, the centre.
SERVO_PULSES = [992, 1112, 1312, 1462, 1512, 1562, 1712, 1912, 2032]


def board_reader(board: BoardEmulator):
    """A ``read_samples`` of the free-running board, 1 ms per call (no command is sent, so its
    watchdog stays unarmed).
    """
    board.receive(P.encode(P.Hello(0, 1000, 1000)), 0.0)
    clock = [0.0]

    def read():
        clock[0] += board.dt
        return [P.decode(P.SAMPLE, f[5:-2]) for f in board.tick(clock[0])]
    return read


def settled_steer(params: dict, truth: BoardTruth, pulse: float) -> float:
    """The wheel's angle [rad] at ``pulse`` [us], mean of the approaches from either side."""
    angles = []
    for side in (-100.0, 100.0):
        sim = RigSimulation(rig_config(params))
        for p in (pulse + side, pulse):
            for _ in range(2000):
                sim.step(RigInputs(front_steer=truth.steer(p)))
        angles.append(sim.outputs.actuator_front.achieved)
    return sum(angles) / 2.0


def belt_operator(board: BoardEmulator, travel: float = 2.0, voltage: float = 1.0):
    """``(mark, measured travel)`` of the belt procedure on the emulated rig: at the end mark
    the operator runs the belt from the drive's panel at ``voltage`` [V] until it has moved
    ``travel`` [m], lets it coast to rest, and measures how far the start stripe moved.
    """
    start = []

    def mark(which):
        sim = board.sim
        if which == 'start':
            while sim.belt.speed > 0.0:      # at rest at the start mark
                sim.step(RigInputs(drive_voltage=0.0))
            start.append(sim.belt.position)
            return
        while sim.belt.position - start[0] < travel:
            sim.step(RigInputs(drive_voltage=voltage))
        while sim.belt.speed > 0.0:
            sim.step(RigInputs(drive_voltage=0.0))
    return mark, lambda: board.sim.belt.position - start[0]


def calibrate_emulated(params: dict | None = None, truth: BoardTruth | None = None
                       ) -> Calibration:
    params = dict(params or {})
    truth = truth or BoardTruth()
    board = BoardEmulator(rig_config(params), truth)
    pots = calibrate_pots(board_reader(board), JIG_POSES,
                          lambda i, pose: setattr(board, 'jig', tuple(pose)), 500)
    servo = fit_servo(SERVO_PULSES, [settled_steer(params, truth, p) for p in SERVO_PULSES])
    belt = calibrate_belt(board_reader(board), *belt_operator(board))
    belt = BeltCalibration(counts_per_metre=round(belt.counts_per_metre, 6))
    return Calibration(pots=pots, servo=servo, belt=belt,
                       drive=DriveCalibration(volts_full_scale=12.7)).check()


def wheel_operator(board: BoardEmulator, turns: float):
    """``mark`` of the wheels' procedure on the emulated torque car: at the end mark every
    wheel has been turned ``turns`` turns forward by hand (the car lifted: only the wheels'
    encoders move), stopping a quarter count past its mark (a hand never stops on a count's
    edge).
    """
    enc = board.sim.torque_car.encoders

    def mark(which):
        if which == 'end':
            n = enc.params.counts_per_rev
            enc.theta = enc.theta + 2.0 * math.pi * (turns + 0.25 / n)
            enc.counts = np.floor(enc.theta * n / (2.0 * math.pi)).astype(np.int64)
    return mark


def calibrate_emulated_wheels(truth: BoardTruth | None = None, turns: float = 10.0):
    """The wheels' section of the emulated torque car (module docstring)."""
    truth = truth or BoardTruth()
    board = BoardEmulator(rig_config({'plant': 'two_track', 'u0': 0.0, 'belt_speed0': 0.0}),
                          truth)
    return calibrate_wheels(board_reader(board), wheel_operator(board, turns), turns,
                            truth.motor_constant, truth.driver_full_scale, truth.motor_sign)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m irs_hardware.emulator.jig',
        description='Calibrate the emulated rig by the procedure of docs/hardware.md.')
    parser.add_argument('output', help='the calibration YAML to write')
    parser.add_argument('car', nargs='?', choices=['torque_car'],
                        help='torque_car: add the wheels section')
    args = parser.parse_args(argv)
    cal = calibrate_emulated()
    if args.car == 'torque_car':
        cal = cal.model_copy(update={'wheels': calibrate_emulated_wheels()})
    save_calibration(cal, args.output)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
