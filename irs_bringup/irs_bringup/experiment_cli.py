"""``experiment``: run IRS experiments (``ros2 run irs_bringup experiment ...``, or ``./irs run``).

commands:
  experiment list                        installed experiment files
  experiment run <name|file.yaml>        run one through the ROS graph, record, plot
  experiment run <name> --composed       the same with every node in one process
  experiment run <name> --offline        the same cores without ROS (closed_loop.py)
  experiment recover                     rig/recover: the running rig back from any fault
"""
import argparse
import sys

from .experiment import ExperimentError, experiments_dir, load_experiment

COMPOSED_HELP = ('every node and the recorder in one process (one executor, messages handed over '
                 'in-process; the same lock-step bag, several times faster)')


def _post_process(result, log=print):
    """Validate the bag, write plots and the .rrd; returns the list of written artefacts."""
    written = []
    if result.bag_dir is None or not result.bag_dir.exists():
        return written
    from irs_bag import BagError, validate
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
        from irs_bag.plots import make_plots
        written += make_plots(result.bag_dir, result.run_dir / 'plots')
    except Exception as exc:  # plots must never hide the run's result
        log(f'[experiment] plots failed: {exc}')
    try:
        from irs_bag.rerun_export import export_rrd
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
    sub.add_parser('recover', help='call rig/recover (docs/safety.md) and wait until the rig runs')
    p_run.add_argument('--rt-priority', type=int, default=0, metavar='N',
                       help='run every node process with SCHED_FIFO priority N (1-99; needs root '
                       'or CAP_SYS_NICE; 0 = normal scheduling)')
    args = parser.parse_args(argv)
    if getattr(args, 'offline', False) and getattr(args, 'composed', False):
        parser.error('--composed runs the graph, --offline runs the cores without it: pick one')
    try:
        if args.cmd == 'list':
            for path in sorted(experiments_dir().glob('*.yaml')):
                exp = load_experiment(str(path))
                print(f'{path.stem:36s} {exp.clock:9s} {exp.duration:7.1f} s  {exp.description}')
            return 0
        if args.cmd == 'recover':
            from irs_vehicle_sim.recover_call import recover
            return 0 if recover() else 1
        if args.cmd == 'run':
            if args.offline:
                from .offline_twin.from_experiment import offline_run
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
    except ExperimentError as exc:
        print(f'experiment: {exc}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
