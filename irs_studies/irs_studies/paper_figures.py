"""``figures``: reproduce the paper's Figures 5-10 through the graph, in one command.

    ./irs run irs_studies figures [--runs-dir runs/figures] [--img-dir DIR]
                                  [--only treadmill actuator ...]

Each part runs its experiments (lock-step, recorded to MCAP), identifies from the bags alone and
writes its PNGs into ``--img-dir`` (default ``<runs-dir>/img``; ``make figures`` gives
``docs/img``, the figures the docs show); the numbers each part returns are printed and written
to ``<runs-dir>/figures.json`` (what ``docs/paper.md`` quotes). A part that fails is reported in
one line and the others still run; the exit code is then 1 (exit codes: docs/cli.md).

Parts, in the paper's order (module: function ``reproduce_figures(img_dir, runs_dir) -> dict``):

=============  =====================================  ==========================================
part           module                                 figures
=============  =====================================  ==========================================
treadmill      ``irs_sysid.treadmill_cli``    5 (belt steps and coast-downs)
actuator       ``irs_sysid.actuator_cli``     6 (amplitude-dependent Bode), 7 (steps)
vehicle        ``irs_sysid.vehicle_cli``      8 (closed-loop Bode), 9 (step)
figure10       ``irs_studies.figure10.study``   10 (both step sizes, seed statistics)
cycle          ``irs_sysid.cycle``            identify, design, run (beyond the paper)
=============  =====================================  ==========================================
"""
from __future__ import annotations

import importlib
import json
import sys
import time
from pathlib import Path

from irs_common.cli import BUG_HINT, InputError, RunFailed, describe, error, one_line, run_cli

#: part -> module holding its ``reproduce_figures``
PARTS = {
    'treadmill': 'irs_sysid.treadmill_cli',
    'actuator': 'irs_sysid.actuator_cli',
    'vehicle': 'irs_sysid.vehicle_cli',
    'figure10': 'irs_studies.figure10.study',
    'cycle': 'irs_sysid.cycle',
}


def add_arguments(parser) -> None:
    parser.add_argument('--img-dir', default=None, type=Path,
                        help='where the PNGs go (default <runs-dir>/img)')
    parser.add_argument('--runs-dir', default='runs/figures', type=Path,
                        help='where the experiment runs and figures.json go')
    parser.add_argument('--only', nargs='+', choices=list(PARTS), metavar='PART',
                        help=f'run these parts only ({", ".join(PARTS)})')


def reproduce(parts, img_dir: Path, runs_dir: Path, log=print) -> tuple[dict, list]:
    """Run each part; ``({part: its numbers}, [failure lines])``."""
    img_dir.mkdir(parents=True, exist_ok=True)
    runs_dir.mkdir(parents=True, exist_ok=True)
    results, failures = {}, []
    for part in parts:
        t0 = time.monotonic()
        log(f'== {part}')
        try:
            module = importlib.import_module(PARTS[part])
            numbers = module.reproduce_figures(img_dir, runs_dir / part)
        except Exception as exc:  # noqa: BLE001 -- one part's failure must not stop the others
            what = '' if isinstance(exc, (InputError, RunFailed, OSError)) else \
                f'internal error: {type(exc).__name__}: '
            failures.append(f'{part}: {what}{one_line(exc)}' + (f'; {BUG_HINT}' if what else ''))
            log(f'   FAILED: {failures[-1]}')
            continue
        results[part] = {k: (v if isinstance(v, (int, float, str, bool)) else str(v))
                         for k, v in dict(numbers).items()}
        log(f'   done in {time.monotonic() - t0:.0f} s')
    return results, failures


def _main(argv) -> int:
    import argparse
    parser = argparse.ArgumentParser(prog='figures', description=describe(__doc__))
    add_arguments(parser)
    args = parser.parse_args(argv)
    parts = args.only or list(PARTS)
    img_dir = args.img_dir or args.runs_dir / 'img'
    results, failures = reproduce(parts, img_dir, args.runs_dir)
    out = args.runs_dir / 'figures.json'
    out.write_text(json.dumps(results, indent=2, sort_keys=True) + '\n')
    for part, numbers in results.items():
        for name, value in numbers.items():
            print(f'{part:10s} {name:40s} {value:.6g}' if isinstance(value, float)
                  else f'{part:10s} {name:40s} {value}')
    print(f'numbers: {out}; figures: {img_dir}')
    for line in failures:
        error('figures', line)
    return 1 if failures else 0


def main(argv=None) -> int:
    return run_cli('figures', _main, argv)


if __name__ == '__main__':
    sys.exit(main())
