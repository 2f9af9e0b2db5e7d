"""``experiment``: run IRS experiments (``ros2 run irs_bringup experiment ...``, or ``./irs run``).

commands:
  experiment list                        installed experiment files (read only: no ROS started)
  experiment run <name|file.yaml>        run one through the ROS graph, record, plot
  experiment run <name> --process-per-node   the same with every node in a process of its own
  experiment run <name> --wait-plots     the same, the plots made before it returns
  experiment run <name> --composed       the same with every node in one process
  experiment run <name> --offline        the same cores without ROS: traces, metrics, plots
  experiment run <name> --duration 3     any of these for 3 s instead of the file's duration
  experiment run <name> --view [URL]     stream the run to a rerun viewer while it runs
  experiment run <name> --view ws://127.0.0.1:8765   ... or serve it to the Foxglove app
  experiment recover                     rig/recover: the running rig back from any fault

A lock-step experiment whose file places no node (no process:) runs composed, every node and
the recorder in one process (the same bag as a process per node, several times faster); other
files run as they place their nodes. Every run writes into its own folder under --runs-dir
(default runs/): <name>-<time>/ for the graph, <name>-offline-<time>/ offline. A graph run's
plots and run.rrd are made after it in a background process (the runner says where;
<run>/views.done appears when they are written); --wait-plots makes them before it returns.
Exit codes: docs/cli.md.
"""
import argparse
import os
from pathlib import Path
import sys

from irs_common.cli import EXIT_FAILED, InputError, plain_text, run_cli

from .experiment import experiments_dir, load_experiment

#: rerun's default gRPC URL (irs_bag.live_view_params.DEFAULT_URL; not imported: the CLI
#: parses its arguments before any ROS or rerun import).
DEFAULT_VIEW_URL = 'rerun+http://127.0.0.1:9876/proxy'

COMPOSED_HELP = ('every node and the recorder in one process (one executor, messages handed over '
                 'in-process), whatever the file places; lock-step files that place no node run '
                 'so by default')
PER_NODE_HELP = ('every node and the recorder in a process of its own, whatever the file places '
                 '(the same lock-step bag as composed, several times slower)')


def loop_traces(run_dir) -> list:
    """The ``IRS_TRACE`` files the run's node processes wrote, as their logs name them (none
    without ``IRS_TRACE`` in the environment, which the processes inherit).
    """
    found = []
    if not os.environ.get('IRS_TRACE', '').strip():
        return found
    for log_file in sorted(Path(run_dir, 'logs').glob('*.log')):
        for line in log_file.read_text(errors='replace').splitlines():
            if line.startswith('[irs] loop trace: '):
                found.append(line.split(': ', 1)[1])
    return found


def _validated(result, log=print) -> bool:
    """Validate the run's bag and say so in one line; whether it is there and readable."""
    if result.bag_dir is None or not result.bag_dir.exists():
        return False
    from irs_bag import BagError, validate
    try:
        report = validate(result.bag_dir)
    except BagError as exc:
        log(f'[experiment] bag unreadable: {exc}')
        return False
    log(f'[experiment] bag: {result.bag_dir} '
        f'({"valid" if report.ok else "INVALID: " + "; ".join(report.problems)})')
    return True


def start_post_process(result, log=print):
    """Validate the run's bag (one line), then start its plots and ``run.rrd`` in a background
    process (:func:`irs_bag.views.start_views`); that process, for
    :func:`irs_bag.views.finish_views`, or None without a readable bag.
    """
    if not _validated(result, log):
        return None
    from irs_bag.views import start_views
    return start_views(result.bag_dir, result.run_dir)


def _post_process(result, log=print, wait=True):
    """Validate the bag, then write the plots and the .rrd (``wait``), or start them in the
    background (:func:`start_post_process`) and say where they will appear; returns the list
    of written artefacts (empty in the background).
    """
    if not wait:
        proc = start_post_process(result, log)
        if proc is not None:
            from irs_bag.views import DONE_FILE, LOG_FILE
            run = result.run_dir
            log(f'[experiment] plots and run.rrd: being made in the background (pid {proc.pid}), '
                f'into {run / "plots"}/ and {run / "run.rrd"}')
            log(f'[experiment] they are done when {run / DONE_FILE} exists (log '
                f'{run / LOG_FILE}; --wait-plots waits for them)')
        return []
    if not _validated(result, log):
        return []
    from irs_bag.views import make_views       # plots and run.rrd from one read of the bag
    written = make_views(result.bag_dir, result.run_dir, log)
    for path in written:
        log(f'[experiment] wrote {path}')
    return written


def run_experiment(name, runs_dir='runs', plots=True, log=print, rt_priority=0,
                   deployment='default', duration=None, view=None, view_topics=None,
                   wait_plots=True):
    """Run one experiment through the graph; returns the RunResult. ``deployment``: how the
    nodes sit in processes (:meth:`~.experiment.Experiment.deployed`: ``default``,
    ``composed``, ``process_per_node``); ``duration`` [s]: instead of the file's; ``view``: a
    rerun viewer URL, an ``.rrd`` path or a Foxglove ``ws://host:port`` for the ``live_view``
    node (docs/plots.md), None = no live view; ``view_topics``: its ``topics`` (None = all);
    ``wait_plots``: make the plots and ``run.rrd`` before returning, else in a background
    process (``<run>/views.done`` appears when they are written).
    """
    from .experiment_runner import ExperimentRunner
    exp = load_experiment(name)
    if duration is not None:
        exp = exp.with_duration(duration)
    exp = exp.deployed(deployment)
    result = ExperimentRunner(exp, runs_dir=runs_dir, log=log, rt_priority=rt_priority,
                              view=view, view_topics=view_topics).run()
    ran = (f'simulated {result.sim_time:.3f} s in {result.wall_time:.1f} s wall'
           if exp.clock == 'lockstep' else
           f'ran {result.sim_time:.1f} s in real time ({result.wall_time:.1f} s wall with '
           'start-up)')
    log(f'[experiment] {exp.name}: {result.message}; {ran}; run directory {result.run_dir}')
    for path in loop_traces(result.run_dir):
        log(f'[experiment] loop trace: {path} (python -m irs_common.loop_trace {path})')
    if plots and result.interrupted is None:
        _post_process(result, log, wait=wait_plots)
    return result


def run_offline(name, runs_dir='runs', plots=True, duration=None, log=print):
    """The experiment's cores without ROS, into ``<runs_dir>/<name>-offline-<time>/``
    (:mod:`.offline_twin.run_output`); the run folder.
    """
    from .experiment import make_run_dir, new_run_dir
    from .offline_twin.from_experiment import offline_run, refuse_as_the_node_does
    from .offline_twin.run_output import write_run
    exp = load_experiment(name)
    if duration is not None:
        exp = exp.with_duration(duration)
    try:
        refuse_as_the_node_does(exp, log)
    except ValueError as exc:
        raise InputError(f'{exp.path or exp.name}: {exc}') from None
    res = offline_run(exp)
    run_dir = make_run_dir(new_run_dir(runs_dir, f'{exp.name}-offline'))
    write_run(res, exp, run_dir, plots=plots, log=log)
    last = (f'final y_s = {res["y_s"][-1]:.6f} m' if 'y_s' in res else
            f'final x_belt = {res["x_belt"][-1]:.6f} m, u = {res["u"][-1]:.6f} m/s')
    log(f'[experiment] {exp.name} offline: {len(res["time"])} samples, {last}; '
        f'run directory {run_dir}')
    return run_dir


def list_experiments(out=print) -> int:
    """One line per installed experiment file: name, clock, duration, description.

    Reads the YAML files only (no schema, no parameter tables, no ROS): ``experiment run``
    checks a file fully.
    """
    import yaml

    from irs_common import yaml_io
    paths = sorted(experiments_dir().glob('*.yaml'))
    width = max((len(p.stem) for p in paths), default=0)
    for path in paths:
        try:
            doc = yaml_io.safe_load(path.read_text())
            doc = doc if isinstance(doc, dict) else {}
            duration = float(doc.get('duration'))
            out(f'{path.stem:{width}s} {str(doc.get("clock", "lockstep")):9s} {duration:7.1f} s  '
                f'{doc.get("description", "")}')
        except (OSError, yaml.YAMLError, TypeError, ValueError) as exc:
            out(f'{path.stem:{width}s} (unreadable: {" ".join(str(exc).split())[:80]})')
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='experiment', description=plain_text(__doc__),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest='cmd', required=True)
    sub.add_parser('list', help='installed experiment files')
    p_run = sub.add_parser('run', help='run an experiment')
    p_run.add_argument('experiment', help='name of an installed experiment or a YAML file')
    p_run.add_argument(
        '--runs-dir', default='runs', help='where run directories go (default: runs)'
    )
    p_run.add_argument('--duration', type=float, metavar='SECONDS',
                       help="run this long instead of the file's duration (simulated time in "
                       'lock-step, wall time in real time)')
    p_run.add_argument('--no-plots', action='store_true', help='skip plots and the .rrd')
    p_run.add_argument('--wait-plots', action='store_true', help='make the plots and the .rrd '
                       'before returning (default: in the background after the run, done when '
                       '<run>/views.done exists)')
    p_run.add_argument('--offline', action='store_true', help='simulate the cores without ROS')
    placing = p_run.add_mutually_exclusive_group()
    placing.add_argument('--composed', action='store_const', dest='deployment',
                         const='composed', default='default', help=COMPOSED_HELP)
    placing.add_argument('--process-per-node', action='store_const', dest='deployment',
                         const='process_per_node', help=PER_NODE_HELP)
    p_run.add_argument('--rt-priority', type=int, default=0, metavar='N',
                       help='run every node process with SCHED_FIFO priority N (1-99; needs root '
                       'or CAP_SYS_NICE; 0 = normal scheduling)')
    p_run.add_argument('--view', nargs='?', const=DEFAULT_VIEW_URL, metavar='URL',
                       help='stream the run to a rerun viewer while it runs (default URL '
                       f'{DEFAULT_VIEW_URL}: a viewer started with `rerun`); a path ending in '
                       '.rrd writes that file instead; ws://host:port (e.g. '
                       'ws://127.0.0.1:8765) serves it to the Foxglove app instead')
    p_run.add_argument('--view-topics', metavar='T1,T2', type=lambda t: [
        x.strip() for x in t.split(',') if x.strip()], help='the topics the live view takes '
        '(default: all of its ten); ground_truth/odom,ground_truth/sensor_point,steering/state '
        'keeps a composed loop in-process (docs/plots.md)')
    sub.add_parser('recover', help='call rig/recover (docs/safety.md) and wait until the rig runs')
    return parser


def _main(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cmd == 'list':
        return list_experiments()
    if args.cmd == 'recover':
        from irs_vehicle_sim.recover_call import recover
        recover()
        return 0
    if args.offline and args.deployment != 'default':
        parser.error(f'--{args.deployment.replace("_", "-")} runs the graph, --offline runs the '
                     'cores without it: pick one')
    if args.offline and args.view is not None:
        parser.error('--view streams a running graph; --offline runs no graph')
    if args.view is not None and not (args.view.endswith('.rrd') or args.view.startswith(
            ('rerun://', 'rerun+http://', 'rerun+https://', 'ws://'))):
        parser.error(f'--view {args.view}: neither a rerun URL (rerun+http://host:port/proxy), '
                     'an .rrd file nor a Foxglove ws://host:port')
    if args.view is not None and args.view.startswith('ws://'):
        from irs_bag.foxglove_bridge import parse_ws_url
        try:
            parse_ws_url(args.view)
        except ValueError as exc:
            parser.error(f'--view: {exc}')
    if args.view is not None and args.view.startswith('rerun'):
        from irs_bag.live_view import viewer_problem
        problem = viewer_problem(args.view)
        if problem:
            parser.error(f"--view: {problem}; start one first ('./irs exec rerun' on this "
                         'machine), or write the view to a file: --view live.rrd')
    if args.view_topics is not None and args.view is None:
        parser.error('--view-topics needs --view')
    if not 0 <= args.rt_priority <= 99:
        parser.error('--rt-priority must be 0..99')
    if args.offline:
        run_offline(args.experiment, args.runs_dir, plots=not args.no_plots,
                    duration=args.duration)
        return 0
    result = run_experiment(args.experiment, args.runs_dir, plots=not args.no_plots,
                            rt_priority=args.rt_priority, deployment=args.deployment,
                            duration=args.duration, view=args.view,
                            view_topics=args.view_topics, wait_plots=args.wait_plots)
    if result.interrupted is not None:
        return 128 + result.interrupted if result.interrupted else EXIT_FAILED
    return 0 if result.completed else EXIT_FAILED


def main(argv=None) -> int:
    return run_cli('experiment', _main, argv)


__all__ = ['main', 'run_experiment', 'run_offline', 'InputError']

if __name__ == '__main__':
    sys.exit(main())
