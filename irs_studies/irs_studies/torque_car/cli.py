"""``torque_car``: metrics and figures of the torque car's experiments.

    ./irs run irs_studies torque_car runs/torque_braking_abs_low-<time> ... [--out DIR]
    ./irs run irs_studies torque_car --run [--out DIR]     # run the experiments first
    ./irs run irs_studies torque_car --run --process-per-node   # ... a process per node

Each argument is a run directory (``<run>/bag``), a bag directory or an ``.mcap`` file of one of
the experiments in :data:`EXPERIMENTS`; the experiment is told by the bag's metadata (else by
the run directory's name). It prints the metrics tables (:mod:`.metrics`, Markdown), writes them
to ``--metrics`` (JSON, default ``<out>/metrics.json``) and the figures (:mod:`.plots`) to
``--out`` (default ``runs/torque_car``): ``torque_braking_<surface>.png`` (locked wheels, the
fixed-target and the peak-seeking ABS, per surface: high, low, split and a mid-stop step),
``torque_split_yaw.png`` and ``torque_step_steer.png``. ``--run`` runs the experiments through
the graph (lock-step, one after the other, bags under ``--runs-dir``; composed in one process as
their files place them, or with ``--process-per-node`` a process per node: the same bags) and
then does the same with their bags. A bad file or argument is one line on stderr and exit code
2; an experiment that did not complete is one line, the others go on, exit code 1 (docs/cli.md).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from irs_common.cli import InputError, RunFailed, describe, run_cli

from .metrics import braking_metrics, run_kind, step_steer_metrics
from .report import braking_table, step_steer_table
from .series import load_run

__all__ = ['EXPERIMENTS', 'main', 'analyse']

EXPERIMENTS = tuple(
    [f'torque_braking_{mode}_{surface}' for surface in ('high', 'low', 'split', 'step')
     for mode in ('locked', 'abs', 'abspeak')]
    + ['torque_braking_chassis_split', 'torque_step_steer_open', 'torque_step_steer_chassis'])
PROG = 'torque_car'


def _json_safe(x):
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def analyse(paths, out_dir=None, warn=print) -> dict:
    """Metrics of the runs at ``paths`` and, with ``out_dir``, their figures.

    Returns ``{'braking': {name: metrics}, 'step_steer': {name: metrics}, 'figures': [paths],
    'bags': {name: bag path}}``. ``ValueError`` (one line) for a bad bag.
    """
    braking, steer, bags = {}, {}, {}
    for path in paths:
        try:
            run = load_run(path)
            if run.warnings:
                warn(f'{PROG}: warning: ' + '; '.join(run.warnings))
            kind = run_kind(run.name)
            if kind['kind'] == 'braking':
                braking[run.name] = (run, braking_metrics(run), kind)
            elif kind['kind'] == 'step_steer':
                steer[run.name] = (run, step_steer_metrics(run), kind)
        except ValueError as exc:   # the run at `path` is not what the study reads
            raise InputError(str(exc)) from None
        if kind['kind'] not in ('braking', 'step_steer'):
            warn(f'{PROG}: warning: {path}: experiment {run.name!r} is not a torque-car '
                 'experiment (torque_braking_<mode>_<surface>, torque_step_steer_<mode>): '
                 'skipped')
            continue
        bags[run.name] = str(run.path)
    figures = _figures(braking, steer, Path(out_dir)) if out_dir is not None else []
    return {'braking': {k: v[1] for k, v in braking.items()},
            'step_steer': {k: v[1] for k, v in steer.items()},
            'figures': [str(f) for f in figures], 'bags': bags}


def _figures(braking: dict, steer: dict, out: Path) -> list:
    from .plots import plot_braking, plot_split_yaw, plot_step_steer
    figures = []
    for surface in sorted({k['surface'] for _, _, k in braking.values()}):
        runs = {k['mode']: (r, m) for r, m, k in braking.values()
                if k['surface'] == surface and k['mode'] != 'chassis'}
        if runs:
            target = next(iter(runs.values()))[0].param('abs.slip_target', -0.10)
            figures.append(plot_braking(surface, runs, out / f'torque_braking_{surface}.png',
                                        slip_target=float(target)))
    split = {k['mode']: (r, m) for r, m, k in braking.values()
             if k['surface'] == 'split' and r.has('odom')}
    if split:
        figures.append(plot_split_yaw(split, out / 'torque_split_yaw.png'))
    if steer:
        runs = {k['mode']: (r, m) for r, m, k in steer.values()}
        figures.append(plot_step_steer(runs, out / 'torque_step_steer.png'))
    return figures


def run_experiments(names, runs_dir: Path, warn=print, deployment='default') -> list:
    """Run the experiments ``names`` through the graph, placed in processes as ``deployment``
    says (:meth:`irs_bringup.experiment.Experiment.deployed`); the bags of those that completed.
    """
    from irs_sysid.common import run_experiment
    bags = []
    for i, name in enumerate(names, 1):
        print(f'{PROG}: running {name} ({i}/{len(names)})', flush=True)
        try:
            bags.append(run_experiment(name, runs_dir, deployment))
        except (RunFailed, InputError, OSError) as exc:
            warn(f'{PROG}: error: {exc}')
    return bags


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=describe(__doc__))
    p.add_argument('paths', nargs='*', help='run directories, bag directories or .mcap files')
    p.add_argument('--run', action='store_true',
                   help='run the experiments through the graph first (see --experiments)')
    p.add_argument('--experiments', nargs='+', default=list(EXPERIMENTS), metavar='NAME',
                   help=f'experiments for --run (default: all {len(EXPERIMENTS)})')
    p.add_argument('--process-per-node', action='store_true',
                   help='with --run: every node and the recorder in a process of its own '
                   '(the same bags, several times slower)')
    p.add_argument('--runs-dir', type=Path, default=Path('runs'),
                   help='where --run puts its runs (default runs/)')
    p.add_argument('--out', type=Path, default=Path('runs/torque_car'),
                   help='directory for the PNG figures (default runs/torque_car)')
    p.add_argument('--metrics', type=Path, default=None,
                   help='metrics JSON (default <out>/metrics.json)')
    return p


def _main(argv) -> int:
    args = build_parser().parse_args(argv)
    args.metrics = args.metrics or args.out / 'metrics.json'

    def warn(line):
        print(line, file=sys.stderr, flush=True)

    if args.process_per_node and not args.run:
        raise InputError('--process-per-node places the nodes of --run: add --run')
    paths, failed = list(args.paths), False
    if args.run:
        bags = run_experiments(args.experiments, args.runs_dir, warn,
                               'process_per_node' if args.process_per_node else 'default')
        failed = len(bags) < len(args.experiments)
        paths += bags
    if not paths:
        raise InputError('no runs given (paths or --run)')
    res = analyse(paths, args.out, warn)
    if not res['braking'] and not res['step_steer']:
        raise InputError('none of the runs is a torque-car experiment')
    args.metrics.parent.mkdir(parents=True, exist_ok=True)
    args.metrics.write_text(json.dumps(_json_safe(res), indent=1) + '\n')
    if res['braking']:
        print(braking_table(res['braking']))
    if res['step_steer']:
        print(step_steer_table(res['step_steer']))
    for f in res['figures']:
        print(f'{PROG}: wrote {f}')
    print(f'{PROG}: wrote {args.metrics}')
    return 1 if failed else 0


def main(argv=None) -> int:
    return run_cli(PROG, _main, argv)


if __name__ == '__main__':
    sys.exit(main())
