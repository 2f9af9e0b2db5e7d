"""sysid actuator through the graph: a short swept sine, a 1 deg step and a full swing on the
servo, recorded, then the CLI on the bags alone (dead time, small-amplitude pole, rate limit,
Figures 6-7).

Tolerances (irs_bringup.sysid.actuator_cli): dead time within 3 ms of the configured 17 ms (the
mean of the radio frame's); the pole fitted at 2 deg within 5 % of the same fit on the configured
actuator core driven by the recorded command, and well above the large-amplitude poles (above
5 Hz: the paper's upper range); the slew rate of the -15 -> +15 deg swing within 10 % of
rate_limit / gear_ratio.
"""
import math

from irs_bringup.run.experiment import load_experiment
from irs_bringup.run.experiment_runner import ExperimentRunner
from irs_bringup.sysid import actuator_cli as cli
from irs_bringup.sysid.sysid_cli import main as sysid_main


def _run(path, runs_dir):
    res = ExperimentRunner(load_experiment(str(path)), runs_dir=runs_dir, progress=False).run()
    assert res.completed, res.message
    return res.bag_dir


def test_actuator_identified_from_bags_recorded_through_the_graph(tmp_path, capsys):
    exps = tmp_path / 'experiments'
    sweep = _run(cli.sweep_experiment(2.0, exps, sweep_time=5.0, f1=12.0), tmp_path / 'runs')
    steps = _run(cli.experiment_copy(
        'sysid_actuator_steps', exps, 'short',
        {'signal.times': [0.2, 0.7, 1.2],
         'signal.values': [math.radians(1.0), math.radians(-15.0), math.radians(15.0)]},
        duration=1.8), tmp_path / 'runs')

    res = cli.identify([cli.load_run(sweep), cli.load_run(steps)])
    rows = {e.name.split(' (')[0]: e for e in cli.estimates(res)}
    for e in rows.values():
        print(f'{e.name:32s} {e.value:.5g} {e.unit} (configured {e.configured:.5g})')
    assert res['params'].delay == 0.017 and res['params'].gear_ratio == 3.0  # from the bag
    pole = rows['pole at 2 deg']
    assert pole.within_tolerance() and pole.value > 5.0
    assert rows['dead time'].within_tolerance()
    assert abs(res['fit'].delay - 0.017) <= cli.DELAY_ABS_TOL
    assert rows['rate limit'].within_tolerance()
    assert rows['loop bandwidth'].within_tolerance()

    prefix = tmp_path / 'img' / 'actuator_'
    assert sysid_main(['actuator', str(sweep), str(steps), '--png', str(prefix)]) == 0
    out = capsys.readouterr().out
    assert 'OUTSIDE' not in out and 'pole at 2 deg' in out
    for name in ('figure6_actuator_bode.png', 'figure7_actuator_steps.png'):
        png = tmp_path / 'img' / f'actuator_{name}'
        assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_bad_bag_is_one_line_exit_2(tmp_path, capsys):
    assert sysid_main(['actuator', str(tmp_path / 'nothing')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('sysid actuator: ') and err.count('\n') == 1
