"""``bag``: one command for the bag tools.

Usage::

    bag info BAG [--validate] [--no-metadata]        (irs_bag.info)
    bag export BAG [--topics T ...] --out DIR        (irs_bag.export)
    bag play BAG [options]                           (irs_bag.play)
    bag plots BAG --out DIR                          (irs_bag.plots)
    bag rerun BAG --out FILE.rrd                     (irs_bag.rerun_export)
    bag validate BAG                                 (irs_bag.validation: CRCs, indexes)
    bag recover BAG [--out DIR]                      (irs_bag.recovery)

Every verb reads unfinished or damaged bags too: the readable part (a damaged summary is
replaced by a scan of the data section; an unfinished bag gives its complete chunks), with one
warning line on stderr saying so.

Exit codes: 0 ok; 1 the bag was read but found wanting (``validate``: problems; ``plots`` /
``rerun``: no usable topic; ``play``: subscriber timeout); 2 unreadable bag (one line naming
the file and what is wrong) or usage error. Errors are one line, never a traceback.
"""
from __future__ import annotations

import sys
from typing import List, Optional

COMMANDS = {
    'info': 'show topics, counts, rates, metadata',
    'export': 'one CSV per topic',
    'play': 'replay onto the topics with the recorded timing',
    'plots': 'PNG plots (lateral, steering, belt, car position)',
    'rerun': 'a rerun .rrd recording (top-down view + time series)',
    'validate': 'check CRCs, indexes and metadata.yaml',
    'recover': 'write a valid bag from an unfinished or damaged one',
}


def _usage() -> str:
    lines = ['usage: bag <command> [args...]', '', 'commands:']
    lines += [f'  {k:<9} {v}' for k, v in COMMANDS.items()]
    lines.append("\n'bag <command> --help' for the options of a command.")
    return '\n'.join(lines)


def _validate(argv: List[str]) -> int:
    import argparse

    from .reader import BagError
    from .validation import validate

    p = argparse.ArgumentParser(
        prog='bag validate', description='Validate a bag (CRCs, indexes, metadata.yaml).')
    p.add_argument('bag')
    args = p.parse_args(argv)
    try:
        rep = validate(args.bag)
    except (BagError, OSError) as exc:
        print(f'bag validate: error: {exc}', file=sys.stderr)
        return 2
    if rep.ok:
        if rep.warnings:
            print('bag validate: warning: ' + '; '.join(rep.warnings), file=sys.stderr)
        what = 'OK' if rep.complete else 'OK (recovered prefix of an unfinished bag)'
        print(f'{what}: {rep.message_count} messages, {rep.chunk_count} chunks, CRCs valid')
        return 0
    print('FAILED:')
    for prob in rep.problems:
        print(f'  - {prob}')
    for note in rep.warnings:
        print(f'  (note: {note})')
    more = f' (+{len(rep.problems) - 1} more problems)' if len(rep.problems) > 1 else ''
    first = rep.problems[0] if rep.problems else 'invalid bag'
    print(f'bag validate: error: {first}{more}', file=sys.stderr)
    return 1


def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ('-h', '--help', 'help'):
        print(_usage())
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd == 'info':
        from .info import main as run
    elif cmd == 'export':
        from .export import main as run
    elif cmd == 'play':
        from .play import main as run
    elif cmd == 'plots':
        from .plots import main as run
    elif cmd == 'rerun':
        from .rerun_export import main as run
    elif cmd == 'validate':
        run = _validate
    elif cmd == 'recover':
        from .recovery import main as run
    else:
        print(f"bag: error: unknown command '{cmd}'\n{_usage()}", file=sys.stderr)
        return 2
    try:
        return int(run(rest) or 0)
    except KeyboardInterrupt:
        return 130
    except Exception as exc:  # a last resort: one line, never a traceback
        from .scan import one_line
        print(f'bag {cmd}: error: unexpected {one_line(exc)} (please report this bag)',
              file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
