"""``sysid vehicle`` on a sweep recorded through the graph (paper Fig. 8), and its bad input.

One short lock-step run (the sysid_vehicle_sweep graph under the paper's PI, composed, with the
sweep cut to 6 s of 0.4-5 Hz, 4 s to settle, to keep the suite short) recorded to MCAP; the
identification reads the bag alone. The rig runs its defaults: the arm's noise and
quantisation on, the servo with backlash.

What is held to the stated tolerances (vehicle_fit.TOLERANCES): the vehicle identified from the
achieved steer (gain, w_n and zeta of the zeros and poles, the frequency response). The paper's
way (steer command, actuator a 4.6 Hz lag) is printed but not held: the rig's servo is not a
4.6 Hz lag at these amplitudes (slew limited; docs in vehicle_cli), so it misses the gain.
"""
import copy
import subprocess
import sys

import pytest

from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import ExperimentRunner
from irs_sysid.cli import main


@pytest.fixture(scope='module')
def sweep_bag(tmp_path_factory):
    exp = copy.deepcopy(load_experiment('sysid_vehicle_sweep'))
    exp.node('irs_control', 'reference_generator').params.update(
        {'signal.f0': 0.4, 'signal.f1': 5.0, 'signal.sweep_time': 6.0})
    exp.duration = 10.5
    res = ExperimentRunner(exp, runs_dir=tmp_path_factory.mktemp('runs'), progress=False).run()
    assert res.completed, res.message
    return res.bag_dir


def test_vehicle_identified_from_the_graph_bag(sweep_bag, tmp_path, capsys):
    # the command the README gives: report and Figure 8 from the bag alone (one bag read)
    assert main(['vehicle', str(sweep_bag), '--png', str(tmp_path / 'veh')]) == 0
    out = capsys.readouterr().out
    blocks = {b.splitlines()[0].split(' (')[0]: b for b in out.strip().split('\n\n')}
    assert {'Open loop from the steer command, actuator = 4.60 Hz lag + 17.5 ms',
            'Vehicle from the achieved steer'} <= set(blocks), out
    assert '0.4-5 Hz' in out       # the band read from the bag's reference_generator parameters
    achieved = blocks['Vehicle from the achieved steer']
    for name in ('gain K', 'zeros: w_n', 'zeros: zeta', 'poles: w_n', 'poles: zeta',
                 'max |P/P_configured - 1|'):
        line = [x for x in achieved.splitlines() if x.startswith(name)]
        assert len(line) == 1 and line[0].endswith('  ok'), (name, achieved)
    assert 'OUTSIDE' not in achieved, achieved
    assert (tmp_path / 'veh_bode.png').stat().st_size > 10_000


@pytest.mark.parametrize('argv, words', [
    (['vehicle', '/nonexistent/bag'], 'no such bag'),
    (['vehicle', '{bag}', '--coherence', '1.5'], '--coherence'),
    (['vehicle', '{bag}', '--band', '5', '0.4'], '--band'),
    (['vehicle', '{bag}', '--lag-hz', '-1'], '--lag-hz'),
    (['vehicle', '{bag}'], 'no metadata.yaml and no .mcap'),   # an empty directory: not a bag
    (['cycle', '--plant', 'no_such_car', '--offline'], 'unknown plant'),
])
def test_bad_input_one_line_exit_2(argv, words, tmp_path, capsys):
    (tmp_path / 'bag').mkdir()
    argv = [a.replace('{bag}', str(tmp_path / 'bag')) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], err


def test_cli_module_exits_2_without_traceback(tmp_path):
    p = subprocess.run([sys.executable, '-m', 'irs_sysid.cli', 'vehicle',
                        str(tmp_path / 'missing')], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert 'Traceback' not in p.stderr


def test_paper_method_holds_with_the_papers_servo():
    """With the servo configured as the paper's model (a 4.6 Hz lag, a 6.98 rad/s slew at the
    wheel, no friction, minimum drive or linkage, the 17 ms delay constant), the paper's way --
    steer command, actuator a 4.6 Hz lag -- recovers Eq. 6's gain and response within the
    tolerances, with the arm's noise and quantisation, the backlash and the delay on (the offline
    loop of the same cores, the full 12 s sweep under the PI). The single zeros and poles are not
    held: Eq. 6's set nearly cancels, and the PI's sweep fixes them no better than the response
    (vehicle_fit).
    """
    from irs_sysid import cycle, vehicle_cli

    exp = copy.deepcopy(load_experiment('sysid_vehicle_sweep'))
    exp.node('irs_vehicle_sim', 'vehicle_sim').params.update({
        'actuator_front.lag_hz': 4.6, 'actuator_front.rate_limit': 6.981,
        'actuator_front.gear_ratio': 1.0, 'actuator_front.enable_friction': False,
        'actuator_front.enable_linkage_geometry': False, 'actuator_front.min_drive': 0.0,
        'actuator_front.enable_radio_frame': False})
    run = cycle._run_experiment(exp, None, offline=True)
    assert run['params']['vehicle_sim']['arm.enable_noise'] is True
    (_title, paper), _ = vehicle_cli.reports(vehicle_cli.identify(run))
    held = [e for e in paper if e.name.startswith(('gain K', 'max |P/P_configured'))]
    assert len(held) == 2
    bad = [(e.name, e.value, e.configured) for e in held if not e.within_tolerance()]
    assert not bad, bad
