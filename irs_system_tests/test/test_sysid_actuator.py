"""sysid actuator through the graph: a short swept sine and two steps on the servo, recorded,
then the CLI on the bags alone (dead time, pole, rate limit, Figures 6-7).

The sweep runs the servo with its non-linear elements off (no slew limit, dead zone, linkage
geometry or backlash): a first-order lag of ``lag_hz`` behind the transport delay, so the fit
has a known answer. The rig steps that lag exactly for a command held over each 1 ms step: the
sampled response is the continuous one times the hold's ``exp(-j w dt/2) sinc(w dt/2)``, so the
fit must find the configured pole and gain within the hold's droop, ``(w dt)^2/24 = 2.4e-4`` at
the 12 Hz top (0.5 % allowed), and the dead time within 0.1 ms of the configured one plus half
a step for the hold less the step by which ``steering/state`` reports its command late (the
command stamped t_k acted over the step before t_k): ``delay - dt/2``. The steps run
the servo as configured: the slew rate of the 10 deg step within 10 % of rate_limit /
gear_ratio, the dead time within 3 ms of 17 ms (actuator_cli's tolerances).
"""
import math

import yaml

from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import ExperimentRunner
from irs_sysid import actuator_cli as cli
from irs_sysid.cli import main as sysid_main
from irs_vehicle_sim.actuator import ActuatorParams

DT = 1e-3
#: the servo's non-linear elements, switched off (those this build has)
LINEAR = {f'actuator_front.enable_{x}': False
          for x in ('rate_limit', 'friction', 'linkage_geometry', 'backlash', 'radio_frame',
                    'linkage_compensation')
          if f'enable_{x}' in ActuatorParams.__dataclass_fields__}


def _linear(path):
    doc = yaml.safe_load(path.read_text())
    doc['nodes']['vehicle_sim']['params'].update(LINEAR)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _run(path, runs_dir):
    res = ExperimentRunner(load_experiment(str(path)), runs_dir=runs_dir, progress=False).run()
    assert res.completed, res.message
    return res.bag_dir


def test_actuator_identified_from_bags_recorded_through_the_graph(tmp_path, capsys):
    exps = tmp_path / 'experiments'
    sweep = _run(_linear(cli.sweep_experiment(2.0, exps, sweep_time=5.0, f1=15.0)),
                 tmp_path / 'runs')
    steps = _run(cli.experiment_copy(
        'sysid_actuator_steps', exps, 'short',
        {'signal.times': [0.2, 0.7], 'signal.values': [math.radians(1.0), math.radians(10.0)]},
        duration=1.3), tmp_path / 'runs')

    res = cli.identify([cli.load_run(sweep), cli.load_run(steps)])
    rows = {e.name.split(' (')[0]: e for e in cli.estimates(res)}
    for e in rows.values():
        print(f'{e.name:32s} {e.value:.5g} {e.unit} (configured {e.configured:.5g})')
    p = res['params']
    assert p.delay == 0.017 and p.gear_ratio == 3.0 and not p.enable_rate_limit  # from the bag
    fit = res['fit']
    assert abs(fit.poles_hz[0] / p.lag_hz - 1.0) < 0.005, fit.poles_hz
    assert abs(fit.gains[0] - 1.0) < 0.005, fit.gains
    assert abs(fit.delay - (p.delay - DT / 2)) < 1e-4, fit.delay
    assert rows['pole at 2 deg'].within_tolerance()
    assert rows['dead time'].within_tolerance()
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
    assert err.startswith('sysid: error: ') and err.count('\n') == 1
