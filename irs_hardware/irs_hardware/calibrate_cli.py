"""``calibrate``: the rig's calibration procedure, writing the YAML the node loads.

    calibrate pots  --port /dev/ttyACM0 --poses poses.yaml --out cal.yaml [--base cal.yaml]
    calibrate servo --pulses 1100,1300,1450,1500,1550,1700,1900 --out cal.yaml [--base ...]
    calibrate belt  --port /dev/ttyACM0 --travel 4.88 --out cal.yaml [--base ...]
    calibrate drive --volts-full-scale 12.7 --out cal.yaml [--base ...]
    calibrate wheels --port /dev/ttyACM0 --turns 10 --motor-constant 0.02 \
                     --driver-full-scale 20 --motor-signs 1,-1,1,-1 --out cal.yaml [--base ...]

``pots``: for each pose of the file (``poses: [[x, y, psi], ...]`` [m, m, rad] in the
treadmill frame, the arm on the jig's pins), the operator places the arm and presses Enter; the
ADC counts are averaged over ``--samples`` readings and the joint angles of the pose come from
the arm's inverse kinematics (irs_models.arm_kinematics); :func:`~.calibration.fit_pots`.
``servo``: the board sends each pulse, the operator types the wheel angle read on the
protractor [deg]; :func:`~.calibration.fit_servo` (refuses a servo that cannot reach +-15 deg).
``belt``: with the belt at rest at the start mark, Enter; the operator runs the belt (the
drive's own panel, the board holding the enable line high, or by hand) over a taped length
``--travel`` [m] and stops it at the end mark, Enter; counts per metre from the counter
difference of a sample taken after each Enter (:func:`calibrate_belt`). The board is read
and kept alive by a thread throughout (its watchdog stays fed while the operator works).
``drive``: the voltage of the set-point's full scale (the drive's 15 mph setting). ``wheels``
(the torque car, lifted off the belt, motors off): Enter, each wheel turned forward ``--turns``
whole turns by hand, Enter; counts per revolution and each encoder's sign from the counters
(:func:`calibrate_wheels`); the motors' torque constant at the wheel, the drivers' full-scale
current and the motors' signs from their data sheets and wiring. Other sections are kept from
``--base`` (a partial file is fine until pots, servo, belt and drive are there, which the node
needs). Docs: docs/hardware.md, "Calibration".
"""
from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from pathlib import Path

import numpy as np
import yaml
from pydantic import ValidationError

from irs_common import yaml_io
from irs_common.cli import InputError, describe, run_cli
from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

from . import protocol as P
from .calibration import (BeltCalibration, Calibration, CalibrationError, DriveCalibration,
                          PotCalibration, ServoCalibration, WheelCalibration, fit_belt,
                          fit_pots, fit_servo, fit_wheel_encoders)


def pose_angles(poses, geometry: ArmGeometry | None = None) -> np.ndarray:
    """Joint angles [rad] (m, 3) of jig poses ``[(x, y, psi), ...]``."""
    g = geometry or ArmGeometry()
    return np.array([inverse_kinematics(x, y, psi, g) for x, y, psi in poses])


def mean_counts(read_samples, n: int) -> np.ndarray:
    """Mean ADC counts (3,) of ``n`` readings from ``read_samples()`` (a list per call)."""
    got = []
    while len(got) < n:
        got += [s.adc for s in read_samples()]
    return np.mean(np.array(got[:n], dtype=float), axis=0)


def calibrate_pots(read_samples, poses, move, n: int = 200):
    """:func:`fit_pots` of the counts at each pose; ``move(i, pose)`` puts the arm there."""
    counts = []
    for i, pose in enumerate(poses):
        move(i, pose)
        read_samples()                    # what was sampled before the arm sat still
        counts.append(mean_counts(read_samples, n))
    return fit_pots(np.array(counts), pose_angles(poses))


def calibrate_belt(read_samples, mark, travel):
    """:func:`fit_belt` of the belt counter over ``travel`` [m] (a number, or a function
    called after the end mark: the travel measured then); ``mark('start')`` and ``mark('end')``
    wait for the operator. Each count is that of a sample taken after the mark: the samples
    read before are dropped.
    """
    counts = []
    for which in ('start', 'end'):
        mark(which)
        read_samples()
        counts.append(read_samples()[-1].belt)
    metres = travel() if callable(travel) else travel
    return fit_belt(counts[1] - counts[0], metres)


def calibrate_wheels(read_samples, mark, turns: float, motor_constant: float,
                     driver_full_scale: float, motor_signs) -> WheelCalibration:
    """The wheels' section: :func:`fit_wheel_encoders` of the counters at the two marks
    (``mark('start')``, ``mark('end')``; each count from a sample taken after the mark) over
    ``turns`` forward turns of every wheel, and the motors' data-sheet constants.
    """
    counts = []
    for which in ('start', 'end'):
        mark(which)
        read_samples()
        last = read_samples()[-1]
        if last.wheels is None:
            raise CalibrationError("the board has no wheel counters (not the torque car's)")
        counts.append(last.wheels)
    delta = [((b - a + 2 ** 31) % 2 ** 32) - 2 ** 31 for a, b in zip(*counts)]
    n, signs = fit_wheel_encoders(delta, turns)
    return WheelCalibration(counts_per_rev=n, encoder_sign=signs,
                            motor_constant=float(motor_constant),
                            driver_full_scale=float(driver_full_scale),
                            motor_sign=[int(v) for v in motor_signs])


class BoardReader:
    """The board alone for the procedure (no drive): free-running, read by a thread that
    answers every sample with the current pulse and enable line (the watchdog stays fed).
    ``read()`` returns the samples that came since the last call, waiting up to 1 s for one
    (``P.HELLO_WAIT`` for the first: the HELLO is repeated until the board samples, as
    :meth:`.driver.SerialModbusRig.start` does).
    """

    def __init__(self, port, baud, pulse_us=1500.0, enable=False):
        import serial
        self.serial = serial.Serial(port, baud, timeout=0.01)
        self.parser = P.FrameParser()
        self.pulse_us, self.enable = pulse_us, enable
        self.samples, self.error = [], None
        self.cond = threading.Condition()
        self.running = True
        self.hello = P.encode(P.Hello(0, 200, 1000, int(round(pulse_us * 2))))
        self.begin, self.sampling = time.monotonic(), False
        self.serial.write(self.hello)
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _loop(self):
        sent = 1
        try:
            while self.running:
                got = [m for m in self.parser.feed(self.serial.read(4096))
                       if isinstance(m, P.Sample)]
                self.sampling = self.sampling or bool(got)
                if not self.sampling and P.hello_due(sent, time.monotonic() - self.begin):
                    self.serial.write(self.hello)       # a board reset by the port's opening
                    sent += 1
                if got:
                    self.serial.write(P.encode(P.Command(
                        got[-1].tick, int(round(self.pulse_us * 2)),
                        P.DRIVE_ENABLE if self.enable else 0)))
                    with self.cond:
                        self.samples += got
                        del self.samples[:-10000]
                        self.cond.notify_all()
        except OSError as exc:           # serial.SerialException is an OSError
            with self.cond:
                self.error = exc
                self.cond.notify_all()

    def read(self):
        wait = 1.0 if self.sampling else max(1.0, self.begin + P.HELLO_WAIT - time.monotonic())
        deadline = time.monotonic() + wait
        with self.cond:
            while not self.samples and self.error is None and time.monotonic() < deadline:
                self.cond.wait(deadline - time.monotonic())
            if self.error is not None:
                raise OSError(f'board: {self.error}')
            if not self.samples:
                raise OSError(f'board: no sample for {wait:.1f} s (IRSL firmware? baud rate?)')
            out, self.samples = self.samples, []
        return out

    def close(self):
        self.running = False
        self.thread.join(timeout=1.0)
        self.serial.close()


SECTIONS = {'pots': PotCalibration, 'servo': ServoCalibration, 'belt': BeltCalibration,
            'drive': DriveCalibration, 'wheels': WheelCalibration}
#: The sections every rig needs (``wheels``: the torque car only).
REQUIRED = ('pots', 'servo', 'belt', 'drive')


def _check(doc: dict, where) -> dict:
    """Each section valid (one line naming the first problem); the whole file checked once
    every section is there.
    """
    for key, value in doc.items():
        if key not in SECTIONS:
            raise CalibrationError(f'{where}: unknown section {key!r}')
        try:
            SECTIONS[key].model_validate(value)
        except ValidationError as exc:
            err = exc.errors()[0]
            raise CalibrationError(f"{where}: {key}.{'.'.join(map(str, err['loc']))}: "
                                   f"{err['msg']}") from None
    if set(REQUIRED) <= set(doc):
        Calibration.model_validate(doc).check()
    return doc


def _base(path) -> dict:
    """The sections of an earlier (possibly partial) calibration file, checked."""
    if path is None:
        return {}
    doc = yaml_io.safe_load(Path(path).read_text()) or {}
    if not isinstance(doc, dict):
        raise CalibrationError(f'{path}: not a mapping of calibration sections')
    return _check(doc, path)


def _servo(board, pulses):
    angles = []
    for p in pulses:
        board.pulse_us = p
        time.sleep(0.5)                         # the servo settles
        angles.append(math.radians(float(input(f'{p:.0f} us: wheel angle [deg]? '))))
    return fit_servo(pulses, angles)


def _main(argv) -> int:
    ap = argparse.ArgumentParser(prog='calibrate', description=describe(__doc__))
    ap.add_argument('what', choices=('pots', 'servo', 'belt', 'drive', 'wheels'))
    ap.add_argument('--port', default='/dev/ttyACM0')
    ap.add_argument('--baud', type=int, default=1_000_000)
    ap.add_argument('--poses', type=Path)
    ap.add_argument('--pulses', default='1100,1300,1450,1500,1550,1700,1900')
    ap.add_argument('--travel', type=float)
    ap.add_argument('--samples', type=int, default=200)
    ap.add_argument('--volts-full-scale', type=float, default=12.7)
    ap.add_argument('--turns', type=float)
    ap.add_argument('--motor-constant', type=float)
    ap.add_argument('--driver-full-scale', type=float)
    ap.add_argument('--motor-signs', default='1,-1,1,-1')
    ap.add_argument('--out', type=Path, required=True)
    ap.add_argument('--base', type=Path)
    args = ap.parse_args(argv)
    if args.what == 'belt' and not (args.travel and args.travel > 0):
        ap.error('belt needs --travel: the taped length [m] > 0')
    if args.what == 'pots' and args.poses is None:
        ap.error('pots needs --poses: the jig poses file')
    if args.what == 'wheels' and not (args.turns and args.motor_constant
                                      and args.driver_full_scale):
        ap.error('wheels needs --turns (whole turns of each wheel), --motor-constant [N m/A] '
                 'and --driver-full-scale [A]')
    board = None
    try:
        doc = _base(args.base)
        if args.what != 'drive':
            board = BoardReader(args.port, args.baud, enable=args.what == 'belt')
        if args.what == 'pots':
            poses = yaml_io.safe_load(args.poses.read_text())['poses']
            doc['pots'] = calibrate_pots(board.read, poses, lambda i, p: input(
                f'place the arm at pose {i + 1} {p} and press Enter '), args.samples).model_dump()
        elif args.what == 'servo':
            doc['servo'] = _servo(board, [float(p) for p in args.pulses.split(',')]).model_dump()
        elif args.what == 'belt':
            prompts = {'start': 'belt at rest at the start mark: press Enter ',
                       'end': f'belt run {args.travel} m, at rest at the end mark: press Enter '}
            doc['belt'] = calibrate_belt(board.read, lambda w: input(prompts[w]),
                                         args.travel).model_dump()
        elif args.what == 'drive':
            doc['drive'] = DriveCalibration(volts_full_scale=args.volts_full_scale).model_dump()
        elif args.what == 'wheels':
            prompts = {'start': 'car lifted, wheels still at their marks: press Enter ',
                       'end': f'each wheel turned forward {args.turns:g} turns, at its mark: '
                              'press Enter '}
            doc['wheels'] = calibrate_wheels(
                board.read, lambda w: input(prompts[w]), args.turns, args.motor_constant,
                args.driver_full_scale, [int(v) for v in args.motor_signs.split(',')]
            ).model_dump()
        args.out.write_text(yaml.safe_dump(_check(doc, args.out), sort_keys=False))
    except (CalibrationError, ValueError, KeyError, TypeError, yaml.YAMLError) as exc:
        raise InputError(exc) from exc   # a bad file, pose list or fit: one line, exit 2
    finally:
        if board is not None:
            board.close()
    print(f'calibrate: {args.what} written to {args.out}')
    return 0


def main(argv=None) -> int:
    """The console script: one ``calibrate: error:`` line and the exit codes of docs/cli.md
    (2: bad input or a board/port that cannot be used).
    """
    return run_cli('calibrate', _main, argv)


if __name__ == '__main__':
    sys.exit(main())
