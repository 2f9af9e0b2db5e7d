"""Whole experiments through the ROS graph (lock-step, recorded): every node its own process, or
composed in one (``Experiment.composed``) where the test is about the result, not the processes.
"""
import json
from pathlib import Path
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest
import yaml

from irs_bag import BagReader, validate
from irs_bringup.experiment import ExperimentError, NodeEntry, load_experiment
from irs_bringup.experiment_cli import main as experiment_main
from irs_bringup.offline_twin.from_experiment import offline_run
from irs_bringup.experiment_schema import ExperimentModel, NodeModel
from irs_bringup.executables import resolve_executable
from irs_bringup.experiment_runner import ExperimentRunner
from irs_bringup.processes import wait_until
from irs_studies.regulation_metrics import phase_metrics
from irs_bag.run_series import series_by_stamp


def test_treadmill_regulation_keeps_the_car_on_the_belt(tmp_path):
    exp = load_experiment('treadmill_regulation').composed()
    result = ExperimentRunner(exp, runs_dir=tmp_path, progress=False).run()
    assert result.completed, result.message
    assert json.loads((result.run_dir / 'result.json').read_text())['completed'] is True
    assert result.exit_codes == {'graph': 0}, result.exit_codes
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
    faults = [
        s
        for s in series_by_stamp(result.bag_dir, {'/treadmill/state': {'mode': 'mode'}})[
            'mode'
        ].values()
        if s == 3
    ]
    assert not faults
    # Every recorded topic carries every step's stamp t_0 .. t_N (N = duration / dt).
    n_steps = round(exp.duration * 1000)
    expected = set(range(0, (n_steps + 1) * 1_000_000, 1_000_000))
    stamps, counts = {}, {}
    with BagReader(result.bag_dir) as reader:
        assert set(reader.topics) == set(exp.record_topics)
        for m, msg in reader.decoded():
            s = msg.clock if m.topic == '/clock' else msg.header.stamp
            stamps.setdefault(m.topic, set()).add(s.sec * 1_000_000_000 + s.nanosec)
            counts[m.topic] = counts.get(m.topic, 0) + 1
    for topic in exp.record_topics:
        assert stamps[topic] == expected, f'{topic}: {len(stamps[topic])} of {len(expected)} steps'
        assert counts[topic] == len(expected), f'{topic}: {counts[topic] - len(expected)} repeated'


def run_in_thread(exp, tmp_path, **kw):
    """``exp``'s runner started in a thread and its run under way: ``(runner, thread, box)``,
    ``box['result']`` its RunResult once the thread has ended.
    """
    runner = ExperimentRunner(exp, runs_dir=tmp_path, progress=False, **kw)
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault('result', runner.run()))
    thread.start()
    assert wait_until(lambda: runner.phase in ('running', 'done'), 120.0)
    assert runner.phase == 'running', 'the run must be under way'
    return runner, thread, box


def test_killing_a_node_ends_the_run_with_a_clear_message(tmp_path):
    exp = load_experiment('figure10_mrc_with_actuator')
    exp.duration = 60.0
    runner, thread, box = run_in_thread(exp, tmp_path)
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
    # the run folder says that the run failed, and why
    doc = json.loads((result.run_dir / 'result.json').read_text())
    assert doc['completed'] is False and doc['message'] == result.message
    assert doc['duration'] == 60.0 and doc['experiment'] == 'figure10_mrc_with_actuator'


def test_a_node_refusing_to_start_names_no_bag_that_was_never_written(tmp_path):
    """An unstable PI design (kp 400): the composed process's lateral controller refuses it at
    start, before the recorder has written anything, so the message must not send the user to
    ``bag recover`` (there is no bag to recover).
    """
    from irs_bringup.experiment import find_experiment
    from irs_bringup.experiment_cli import run_experiment
    doc = yaml.safe_load(find_experiment('figure10_pi').read_text())
    doc['name'] = 'unstable_pi'
    doc['nodes']['lateral_controller']['params']['kp'] = 400.0
    path = tmp_path / 'unstable_pi.yaml'
    path.write_text(yaml.safe_dump(doc))
    result = run_experiment(str(path), runs_dir=tmp_path, plots=False)
    assert not result.completed
    assert 'died (exit code 2)' in result.message, result.message
    assert not list((result.run_dir / 'bag').glob('*.mcap'))
    assert 'bag recover' not in result.message, result.message


def test_a_controlled_stop_of_the_rig_is_logged_once_and_named_in_the_result(tmp_path):
    """Real time, composed: the loop's process stopped for 1.2 s (SIGSTOP) falls more than the
    stall grace behind real time and the rig stops car and belt under control. The runner logs
    the stop once when it begins, with its cause, and the run's result message names it.
    """
    exp = load_experiment('realtime_figure10_composed').with_duration(8.0)
    logs = []
    runner, thread, box = run_in_thread(exp, tmp_path, log=logs.append)
    loop = runner.procs['loop']
    os.kill(loop.pid, signal.SIGSTOP)
    time.sleep(1.2)                  # the stimulus: the process frozen for 1.2 s
    os.kill(loop.pid, signal.SIGCONT)
    thread.join(120)
    assert not thread.is_alive()
    result = box['result']
    assert result.completed and result.safe_stop, (result.message, logs)
    lines = [ln for ln in logs if 'stops car and belt under control' in ln]
    assert len(lines) == 1 and result.safe_stop in lines[0], logs
    assert 'stall_grace' in result.safe_stop and result.safe_stop in result.message


def test_a_dead_recorder_names_bag_recover_and_its_last_output_once(tmp_path):
    """SIGKILL the recorder of a running experiment: the run stops with a one-line message that
    names ``bag recover`` for its bag, the recorder's last output is logged once (the message
    the experiment command prints after the run does not repeat it), and ``bag recover`` makes
    a valid bag of what it recorded.
    """
    exp = load_experiment('figure10_mrc_with_actuator')
    exp.duration = 60.0
    logs = []
    runner, thread, box = run_in_thread(exp, tmp_path, log=logs.append)
    recorder = runner.procs['recorder']
    os.kill(recorder.pid, signal.SIGKILL)
    thread.join(120)
    assert not thread.is_alive()
    result = box['result']
    bag = runner.run_dir / 'bag'
    assert not result.completed
    assert result.message.startswith("node 'recorder' died (exit code -9)"), result.message
    assert f'`bag recover {bag}`' in result.message and '\n' not in result.message
    last = recorder.tail(1)
    assert last and sum(entry.count(last) for entry in logs + [result.message]) == 1, logs
    res = subprocess.run([resolve_executable('irs_bag', 'bag'), 'recover', str(bag), '--out',
                          str(tmp_path / 'fixed')], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert validate(tmp_path / 'fixed').ok


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
    result = ExperimentRunner(exp.deployed(), runs_dir=tmp_path, progress=False).run()
    assert set(result.exit_codes) == {'graph'}, result.exit_codes
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
    runner = subprocess.Popen(
        [exe, 'run', 'figure10_pi', '--process-per-node', '--no-plots', '--runs-dir',
         str(tmp_path)],
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
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


# ---------------------------------------------------------------- experiment files: the schema
# Fast tests (no graph): every malformed file gives one ExperimentError line
# '<file>: <key>: <what is wrong>', and the CLI prints it as 'experiment: ...' with exit code 2.

VALID = {
    'name': 'schema_test', 'description': 'minimal', 'clock': 'lockstep', 'duration': 0.5,
    'nodes': {
        'vehicle_sim': {'package': 'irs_vehicle_sim', 'executable': 'vehicle_sim',
                        'params_files': ['pkg://irs_vehicle_sim/config/rig.yaml'],
                        'params': {'x0': 0.3, 'lockstep_inputs': ['drive']}},
        'treadmill_regulator': {'package': 'irs_treadmill', 'executable': 'treadmill_regulator',
                                'params_files': ['pkg://irs_treadmill/config/treadmill.yaml']}},
    'record': {'topics': ['/pose']}}


def _doc(**changes):
    """VALID with changes; keys are dotted paths, value DELETE removes the key."""
    import copy
    doc = copy.deepcopy(VALID)
    for dotted, value in changes.items():
        *parents, leaf = dotted.split('__')
        target = doc
        for part in parents:
            target = target[part]
        if value is DELETE:
            del target[leaf]
        else:
            target[leaf] = value
    return doc


DELETE = object()
VS = 'nodes__vehicle_sim__'

BAD_FILES = {
    'unknown executable': (_doc(**{VS + 'executable': 'vehicle_simm'}),
                           'nodes.vehicle_sim.executable',
                           "no executable 'vehicle_simm' in package 'irs_vehicle_sim' (it has: "),
    'unknown package': (_doc(**{VS + 'package': 'irs_nothing'}), 'nodes.vehicle_sim.package',
                        "package 'irs_nothing' is not in the ament index"),
    'nodes a list': (_doc(nodes=['vehicle_sim']), 'nodes',
                     "expected a valid dictionary, got ['vehicle_sim']"),
    'node entry not a mapping': (_doc(nodes={'vehicle_sim': 'irs_vehicle_sim'}),
                                 'nodes.vehicle_sim',
                                 "expected a valid dictionary, got 'irs_vehicle_sim'"),
    'node without executable': (_doc(**{VS + 'executable': DELETE}),
                                'nodes.vehicle_sim.executable', 'required but missing'),
    'unknown node key': (
        _doc(**{VS + 'param': {}}),
        'nodes.vehicle_sim.param',
        'unknown key (expected one of: package, executable, params_files, params, '
        'remaps, process)',
    ),
    'params a list': (_doc(**{VS + 'params': ['x0', 0.3]}), 'nodes.vehicle_sim.params',
                      "expected a valid dictionary, got ['x0', 0.3]"),
    'params nested': (_doc(**{VS + 'params': {'actuator_front': {'lag_hz': 4.0}}}),
                      'nodes.vehicle_sim.params.actuator_front',
                      'a nested mapping: give flat names (<name>.<key>: value)'),
    'param without value': (
        _doc(**{VS + 'params': {'x0': None}}),
        'nodes.vehicle_sim.params.x0',
        'a boolean, number, string or list of one of those expected, got None',
    ),
    'param empty list': (_doc(**{VS + 'params': {'lockstep_inputs': []}}),
                         'nodes.vehicle_sim.params.lockstep_inputs',
                         'an empty list cannot be passed'),
    'param mixed list': (_doc(**{VS + 'params': {'lockstep_inputs': ['drive', 1]}}),
                         'nodes.vehicle_sim.params.lockstep_inputs',
                         "all elements of a list must have one type, got ['drive', 1]"),
    'remaps a list': (_doc(**{VS + 'remaps': ['a:=b']}), 'nodes.vehicle_sim.remaps',
                      'expected a valid dictionary'),
    'remap to a number': (_doc(**{VS + 'remaps': {'pose': 3}}), 'nodes.vehicle_sim.remaps.pose',
                          'expected a valid string, got 3'),
    'params_files a string': (
        _doc(**{VS + 'params_files': 'pkg://irs_vehicle_sim/config/rig.yaml'}),
        'nodes.vehicle_sim.params_files',
        'expected a valid list',
    ),
    'record a list': (_doc(record=['/pose']), 'record',
                      "expected a valid dictionary, got ['/pose']"),
    'record topics a string': (_doc(record={'topics': '/pose'}), 'record.topics',
                               "expected a valid list, got '/pose'"),
    'record unknown key': (_doc(record={'topic': ['/pose']}), 'record.topic',
                           'unknown key (expected one of: topics, process)'),
    'params file of an unknown package': (
        _doc(**{VS + 'params_files': ['pkg://irs_nothing/config/rig.yaml']}),
        'nodes.vehicle_sim.params_files[0]',
        "'pkg://irs_nothing/config/rig.yaml': package 'irs_nothing' is not in the ament index",
    ),
    'missing params file': (_doc(**{VS + 'params_files': ['/nonexistent/rig.yaml']}),
                            'nodes.vehicle_sim.params_files[0]',
                            "parameter file '/nonexistent/rig.yaml' not found"),
    'missing file in a package': (
        _doc(**{VS + 'params_files': ['pkg://irs_vehicle_sim/config/no.yaml']}),
        'nodes.vehicle_sim.params_files[0]',
        'not found',
    ),
    'duration below one step': (_doc(duration=0.0001), 'duration',
                                '0.0001 s is shorter than one rig step (dt = 0.001 s)'),
    'duration below one step of the rig dt': (
        _doc(duration=0.003, **{VS + 'params': {'dt': 0.004}}),
        'duration',
        'shorter than one rig step (dt = 0.004 s)',
    ),
    'duration true': (_doc(duration=True), 'duration', 'expected a number of seconds, got True'),
    'duration a string': (_doc(duration='8 s'), 'duration',
                          "expected a number of seconds, got '8 s'"),
    'duration zero': (_doc(duration=0), 'duration',
                      'expected a number of seconds greater than 0, got 0'),
    'duration infinite': (_doc(duration=float('inf')), 'duration',
                          'expected a finite number of seconds, got inf'),
    'duration missing': (_doc(duration=DELETE), 'duration', 'required but missing'),
    'name with ../': (_doc(name='../escape'), 'name', "'../escape' is not a plain name"),
    'name with /': (_doc(name='a/b'), 'name', "'a/b' is not a plain name"),
    'name with a space': (_doc(name='a b'), 'name', 'is not a plain name'),
    'name a number': (_doc(name=10), 'name', 'expected a valid string, got 10'),
    'clock unknown': (_doc(clock='fast'), 'clock',
                      "expected 'lockstep' or 'realtime', got 'fast'"),
    'unknown top-level key': (_doc(durration=1.0), 'durration',
                              'unknown key (expected one of: name, description, clock, duration'),
    'no nodes': (_doc(nodes={}), 'nodes', 'at least one entry expected, got {}'),
    'two rigs': (_doc(nodes__rig2=dict(VALID['nodes']['vehicle_sim'])), 'nodes',
                 "more than one vehicle_sim: ['vehicle_sim', 'rig2']"),
    'bad node name': (_doc(nodes={'my-node': VALID['nodes']['vehicle_sim']}), 'nodes',
                      'node names must be ROS names'),
    'process not a plain name': (_doc(**{VS + 'process': '../p'}), 'nodes.vehicle_sim.process',
                                 "'../p' is not a plain name for a process group"),
    'process a list': (_doc(**{VS + 'process': ['a']}), 'nodes.vehicle_sim.process',
                       'expected a valid string'),
    'parameter of the wrong type': (
        _doc(**{VS + 'params': {'x0': 'abc'}}),
        'nodes.vehicle_sim.params.x0',
        "parameter 'x0': got 'abc' (string), expected a finite double in [-1.2192, 1.2192]",
    ),
    'parameter out of range': (_doc(**{VS + 'params': {'x0': 5.0}}), 'nodes.vehicle_sim.params.x0',
                               'got 5.0 (out of range)'),
    'boolean for a double parameter': (_doc(**{VS + 'params': {'ds': True}}),
                                       'nodes.vehicle_sim.params.ds', 'got True (boolean)'),
    'lock-step input nobody publishes': (
        _doc(**{VS + 'params': {'x0': 0.3, 'lockstep_inputs': ['steering', 'drive']}}),
        'nodes.vehicle_sim.params.lockstep_inputs',
        "'steering' waits each step for /steering/command, which no node of the experiment "
        'publishes (the run would not get past t = 0)'),
    'reference_sync without a reference': (
        _doc(nodes__lateral_controller={
            'package': 'irs_control', 'executable': 'lateral_controller',
            'params': {'mode': 'pi', 'reference_sync': True}}),
        'nodes.lateral_controller.params.reference_sync',
        'reference_sync waits each step for /lateral/reference, which no node'),
    'misspelt parameter of a node with a whole table': (
        _doc(nodes__treadmill_regulator__params={'enabeld': False}),
        'nodes.treadmill_regulator.params.enabeld',
        "'enabeld' is not a parameter (did you mean enabled",
    ),
}


def _write(tmp_path, doc, name='exp.yaml'):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False) if not isinstance(doc, str) else doc)
    return path


def test_schema_installed_experiments_load():
    from irs_bringup.experiment import experiments_dir
    names = ['figure10_mrc_with_actuator', 'figure10_mrc_without_actuator', 'figure10_pi',
             'treadmill_regulation']
    assert set(names) <= {p.stem for p in experiments_dir().glob('*.yaml')}
    for name in names:
        exp = load_experiment(name)
        assert exp.name == name and exp.nodes and all(n.process is None for n in exp.nodes)


def test_schema_the_valid_document_loads_with_its_values(tmp_path):
    exp = load_experiment(
        str(
            _write(
                tmp_path,
                _doc(
                    **{VS + 'process': 'rig_group',
                       VS + 'params': {'x0': 0, 'lockstep_inputs': ['drive']}}
                ),
            )
        )
    )
    rig = exp.node('irs_vehicle_sim', 'vehicle_sim')
    assert (exp.name, exp.clock, exp.duration, exp.record_topics) == ('schema_test', 'lockstep',
                                                                      0.5, ['/pose'])
    assert rig == NodeEntry('vehicle_sim', 'irs_vehicle_sim', 'vehicle_sim',
                            ['pkg://irs_vehicle_sim/config/rig.yaml'],
                            {'x0': 0, 'lockstep_inputs': ['drive']}, {}, 'rig_group')
    assert exp.node('irs_treadmill', 'treadmill_regulator').process is None
    # one rig step is enough; an integer duration is a number
    assert load_experiment(str(_write(tmp_path, _doc(duration=0.001)))).duration == 0.001
    assert load_experiment(str(_write(tmp_path, _doc(duration=2)))).duration == 2.0
    # empty sections (YAML null) are empty, a number list with ints is doubles
    doc = _doc(record=None, **{VS + 'remaps': None,
                               VS + 'params': {'x0': 0.3, 'lockstep_inputs': ['drive']}})
    assert load_experiment(str(_write(tmp_path, doc))).record_topics == []
    assert NodeModel(package='p', executable='e', params={'poles': [1, 2.5]}).params == {
        'poles': [1.0, 2.5]
    }
    assert 'process' in ExperimentModel.model_fields['nodes'].annotation.__args__[1].model_fields


def test_composed_puts_every_node_and_the_recorder_in_one_process_and_leaves_the_file_alone(
        tmp_path):
    exp = load_experiment(str(_write(tmp_path, _doc(**{VS + 'process': 'rig_group'}))))
    assert exp.processes() == {'vehicle_sim': 'rig_group', 'treadmill_regulator': None,
                               'recorder': None}
    together = exp.composed()
    assert together.processes() == {'vehicle_sim': 'graph', 'treadmill_regulator': 'graph',
                                    'recorder': 'graph'}
    assert exp.composed('loop').record_process == 'loop'
    # the loaded experiment is untouched, the rest of the copy is the same
    assert exp.processes()['vehicle_sim'] == 'rig_group' and exp.record_process is None
    assert [(n.name, n.params) for n in together.nodes] == [(n.name, n.params) for n in exp.nodes]
    together.node('irs_vehicle_sim', 'vehicle_sim').params['x0'] = 0.5     # a copy of its own
    assert exp.node('irs_vehicle_sim', 'vehicle_sim').params['x0'] == 0.3
    exp.per_node().node('irs_vehicle_sim', 'vehicle_sim').params['x0'] = 0.5
    assert exp.node('irs_vehicle_sim', 'vehicle_sim').params['x0'] == 0.3
    assert (together.name, together.duration, together.record_topics) == (
        exp.name, exp.duration, exp.record_topics)
    # without recording there is no recorder to place
    quiet = load_experiment(str(_write(tmp_path, _doc(record=None))))
    assert 'recorder' not in quiet.composed().processes()


def test_default_deployment_composes_lockstep_files_that_place_no_node(tmp_path):
    free = load_experiment(str(_write(tmp_path, _doc())))
    assert free.deployed().processes() == free.composed().processes() == {
        'vehicle_sim': 'graph', 'treadmill_regulator': 'graph', 'recorder': 'graph'}
    assert free.deployed().deployment_line() == \
        "composed: every node and the recorder in one process 'graph'"
    # a file that places its nodes runs as written, the recorder included
    placed = load_experiment(str(_write(tmp_path, _doc(
        **{VS + 'process': 'rig_group', 'record__process': 'rig_group'}))))
    assert placed.deployed().processes() == placed.processes() == {
        'vehicle_sim': 'rig_group', 'treadmill_regulator': None, 'recorder': 'rig_group'}
    assert placed.deployed().deployment_line() == \
        "2 processes: 'rig_group' (vehicle_sim, recorder), treadmill_regulator"
    only_recorder = load_experiment(str(_write(tmp_path, _doc(record__process='r'))))
    assert only_recorder.deployed().processes()['vehicle_sim'] is None
    # real time runs as written, whether it places its nodes or not
    realtime = load_experiment(str(_write(tmp_path, _doc(clock='realtime'))))
    assert set(realtime.deployed().processes().values()) == {None}
    assert realtime.deployed('composed').processes() == free.composed().processes()
    # process per node, whatever the file places
    for exp in (free, placed, realtime):
        assert set(exp.deployed('process_per_node').processes().values()) == {None}
    assert placed.deployed('process_per_node').deployment_line() == \
        'process per node (3 processes)'
    with pytest.raises(ValueError, match="got 'together'"):
        free.deployed('together')
    # the installed files: Figure 10 places no node, the sysid and torque-car files one group
    for name in ('figure10_pi', 'sysid_actuator_steps', 'torque_braking_abs_low'):
        groups = set(load_experiment(name).deployed().processes().values())
        assert len(groups) == 1 and None not in groups, (name, groups)
    assert set(load_experiment('realtime_figure10').deployed().processes().values()) == {None}


def test_deployment_options_exclude_each_other_and_offline(capsys):
    for options in (['--offline', '--composed'], ['--offline', '--process-per-node']):
        with pytest.raises(SystemExit) as info:
            experiment_main(['run', 'figure10_pi', *options])
        assert info.value.code == 2
        assert 'pick one' in capsys.readouterr().err, options
    with pytest.raises(SystemExit) as info:
        experiment_main(['run', 'figure10_pi', '--composed', '--process-per-node'])
    assert info.value.code == 2
    assert 'not allowed with argument' in capsys.readouterr().err
    from irs_studies.figure10.cli import main as figure10_main
    with pytest.raises(SystemExit) as info:
        figure10_main(['--offline', '--process-per-node'])
    assert info.value.code == 2
    assert 'pick one' in capsys.readouterr().err


@pytest.mark.parametrize('case', sorted(BAD_FILES))
def test_schema_bad_file_is_one_line_naming_file_key_and_problem(tmp_path, case):
    doc, key, what = BAD_FILES[case]
    path = _write(tmp_path, doc)
    with pytest.raises(ExperimentError) as info:
        load_experiment(str(path))
    msg = str(info.value)
    assert msg.startswith(f'{path}: {key}: ') and what in msg, msg
    assert '\n' not in msg


def test_schema_not_yaml_and_not_a_mapping(tmp_path):
    for text, what in (('name: [unclosed\n', 'not valid YAML'),
                       ('', '(top level): the file is empty: a mapping of keys expected'),
                       ('# only a comment\n', '(top level): the file is empty'),
                       ('- a\n- b\n', "(top level): a mapping of keys expected, got ['a', 'b']")):
        path = _write(tmp_path, text)
        with pytest.raises(ExperimentError) as info:
            load_experiment(str(path))
        assert str(info.value).startswith(f'{path}: ') and what in str(info.value)
        assert '\n' not in str(info.value)


def test_a_directory_or_an_empty_name_is_no_experiment_file(tmp_path):
    folder = tmp_path / 'adir.yaml'
    folder.mkdir()
    for arg, what in ((str(folder), f'experiment file {folder} is a directory, not a file'),
                      (str(tmp_path), f'experiment file {tmp_path} is a directory, not a file'),
                      ('', 'no experiment named (an empty argument)')):
        with pytest.raises(ExperimentError) as info:
            load_experiment(arg)
        assert str(info.value) == what


def test_a_params_file_the_node_would_refuse_is_refused_before_start(tmp_path):
    """A directory, a file with no section for the node, two types for one parameter."""
    misspelt = tmp_path / 'misspelt.yaml'
    misspelt.write_text('treadmill_regulatr:\n  ros__parameters:\n    rate_hz: 100.0\n')
    retyped = tmp_path / 'retyped.yaml'
    retyped.write_text('treadmill_regulator:\n  ros__parameters:\n    rate_hz: 100.0\n')
    retyped2 = tmp_path / 'retyped2.yaml'
    retyped2.write_text('treadmill_regulator:\n  ros__parameters:\n    rate_hz: [1.0]\n')
    for files, what in (
            ([str(tmp_path)],
             r"params_files\[0\]: parameter file '.*' is a directory, not a file"),
            ([str(misspelt)], r'params_files: --params-file .*misspelt.yaml: no section for node '
                              r'/treadmill_regulator: it has treadmill_regulatr \(a misspelt'),
            ([str(retyped), str(retyped2)], r"params_files: parameter 'rate_hz' of node "
                                            r'/treadmill_regulator: .*retyped.yaml gives')):
        doc = _doc(nodes__treadmill_regulator__params_files=files)
        with pytest.raises(ExperimentError, match=what) as info:
            load_experiment(str(_write(tmp_path, doc)))
        assert '\n' not in str(info.value)


def test_schema_file_name_must_be_a_plain_name_without_name_key(tmp_path):
    path = _write(tmp_path, _doc(name=DELETE), name='my exp.yaml')
    with pytest.raises(ExperimentError, match=r"name: the file name 'my exp' is not a plain name"):
        load_experiment(str(path))
    assert (
        load_experiment(str(_write(tmp_path, _doc(name=DELETE), name='plain-1.yaml'))).name
        == 'plain-1'
    )


def test_schema_bad_parameter_in_a_params_file_names_that_file(tmp_path):
    params = tmp_path / 'reg.yaml'
    params.write_text('treadmill_regulator:\n  ros__parameters:\n    rate_hz: fast\n')
    doc = _doc(nodes__treadmill_regulator__params_files=['pkg://irs_treadmill/config/treadmill.yaml',
                                                         str(params)])
    with pytest.raises(ExperimentError, match=r"nodes\.treadmill_regulator\.params_files\[1\]: "
                                              r"parameter 'rate_hz': got 'fast' \(string\)"):
        load_experiment(str(_write(tmp_path, doc)))
    params.write_text('- not a parameter file\n')
    with pytest.raises(
        ExperimentError, match=r'params_files\[1\]: .*reg.yaml: expected <node name>'
    ):
        load_experiment(str(_write(tmp_path, doc)))


@pytest.mark.parametrize('case', ['unknown executable', 'nodes a list', 'missing params file',
                                  'params file of an unknown package', 'duration below one step',
                                  'duration true', 'name with ../', 'parameter of the wrong type',
                                  'record topics a string'])
def test_schema_cli_prints_one_line_and_exits_2(tmp_path, capsys, case):
    doc, key, what = BAD_FILES[case]
    path = _write(tmp_path, doc)
    for offline in ([], ['--offline']):
        code = experiment_main(['run', str(path), '--runs-dir', str(tmp_path / 'runs'), *offline])
        out, err = capsys.readouterr()
        assert code == 2 and out == ''
        assert err.startswith(f'experiment: error: {path}: {key}: ') and what in err, err
        assert err.count('\n') == 1
    assert not (tmp_path / 'runs').exists() and not (tmp_path.parent / 'escape').exists()


def test_schema_offline_run_with_a_parameter_only_the_cores_check_is_one_line(tmp_path, capsys):
    doc = _doc(
        nodes__lateral_controller={'package': 'irs_control', 'executable': 'lateral_controller',
                                   'params': {'mode': 'mrc', 'reference_model_den': [1.0, -1.0]}}
    )
    path = _write(tmp_path, doc)
    assert experiment_main(['run', str(path), '--offline']) == 2
    _out, err = capsys.readouterr()
    assert err == (f'experiment: error: {path}: nodes.lateral_controller: reference_model_den '
                   'must be stable (all roots with negative real part); got roots [1.] of '
                   '[1.0, -1.0].\n')
    # a mode the table knows not is refused at loading, naming the file and the key
    doc['nodes']['lateral_controller']['params'] = {'mode': 'lqr'}
    with pytest.raises(ExperimentError, match=r"nodes\.lateral_controller\.params\.mode: .*"
                       r"expected one of mrc, pi, got 'lqr'"):
        load_experiment(str(_write(tmp_path, doc)))


def test_schema_the_installed_command_prints_one_line_and_exits_2(tmp_path):
    """Through the real executable (as `./irs run irs_bringup experiment run <file>`)."""
    exe = resolve_executable('irs_bringup', 'experiment')
    for case, extra in (('name with ../', []), ('parameter of the wrong type', ['--offline'])):
        doc, key, what = BAD_FILES[case]
        path = _write(tmp_path, doc)
        res = subprocess.run([exe, 'run', str(path), '--runs-dir',
                               str(tmp_path / 'runs'), *extra],
                             capture_output=True, text=True, timeout=120)
        assert res.returncode == 2, res.stderr
        assert res.stderr.startswith(f'experiment: error: {path}: {key}: ') and what in res.stderr
        assert res.stderr.count('\n') == 1 and 'Traceback' not in res.stderr


def test_surface_section_becomes_the_rigs_surface_parameters(tmp_path):
    """The torque car's road in a ``surface:`` section: the rig gets it as ``surface.*``;
    the installed torque-car experiments use it.
    """
    doc = _doc(surface={'kind': 'split', 'mu_left': 0.8, 'mu_right': 0.3},
               **{VS + 'params': {'plant': 'two_track', 'lockstep_inputs': ['drive']}})
    rig = load_experiment(str(_write(tmp_path, doc))).node('irs_vehicle_sim', 'vehicle_sim')
    assert rig.params == {'plant': 'two_track', 'lockstep_inputs': ['drive'],
                          'surface.kind': 'split', 'surface.mu_left': 0.8,
                          'surface.mu_right': 0.3}
    low = load_experiment('torque_braking_abs_low').node('irs_vehicle_sim', 'vehicle_sim')
    assert low.params['surface.kind'] == 'uniform' and low.params['surface.mu'] == 0.3


@pytest.mark.parametrize('surface, rig_params, what', [
    ({'kind': 'wet'}, {'plant': 'two_track'}, 'surface kind must be one of'),
    ({'kind': 'split', 'mu': 0.3}, {'plant': 'two_track'}, "reads only ['mu_left', 'mu_right']"),
    ({'kind': 'uniform', 'mu': 0.0}, {'plant': 'two_track'}, 'mu'),
    ({'kind': 'uniform', 'mu': 0.3}, {}, 'only the torque car has tyres'),
    ({'kind': 'uniform', 'mu': 0.3}, {'plant': 'two_track', 'surface.mu': 0.8},
     'given here and as nodes.vehicle_sim.params'),
])
def test_surface_section_refused_in_one_line(tmp_path, surface, rig_params, what):
    path = _write(tmp_path, _doc(surface=surface, **{VS + 'params': rig_params}))
    with pytest.raises(ExperimentError) as info:
        load_experiment(str(path))
    msg = str(info.value)
    assert msg.startswith(f'{path}: surface') and what in msg and '\n' not in msg, msg


def test_two_runs_started_in_one_second_get_a_directory_each(tmp_path):
    """Both runners pick the same name (a 1 s resolution); creating it decides who has it."""
    from concurrent.futures import ThreadPoolExecutor

    from irs_bringup.experiment import make_run_dir, new_run_dir
    exp = load_experiment('figure10_pi')
    first, second = (ExperimentRunner(exp, runs_dir=tmp_path, progress=False) for _ in range(2))
    assert first.run_dir == second.run_dir and not first.run_dir.exists()
    with ThreadPoolExecutor(8) as pool:
        made = list(pool.map(make_run_dir, [first.run_dir] * 8))
    assert len(set(made)) == 8 and all(p.is_dir() for p in made)
    assert first.run_dir in made and first.run_dir.with_name(first.run_dir.name + '-8') in made
    assert make_run_dir(new_run_dir(tmp_path, 'other')).parent == tmp_path


def test_the_example_of_docs_experiments_loads(tmp_path):
    """The experiment file docs/experiments.md shows is one the runner takes."""
    import re
    text = (Path(__file__).resolve().parents[2] / 'docs' / 'experiments.md').read_text()
    (example,) = re.findall(r'```yaml\n(.*?)```', text, re.S)
    exp = load_experiment(str(_write(tmp_path, example, name='my_pi_sine.yaml')))
    ctl = exp.node('irs_control', 'lateral_controller')
    assert exp.name == 'my_pi_sine' and ctl.params['kp'] == 4.0
