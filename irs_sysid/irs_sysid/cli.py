"""``sysid``: identify a part of the rig from a recorded bag (``sysid <kind> <bag>``).

    ./irs run irs_sysid sysid treadmill runs/<run>/bag [--png fig5.png]
    ./irs run irs_sysid sysid actuator  <bag> [<bag> ...] [--png ...]
    ./irs run irs_sysid sysid vehicle   <bag> [--png ...]
    ./irs run irs_sysid sysid cycle     ...            (identify, design, run, compare)

Each kind is a module ``irs_sysid.<kind>_cli`` with ``add_arguments(parser)`` and
``run(args) -> int``; it fits from the bag alone, prints identified against configured values
(:mod:`.report`) and writes the paper's figure. A bad bag or argument gives one line on stderr
and exit code 2, never a traceback (exit codes: docs/cli.md).
"""
from __future__ import annotations

import argparse
import importlib
import sys

from irs_common.cli import InputError, describe, run_cli

#: kind -> (module under irs_sysid, one-line help)
KINDS = {
    'treadmill': ('treadmill_cli', 'belt: Eq. 2 gain, pole and delay, Eq. 1 F/B and B/J (Fig. 5)'),
    'actuator': ('actuator_cli', 'steering servo: amplitude-dependent pole, dead time, rate '
                                 'limit (Fig. 6-7)'),
    'vehicle': ('vehicle_cli', 'car: open loop from closed-loop frequency response, step (Fig. '
                               '8-9)'),
    'cycle': ('cycle', 'identify the plant, design MRC/RST on it, run it, report model following'),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='sysid', description=describe(__doc__))
    sub = parser.add_subparsers(dest='kind', required=True, metavar='KIND')
    for kind, (module, help_text) in KINDS.items():
        p = sub.add_parser(kind, help=help_text)
        p.set_defaults(_module=module)
        try:
            importlib.import_module(f'{__package__}.{module}').add_arguments(p)
        except ModuleNotFoundError as exc:
            if exc.name != f'{__package__}.{module}':
                raise
            p.set_defaults(_missing=True)
    return parser


def _main(argv) -> int:
    args = build_parser().parse_args(argv)
    if getattr(args, '_missing', False):
        raise InputError(f'{args.kind} identification is not available in this build')
    module = importlib.import_module(f'{__package__}.{args._module}')
    return int(module.run(args) or 0)


def main(argv=None) -> int:
    return run_cli('sysid', _main, argv)


if __name__ == '__main__':
    sys.exit(main())
