"""``calibrate``: the rig's calibration procedure, writing the YAML the node loads.

    calibrate pots  --port /dev/ttyACM0 --poses poses.yaml --out cal.yaml [--base cal.yaml]
    calibrate servo --pulses 1100,1300,1450,1500,1550,1700,1900 --out cal.yaml [--base ...]
    calibrate belt  --port /dev/ttyACM0 --travel 4.88 --out cal.yaml [--base ...]

``pots``: for each pose of the file (``poses: [[x, y, psi], ...]`` [m, m, rad] in the
treadmill frame, the arm on the jig's pins), the operator places the arm and presses Enter; the
ADC counts are averaged over ``--samples`` readings and the joint angles of the pose come from
the arm's inverse kinematics (irs_models.arm_kinematics); :func:`~.calibration.fit_pots`.
``servo``: the board sends each pulse, the operator types the wheel angle read on the
protractor [deg]; :func:`~.calibration.fit_servo` (refuses a servo that cannot reach +-15 deg).
``belt``: the operator runs the belt over a taped length ``--travel`` [m] (Enter at the start
mark and at the end mark); counts per metre from the counter. Other sections are kept from
``--base``. Docs: docs/hardware.md, "Calibration".
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import yaml

from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

from . import protocol as P
from .calibration import (Calibration, CalibrationError, fit_belt, fit_pots, fit_servo,
                          load_calibration, save_calibration)


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


class _Board:
    """The board alone (no drive) for the procedure: free-running, commands kept alive."""

    def __init__(self, port, baud):
        import serial
        self.serial = serial.Serial(port, baud, timeout=0.05)
        self.parser = P.FrameParser()
        self.pulse_us = None
        self.serial.write(P.encode(P.Hello(0, 200, 1000)))

    def read(self):
        msgs = self.parser.feed(self.serial.read(4096))
        samples = [m for m in msgs if isinstance(m, P.Sample)]
        if samples:
            pulse = self.pulse_us if self.pulse_us is not None else 1500.0
            self.serial.write(P.encode(P.Command(samples[-1].tick, int(round(pulse * 2)), 0)))
        return samples


def _base(path):
    return load_calibration(path).model_dump() if path else None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog='calibrate', description=__doc__.split('\n')[0])
    ap.add_argument('what', choices=('pots', 'servo', 'belt'))
    ap.add_argument('--port', default='/dev/ttyACM0')
    ap.add_argument('--baud', type=int, default=1_000_000)
    ap.add_argument('--poses', type=Path)
    ap.add_argument('--pulses', default='1100,1300,1450,1500,1550,1700,1900')
    ap.add_argument('--travel', type=float)
    ap.add_argument('--samples', type=int, default=200)
    ap.add_argument('--out', type=Path, required=True)
    ap.add_argument('--base', type=Path)
    args = ap.parse_args(argv)
    try:
        doc = _base(args.base) or {}
        board = _Board(args.port, args.baud)
        if args.what == 'pots':
            poses = yaml.safe_load(args.poses.read_text())['poses']
            pots = calibrate_pots(board.read, poses, lambda i, p: input(
                f'place the arm at pose {i + 1} {p} and press Enter '), args.samples)
            doc['pots'] = pots.model_dump()
        elif args.what == 'servo':
            pulses = [float(p) for p in args.pulses.split(',')]
            angles = []
            for p in pulses:
                board.pulse_us = p
                for _ in range(20):
                    board.read()
                angles.append(math.radians(float(input(f'{p:.0f} us: wheel angle [deg]? '))))
            doc['servo'] = fit_servo(pulses, angles).model_dump()
        else:
            input('belt at the start mark: press Enter ')
            c0 = board.read()[-1].belt if board.read() else None
            input(f'belt {args.travel} m on, at the end mark: press Enter ')
            c1 = board.read()[-1].belt
            doc['belt'] = fit_belt(c1 - c0, args.travel).model_dump()
        save_calibration(Calibration.model_validate(doc).check(), args.out)
    except (CalibrationError, OSError, ValueError, KeyError, TypeError) as exc:
        print(f'calibrate: {exc}', file=sys.stderr)
        return 2
    print(f'calibrate: {args.what} written to {args.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
