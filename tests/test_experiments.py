"""Whole experiments through the ROS graph (every node its own process, lock-step, recorded)."""
import os
import signal
import subprocess
import threading

import numpy as np
import pytest

from irs_bringup.bag_reader import BagReader, validate
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_cli import offline_run
from irs_bringup.executables import resolve_executable
from irs_bringup.experiment_runner import ExperimentRunner
from irs_bringup.processes import wait_until
from irs_bringup.regulation_metrics import phase_metrics
from irs_bringup.run_series import series_by_stamp


def test_treadmill_regulation_keeps_the_car_on_the_belt(tmp_path):
    exp = load_experiment('treadmill_regulation')
    result = ExperimentRunner(exp, runs_dir=tmp_path, progress=False).run()
    assert result.completed, result.message
    assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes
    assert validate(result.bag_dir).ok
    data = series_by_stamp(result.bag_dir)
    stamps = np.array(sorted(data['x']))
    t = stamps * 1e-9
    x = np.array([data['x'][s] for s in stamps])
    assert t[-1] == exp.duration and len(stamps) == round(exp.duration * 1000) + 1
    # The graph gives the offline cores' numbers.
    off = offline_run('treadmill_regulation')
    assert np.max(np.abs(x - off['x'][np.round(t * 1000).astype(int)])) < 1e-9
    phases = phase_metrics(t, x, 0.3, [0.5, 4.0])
    for name, ph in zip(('speed-up 0 -> 1.2 m/s', 'slow-down 1.2 -> 0.6 m/s'), phases):
        print(f"{name}: peak position error {ph['peak_error']:.3f} m, "
              f"settled to +-2 cm after {ph['settling_time']:.2f} s")
    up, down = phases
    assert up['peak_error'] < 0.15 and up['settling_time'] < 2.5
    # Slowing down relies on belt friction alone (the drive cannot brake): a larger excursion.
    assert down['peak_error'] < 0.9 and down['settling_time'] < 8.0
    assert np.all(np.abs(x) < 1.2192 - 0.15), 'the car must stay clear of the belt ends'
    faults = [s for s in series_by_stamp(result.bag_dir, {'/treadmill/state': {'mode': 'mode'}})['mode'].values() if s == 3]
    assert not faults
    # Every recorded topic carries every step's stamp t_0 .. t_N (N = duration / dt).
    n_steps = round(exp.duration * 1000)
    expected = set(range(0, (n_steps + 1) * 1_000_000, 1_000_000))
    stamps, counts = {}, {}
    with BagReader(result.bag_dir) as reader:
        assert set(reader.topics) == set(exp.record_topics)
        for m, msg in reader.decoded():
            s = msg.header.stamp
            stamps.setdefault(m.topic, set()).add(s.sec * 1_000_000_000 + s.nanosec)
            counts[m.topic] = counts.get(m.topic, 0) + 1
    for topic in exp.record_topics:
        assert stamps[topic] == expected, f'{topic}: {len(stamps[topic])} of {len(expected)} steps'
        assert counts[topic] == len(expected), f'{topic}: {counts[topic] - len(expected)} repeated'


def test_killing_a_node_ends_the_run_with_a_clear_message(tmp_path):
    exp = load_experiment('figure10_mrc_with_actuator')
    exp.duration = 60.0
    runner = ExperimentRunner(exp, runs_dir=tmp_path, progress=False)
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault('result', runner.run()))
    thread.start()
    assert wait_until(lambda: runner.phase in ('running', 'done'), 120.0)
    assert runner.phase == 'running', 'the run must be under way when the node is killed'
    victim = runner.procs['arm_pose_estimator']
    pids = {name: p.pid for name, p in runner.procs.items()}
    os.kill(victim.pid, signal.SIGKILL)
    thread.join(120)
    assert not thread.is_alive()
    result = box['result']
    assert not result.completed
    assert "node 'arm_pose_estimator' died" in result.message
    for name, pid in pids.items():
        assert not _alive(pid), f'{name} (pid {pid}) left behind'


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_the_car_leaving_the_belt_stops_the_run(tmp_path):
    exp = load_experiment('treadmill_regulation')
    exp.duration = 10.0
    reg = exp.node('irs_treadmill', 'treadmill_regulator')
    reg.params['enabled'] = False          # drive held at 0 V: the belt coasts down ...
    rig = exp.node('irs_vehicle_sim', 'vehicle_sim')
    rig.params.update({'u0': 1.2, 'belt_speed0': 1.2})   # ... under a car driving at 1.2 m/s
    driver = exp.node('irs_bringup', 'driver')
    driver.params.update({'profile.times': [0.0], 'profile.speeds': [1.2]})
    result = ExperimentRunner(exp, runs_dir=tmp_path, progress=False).run()
    assert not result.completed
    assert 'the car left the belt (off_belt:front)' in result.message, result.message
    assert result.sim_time < exp.duration
    assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes


def _children_of_run(run_dir):
    """PIDs of node processes whose command line names files in ``run_dir``."""
    out = subprocess.run(['pgrep', '-f', str(run_dir)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split() if int(p) != os.getpid()]


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGKILL], ids=['SIGTERM', 'SIGKILL'])
def test_stopping_the_runner_leaves_no_process_behind(tmp_path, sig):
    exe = resolve_executable('irs_bringup', 'experiment')
    log = open(tmp_path / 'runner.log', 'w')
    runner = subprocess.Popen([exe, 'run', 'figure10_pi', '--no-plots', '--runs-dir', str(tmp_path)],
                              stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        assert wait_until(lambda: 'graph up' in (tmp_path / 'runner.log').read_text(), 120.0), \
            (tmp_path / 'runner.log').read_text()
        assert len(_children_of_run(tmp_path)) >= 6
        runner.send_signal(sig)
        runner.wait(60)
        assert wait_until(lambda: not _children_of_run(tmp_path), 30.0), \
            f'left behind: {_children_of_run(tmp_path)}'
        if sig == signal.SIGTERM:
            assert 'interrupted' in (tmp_path / 'runner.log').read_text()
    finally:
        for pid in _children_of_run(tmp_path):
            os.kill(pid, signal.SIGKILL)
        if runner.poll() is None:
            runner.kill()
