"""``figure10``: the paper's Figure 10, three runs through the graph and their report.

    ./irs run irs_studies figure10 [--offline | --process-per-node] [--runs-dir runs] [--out DIR]

Runs ``figure10_mrc_with_actuator``, ``figure10_mrc_without_actuator`` and ``figure10_pi``
(lock-step, recorded; each composed in one process, or with ``--process-per-node`` a process per
node: the same bags), reads each bag back and writes ``figure10.png`` and
``figure10_metrics.md`` (:mod:`.report`) into ``--out`` (default ``<runs-dir>/figure10``).
``--offline`` runs the same cores without ROS (:mod:`irs_bringup.offline_twin`); its report goes
to ``<runs-dir>/figure10-offline`` by default, never over the graph's. ``make demo`` runs this
command. Exit codes: docs/cli.md.
"""
import argparse
from pathlib import Path
import sys

from irs_bringup.experiment_cli import PER_NODE_HELP
from irs_common.cli import Interrupted, RunFailed, describe, run_cli

FIGURE10 = {'mrc_with_actuator': 'figure10_mrc_with_actuator',
            'mrc_without_actuator': 'figure10_mrc_without_actuator',
            'pi': 'figure10_pi'}


def figure10(out_dir, offline=False, runs_dir='runs', log=print, deployment='default') -> int:
    """The three runs (or their offline twins) and the report; each run's own plots and
    ``run.rrd`` are made in a background process while the next run goes, and waited for at
    the end.
    """
    from irs_bag.run_series import lateral_run
    from irs_bag.views import finish_views
    from irs_bringup.experiment_cli import run_experiment, start_post_process
    from irs_bringup.offline_twin.from_experiment import offline_run

    from .report import write_report
    runs, views = {}, []
    for key, name in FIGURE10.items():
        if offline:
            runs[key] = offline_run(name)
            continue
        result = run_experiment(name, runs_dir=runs_dir, log=log, deployment=deployment,
                                plots=False)
        if result.interrupted:
            raise Interrupted(result.interrupted)
        if not result.completed:
            raise RunFailed(f'{name} did not complete: {result.message}')
        proc = start_post_process(result, log)
        if proc is not None:
            views.append((proc, result.run_dir))
        runs[key] = lateral_run(result.bag_dir)
    out = Path(out_dir)
    metrics = write_report(
        runs, out, 'Figure 10 ' + ('(offline cores)' if offline else '(ROS graph, lock-step)')
    )
    for proc, run_dir in views:
        finish_views(proc, run_dir, log)
    log(f'[figure10] report: {out / "figure10.png"}, {out / "figure10_metrics.md"}')
    log(
        (out / 'figure10_metrics.md').read_text()
        if (out / 'figure10_metrics.md').exists()
        else str(metrics)
    )
    return 0


def _main(argv) -> int:
    parser = argparse.ArgumentParser(prog='figure10', description=describe(__doc__))
    parser.add_argument('--offline', action='store_true', help='simulate the cores without ROS')
    parser.add_argument('--process-per-node', action='store_true', help=PER_NODE_HELP)
    parser.add_argument('--runs-dir', default='runs', help='where run directories go')
    parser.add_argument('--out', default=None,
                        help='report directory (default: <runs-dir>/figure10, offline '
                        '<runs-dir>/figure10-offline)')
    args = parser.parse_args(argv)
    if args.offline and args.process_per_node:
        parser.error('--process-per-node runs the graph, --offline runs the cores without it: '
                     'pick one')
    default = 'figure10-offline' if args.offline else 'figure10'
    out = args.out or str(Path(args.runs_dir) / default)
    return figure10(out, offline=args.offline, runs_dir=args.runs_dir,
                    deployment='process_per_node' if args.process_per_node else 'default')


def main(argv=None) -> int:
    return run_cli('figure10', _main, argv)


if __name__ == '__main__':
    sys.exit(main())
