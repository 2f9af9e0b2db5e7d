"""``experiment``: run IRS experiments (``ros2 run irs_bringup experiment ...``, or ``./irs run``).

commands:
  experiment list                        installed experiment files
  experiment run <name|file.yaml>        run one through the ROS graph, record, plot
  experiment run <name> --composed       the same with every node in one process
  experiment run <name> --offline        the same cores without ROS (closed_loop.py)
  experiment figure10 [--offline]        the three Figure 10 runs and their report
  experiment demo                        = figure10 through the graph (the README's demo)
"""
import argparse
from pathlib import Path
import sys

from .experiment import ExperimentError, experiments_dir, load_experiment

COMPOSED_HELP = ('every node and the recorder in one process (one executor, messages handed over '
                 'in-process; the same lock-step bag, several times faster)')
FIGURE10 = {'mrc_with_actuator': 'figure10_mrc_with_actuator',
            'mrc_without_actuator': 'figure10_mrc_without_actuator',
            'pi': 'figure10_pi'}


def _post_process(result, log=print):
    """Validate the bag, write plots and the .rrd; returns the list of written artefacts."""
    written = []
    if result.bag_dir is None or not result.bag_dir.exists():
        return written
    from ..bag.bag_reader import BagError, validate
    try:
        report = validate(result.bag_dir)
        log(
            f'[experiment] bag: {result.bag_dir} '
            f'({"valid" if report.ok else "INVALID: " + "; ".join(report.problems)})'
        )
    except BagError as exc:
        log(f'[experiment] bag unreadable: {exc}')
        return written
    try:
        from ..bag.bag_plots import make_plots
        written += make_plots(result.bag_dir, result.run_dir / 'plots')
    except Exception as exc:  # plots must never hide the run's result
        log(f'[experiment] plots failed: {exc}')
    try:
        from ..bag.rerun_export import export_rrd
        rrd = result.run_dir / 'run.rrd'
        export_rrd(result.bag_dir, rrd)
        written.append(rrd)
    except Exception as exc:
        log(f'[experiment] rerun export failed: {exc}')
    for path in written:
        log(f'[experiment] wrote {path}')
    return written


def run_experiment(name, runs_dir='runs', plots=True, log=print, rt_priority=0, composed=False):
    """Run one experiment through the graph; returns the RunResult. ``composed``: every node
    and the recorder in one process (:meth:`~.experiment.Experiment.composed`).
    """
    from .experiment_runner import ExperimentRunner
    exp = load_experiment(name)
    if composed:
        exp = exp.composed()
    result = ExperimentRunner(exp, runs_dir=runs_dir, log=log, rt_priority=rt_priority).run()
    log(f'[experiment] {exp.name}: {result.message}; simulated {result.sim_time:.3f} s in '
        f'{result.wall_time:.1f} s wall; run directory {result.run_dir}')
    if plots:
        _post_process(result, log)
    return result


def offline_run(name):
    """The experiment's closed loop without ROS: arrays as ClosedLoop.run returns them (the
    torque car's, with a chassis_controller: as ChassisLoop.run returns them).
    """
    from .offline import loop_config_from_experiment
    from ..paper.closed_loop import ClosedLoop
    exp = load_experiment(name)
    if exp.node('irs_control', 'chassis_controller') is not None:   # the torque car (issue 13)
        from ..paper.chassis_loop import ChassisLoop, chassis_loop_config
        try:
            return ChassisLoop(chassis_loop_config(exp)).run(exp.duration)
        except (ValueError, TypeError, KeyError) as exc:
            raise ExperimentError(f'{exp.path}: nodes: the offline torque-car loop refuses a '
                                  f'parameter: {" ".join(str(exc).split())}') from None
    try:
        loop = ClosedLoop(loop_config_from_experiment(exp))
    except (ValueError, TypeError, KeyError) as exc:
        # what the ROS-free tables could not check (e.g. the lateral controller's parameters)
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise ExperimentError(f'{exp.path}: nodes: the offline closed loop refuses a parameter: '
                              f'{" ".join(str(msg).split())}') from None
    return loop.run(exp.duration)


def figure10(out_dir, offline=False, runs_dir='runs', log=print, composed=False) -> int:
    from ..paper.figure10 import write_report
    from ..paper.run_series import lateral_run
    runs = {}
    for key, name in FIGURE10.items():
        if offline:
            runs[key] = offline_run(name)
            continue
        result = run_experiment(name, runs_dir=runs_dir, log=log, composed=composed)
        if not result.completed:
            log(f'[figure10] {name} did not complete: {result.message}')
            return 1
        runs[key] = lateral_run(result.bag_dir)
    out = Path(out_dir)
    metrics = write_report(
        runs, out, 'Figure 10 ' + ('(offline cores)' if offline else '(ROS graph, lock-step)')
    )
    log(f'[figure10] report: {out / "figure10.png"}, {out / "figure10_metrics.md"}')
    log(
        (out / 'figure10_metrics.md').read_text()
        if (out / 'figure10_metrics.md').exists()
        else str(metrics)
    )
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='experiment', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest='cmd', required=True)
    sub.add_parser('list', help='installed experiment files')
    p_run = sub.add_parser('run', help='run an experiment')
    p_run.add_argument('experiment', help='name of an installed experiment or a YAML file')
    p_run.add_argument(
        '--runs-dir', default='runs', help='where run directories go (default: runs)'
    )
    p_run.add_argument('--no-plots', action='store_true', help='skip plots and the .rrd')
    p_run.add_argument('--offline', action='store_true', help='simulate the cores without ROS')
    p_run.add_argument('--composed', action='store_true', help=COMPOSED_HELP)
    p_run.add_argument('--rt-priority', type=int, default=0, metavar='N',
                       help='run every node process with SCHED_FIFO priority N (1-99; needs root '
                       'or CAP_SYS_NICE; 0 = normal scheduling)')
    for cmd in ('figure10', 'demo'):
        p = sub.add_parser(cmd, help='the three Figure 10 runs and their report')
        p.add_argument('--offline', action='store_true', help='simulate the cores without ROS')
        p.add_argument('--composed', action='store_true', help=COMPOSED_HELP)
        p.add_argument('--runs-dir', default='runs')
        p.add_argument(
            '--out', default=None, help='report directory (default: <runs-dir>/figure10)'
        )
    args = parser.parse_args(argv)
    if getattr(args, 'offline', False) and getattr(args, 'composed', False):
        parser.error('--composed runs the graph, --offline runs the cores without it: pick one')
    try:
        if args.cmd == 'list':
            for path in sorted(experiments_dir().glob('*.yaml')):
                exp = load_experiment(str(path))
                print(f'{path.stem:36s} {exp.clock:9s} {exp.duration:7.1f} s  {exp.description}')
            return 0
        if args.cmd == 'run':
            if args.offline:
                res = offline_run(args.experiment)
                last = (f'final y_s = {res["y_s"][-1]:.6f} m' if 'y_s' in res else
                        f'final x_belt = {res["x_belt"][-1]:.6f} m, u = {res["u"][-1]:.6f} m/s')
                print(f'offline: {len(res["time"])} samples, {last}')
                return 0
            if not 0 <= args.rt_priority <= 99:
                parser.error('--rt-priority must be 0..99')
            result = run_experiment(args.experiment, args.runs_dir, plots=not args.no_plots,
                                    rt_priority=args.rt_priority, composed=args.composed)
            return 0 if result.completed else 1
        out = args.out or str(Path(args.runs_dir) / 'figure10')
        return figure10(out, offline=args.offline, runs_dir=args.runs_dir, composed=args.composed)
    except ExperimentError as exc:
        print(f'experiment: {exc}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
