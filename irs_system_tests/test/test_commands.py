"""The commands above the nodes as a user meets them: smoke tests, one-line errors, outputs only
where asked, sweeps of any size, the runner in real time (docs/cli.md).

Commands run as the installed executables (``./irs run <pkg> <exe>``) in a temporary working
directory, or in-process where only their argument handling is under test.
"""
import json
import math
import os
from pathlib import Path
import re
import signal
import socket
import subprocess
import sys
import threading
import time

from hypothesis import HealthCheck, given, settings, strategies as st
import pyarrow.parquet as pq
import pytest
import yaml

from irs_bringup.executables import resolve_executable
from irs_bringup.processes import wait_until
from irs_common.cli import BUG_HINT

INTERNAL = 'internal error'


def run(package, exe, *args, cwd, timeout=300, env=None):
    """Run an installed command in ``cwd``; the CompletedProcess (text)."""
    return subprocess.run([resolve_executable(package, exe), *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout, env=env)


def one_line_error(res, prog, code=2):
    """The command ended with ``code`` and one ``<prog>: error: ...`` line, no traceback."""
    assert res.returncode == code, (res.returncode, res.stdout[-2000:], res.stderr[-2000:])
    assert res.stderr.startswith(f'{prog}: error: ') and res.stderr.count('\n') == 1, res.stderr
    assert INTERNAL not in res.stderr and 'Traceback' not in res.stderr + res.stdout
    return res.stderr


def tree(root: Path) -> set:
    """Every path under ``root``, relative."""
    return {str(p.relative_to(root)) for p in root.rglob('*')}


# -------------------------------------------------------------------------- smoke tests
@pytest.mark.parametrize('package,exe,args', [
    ('irs_studies', 'figure10', ['--help']), ('irs_studies', 'figures', ['--help']),
    ('irs_studies', 'sweep', ['--help']), ('irs_studies', 'torque_car', ['--help']),
    ('irs_sysid', 'sysid', ['--help']), ('irs_bringup', 'container', ['--help']),
    ('irs_bringup', 'experiment', ['run', '--help']), ('irs_bringup', 'experiment', ['--help']),
    ('irs_hardware', 'calibrate', ['--help']), ('irs_hardware', 'board_emulator', ['--help']),
    ('irs_hardware', 'drive_emulator', ['--help']),
])
def test_help_of_every_command(tmp_path, package, exe, args):
    res = run(package, exe, *args, cwd=tmp_path, timeout=120)
    assert res.returncode == 0 and 'usage' in res.stdout.lower(), res.stderr
    assert not re.search(r'``|:(mod|class|func|meth|data):`|::\n', res.stdout), res.stdout
    assert tree(tmp_path) == set()


def test_every_node_answers_help_with_its_usage_and_parameters_and_starts_nothing(tmp_path):
    """``<node> --help`` prints the usage and the node's parameter table, exit code 0, before
    rclpy starts (no bag, no log directory), for every node that registers a table.
    """
    from irs_common.params import registered_tables
    tables = registered_tables()
    assert len(tables) >= 10, sorted(tables)
    procs = {key: subprocess.Popen([resolve_executable(*key), '--help'], cwd=tmp_path,
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   env={**os.environ, 'ROS_LOG_DIR': str(tmp_path / 'log')})
             for key in tables}
    for (package, exe), proc in procs.items():
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, (exe, err)
        assert out.startswith(f'usage: ros2 run {package} {exe} [--ros-args'), (exe, out[:300])
        for p in tables[(package, exe)]:
            assert f'\n  {p.name} [{p.unit}] = ' in out, (exe, p.name)
    assert tree(tmp_path) == set()


@pytest.mark.parametrize('args,shown', [
    (['-p', 'clock_mode:=lockstep'], '-p clock_mode:=lockstep'),
    (['clock_mode:=lockstep'], '-p clock_mode:=lockstep'),
])
def test_node_parameters_without_ros_args_are_refused_in_one_line(tmp_path, args, shown):
    """rclpy would ignore them (or read a remap rule) and start the rig in real time."""
    res = run('irs_vehicle_sim', 'vehicle_sim', *args, cwd=tmp_path, timeout=120)
    assert res.returncode == 2, res
    assert res.stderr.startswith('[FATAL] vehicle_sim takes no arguments of its own') \
        and res.stderr.count('\n') == 1, res.stderr
    assert f'vehicle_sim --ros-args {shown} ' in res.stderr, res.stderr
    assert tree(tmp_path) == set()


def test_help_after_ros_args_says_where_it_goes(tmp_path):
    res = run('irs_control', 'lateral_controller', '--ros-args', '-p', 'kp:=2.0', '--help',
              cwd=tmp_path, timeout=120)
    assert res.returncode == 2, res
    assert res.stderr.startswith("[FATAL] unknown ROS arguments after --ros-args: ['--help'] "
                                 '(--help goes before --ros-args, or after a closing --)'), \
        res.stderr
    assert res.stderr.count('\n') == 1, res.stderr


def test_experiment_list_reads_the_files_only(tmp_path):
    """No ROS, no schema, no parameter tables: the list is YAML read from the share folder."""
    code = ('import sys; from irs_bringup.experiment_cli import main; main(["list"]); '
            'heavy = [m for m in ("rclpy", "pydantic", "numpy", "irs_vehicle_sim") '
            'if m in sys.modules]; print("HEAVY", heavy)')
    res = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=120, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[-1] == 'HEAVY []', lines[-1]
    names = [ln.split()[0] for ln in lines[:-1]]
    assert {'figure10_pi', 'realtime_figure10_composed', 'treadmill_regulation'} <= set(names)
    pi = next(ln for ln in lines if ln.startswith('figure10_pi '))
    assert 'lockstep' in pi and '8.0 s' in pi
    # one column each, whatever the length of the names
    assert len({ln.index(' lockstep ' if ' lockstep ' in ln else ' realtime ')
                for ln in lines[:-1]}) == 1, lines


def test_sweep_list_and_similitude(tmp_path):
    res = run('irs_studies', 'sweep', 'list', cwd=tmp_path, timeout=120)
    assert res.returncode == 0 and res.stdout.split()[0] == 'actuator_speed', res.stderr
    assert 'mrc_delay_gain' in res.stdout
    res = run('irs_studies', 'sweep', 'similitude', '--out', 'sim', cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert '| irs_2wd |' in res.stdout and 'Pi3' in res.stdout
    pngs = sorted((tmp_path / 'sim').glob('*.png'))
    assert [p.name for p in pngs] == ['similitude_eq6_eq7_10.png', 'sweep_similitude_speed.png',
                                      'sweep_similitude_step.png']
    assert all(p.stat().st_size > 20000 for p in pngs)
    assert tree(tmp_path) == {'sim', *(f'sim/{p.name}' for p in pngs)}


def test_figure10_offline_writes_its_own_report_and_leaves_the_graphs_alone(tmp_path):
    """``figure10 --offline``: the short form of ``make demo``; its report goes to
    ``<runs-dir>/figure10-offline``, never over the graph's ``<runs-dir>/figure10``.
    """
    graph = tmp_path / 'runs' / 'figure10'
    graph.mkdir(parents=True)
    (graph / 'figure10_metrics.md').write_text('the graph run\n')
    res = run('irs_studies', 'figure10', '--offline', '--runs-dir', 'runs', cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert (graph / 'figure10_metrics.md').read_text() == 'the graph run\n'
    report = tmp_path / 'runs' / 'figure10-offline'
    assert (report / 'figure10.png').stat().st_size > 50000
    text = (report / 'figure10_metrics.md').read_text()
    assert 'offline' in text and 'mrc_with_actuator' in text
    assert tree(tmp_path) <= {'runs', 'runs/figure10', 'runs/figure10/figure10_metrics.md',
                              'runs/figure10-offline', *(f'runs/figure10-offline/{p.name}'
                                                         for p in report.iterdir())}


# ------------------------------------------------------------------------ experiment run
def test_offline_run_writes_traces_metrics_and_plots_in_its_own_folder(tmp_path):
    res = run('irs_bringup', 'experiment', 'run', 'figure10_pi', '--offline', '--duration', '1.5',
              '--runs-dir', 'out', cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    (run_dir,) = (tmp_path / 'out').iterdir()
    assert run_dir.name.startswith('figure10_pi-offline-')
    traces = pq.read_table(run_dir / 'traces.parquet').to_pydict()
    assert len(traces['time']) == 1501 and traces['time'][-1] == pytest.approx(1.5)
    assert {'y_s', 'reference', 'steer_cmd', 'belt_speed'} <= set(traces)
    assert math.isnan(traces['steer_cmd'][-1]) and not math.isnan(traces['steer_cmd'][-2])
    doc = json.loads((run_dir / 'metrics.json').read_text())
    assert doc['experiment'] == 'figure10_pi' and doc['duration'] == 1.5
    m = doc['metrics']
    assert m['samples'] == 1501 and m['fault'] is False
    assert m['final_y_s'] == pytest.approx(traces['y_s'][-1])
    assert 0 < m['max_abs_error'] < 0.05 and m['ise'] > 0
    plots = sorted(p.name for p in (run_dir / 'plots').iterdir())
    assert plots == ['belt.png', 'car_position.png', 'lateral.png', 'steering.png']
    assert all((run_dir / 'plots' / p).stat().st_size > 10000 for p in plots)
    assert {p.split('/')[0] for p in tree(tmp_path)} == {'out'}


def test_offline_plots_are_titled_with_the_controller_as_a_bags_are(tmp_path, monkeypatch):
    import irs_bag.plots
    from irs_bringup.experiment_cli import run_offline
    seen = []
    monkeypatch.setattr(irs_bag.plots, 'plot_series',
                        lambda data, out_dir, info=None: seen.append(info) or [])
    run_offline('figure10_pi', tmp_path, duration=0.2, log=lambda *_: None)
    assert seen and seen[0].controller.startswith('PI (kp '), seen
    assert seen[0].experiment == 'figure10_pi'


def test_offline_refuses_the_design_the_node_refuses_and_runs_it_when_allowed(tmp_path):
    """The paper's MRC checked on irs_2wd: the graph's lateral_controller refuses it at start,
    and so does ``--offline`` (one line, exit 2, no run folder); ``allow_unstable_design`` runs
    it with a warning, as the node does.
    """
    from irs_bringup.experiment import experiments_dir
    doc = yaml.safe_load((experiments_dir() / 'figure10_mrc_with_actuator.yaml').read_text())
    doc.update(name='mrc_on_2wd', duration=0.2)
    doc['nodes']['lateral_controller'].setdefault('params', {})['check_plant'] = 'irs_2wd'
    (tmp_path / 'mrc_on_2wd.yaml').write_text(yaml.safe_dump(doc))
    res = run('irs_bringup', 'experiment', 'run', 'mrc_on_2wd.yaml', '--offline', '--runs-dir',
              'out', cwd=tmp_path)
    err = one_line_error(res, 'experiment')
    assert 'mrc_on_2wd.yaml: nodes.lateral_controller: MRC design' in err, err
    assert 'UNSTABLE' in err, err
    assert not (tmp_path / 'out').exists()
    doc['nodes']['lateral_controller']['params']['allow_unstable_design'] = True
    (tmp_path / 'mrc_on_2wd.yaml').write_text(yaml.safe_dump(doc))
    res = run('irs_bringup', 'experiment', 'run', 'mrc_on_2wd.yaml', '--offline', '--runs-dir',
              'out', cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert '[experiment] warning: MRC design' in res.stdout and 'running anyway' in res.stdout


@pytest.mark.parametrize('value,what', [
    ('0', 'a finite number of seconds > 0 expected, got 0.0'),
    ('-1', 'got -1.0'), ('nan', 'got nan'), ('inf', 'got inf'),
    ('0.0001', 'shorter than one rig step'),
])
def test_experiment_duration_refused_in_one_line(tmp_path, monkeypatch, capsys, value, what):
    """In-process (argument handling only); the installed command: the test below."""
    from irs_bringup.experiment_cli import main
    monkeypatch.chdir(tmp_path)
    for extra in (['--offline'], []):
        code = main(['run', 'figure10_pi', f'--duration={value}', '--runs-dir', 'out', *extra])
        captured = capsys.readouterr()
        res = subprocess.CompletedProcess([], code, captured.out, captured.err)
        err = one_line_error(res, 'experiment')
        assert '--duration: ' in err and what in err, err
    assert tree(tmp_path) == set()


def test_installed_experiment_refuses_a_duration_in_one_line(tmp_path):
    for extra in (['--offline'], []):
        res = run('irs_bringup', 'experiment', 'run', 'figure10_pi', '--duration=nan',
                  '--runs-dir', 'out', *extra, cwd=tmp_path, timeout=120)
        err = one_line_error(res, 'experiment')
        assert '--duration: a finite number of seconds > 0 expected, got nan' in err, err
    assert tree(tmp_path) == set()


def test_wrong_names_get_did_you_mean(tmp_path):
    err = one_line_error(run('irs_bringup', 'experiment', 'run', 'figure10_pii', cwd=tmp_path,
                             timeout=120), 'experiment')
    assert "no experiment 'figure10_pii' (did you mean figure10_pi?)" in err
    assert 'installed (experiment list lists them)' in err and len(err) < 300
    err = one_line_error(run('irs_studies', 'sweep', 'actuator_sped', cwd=tmp_path,
                             timeout=120), 'sweep')
    assert "no sweep 'actuator_sped' (did you mean actuator_speed?)" in err
    assert tree(tmp_path) == set()


# ----------------------------------------------------------- nodes, container, params files
def _driver(tmp_path, *files):
    args = [a for f in files for a in ('--params-file', f)]
    return run('irs_bringup', 'driver', '--ros-args', *args, cwd=tmp_path, timeout=120)


def test_params_file_without_a_section_for_the_node_is_one_line(tmp_path):
    (tmp_path / 'a.yaml').write_text('drivr:\n  ros__parameters:\n    rate: 50.0\n')
    res = _driver(tmp_path, 'a.yaml')
    assert res.returncode == 2, res
    assert res.stderr.strip() == ("[FATAL] configuration error: --params-file a.yaml: no section "
                                  "for node /driver: it has drivr (a misspelt 'driver'?)")


def test_a_node_refuses_a_params_file_before_it_says_anything_else(tmp_path):
    """The rig logs nothing ('rig up: ...') before the one line that refuses its file."""
    (tmp_path / 'a.yaml').write_text('vehicle_sm:\n  ros__parameters:\n    x0: 0.3\n')
    res = run('irs_vehicle_sim', 'vehicle_sim', '--ros-args', '--params-file', 'a.yaml',
              cwd=tmp_path, timeout=120)
    assert res.returncode == 2, res
    assert res.stdout == '' and res.stderr == (
        '[FATAL] configuration error: --params-file a.yaml: no section for node /vehicle_sim: '
        "it has vehicle_sm (a misspelt 'vehicle_sim'?)\n"), res


def test_recover_without_a_rig_fails_in_one_line_after_discovery(tmp_path):
    """No rig in the domain: exit code 1 and one line once discovery had its time (5 s)."""
    res = run('irs_bringup', 'experiment', 'recover', cwd=tmp_path, timeout=120)
    assert one_line_error(res, 'experiment', code=1).startswith(
        'experiment: error: recover: no rig/recover service within 5 s')
    assert tree(tmp_path) == set()


def test_second_params_file_retyping_a_parameter_is_one_line(tmp_path):
    (tmp_path / 'a.yaml').write_text('driver:\n  ros__parameters:\n    rate: 50.0\n')
    (tmp_path / 'b.yaml').write_text('driver:\n  ros__parameters:\n    rate: fast\n')
    res = _driver(tmp_path, 'a.yaml', 'b.yaml')
    assert res.returncode == 2, res
    assert res.stderr.strip() == ("[FATAL] configuration error: parameter 'rate' of node "
                                  '/driver: a.yaml gives a double, b.yaml a string (one '
                                  'parameter, one type)')


def test_params_file_checks_accept_what_ros_accepts():
    from irs_common.params import params_file_problems, section_matches
    assert section_matches('/**', '/driver') and section_matches('driver', '/driver')
    assert section_matches('/*/driver', '/ns/driver') and section_matches('/**/driver', '/driver')
    assert not section_matches('/ns/driver', '/driver') and not section_matches('drivr', '/driver')
    from ament_index_python.packages import get_package_share_directory
    realtime = Path(get_package_share_directory('irs_bringup')) / 'config' / 'realtime.yaml'
    rig = Path(get_package_share_directory('irs_vehicle_sim')) / 'config' / 'rig.yaml'
    assert params_file_problems([rig, realtime], '/vehicle_sim') == []   # several sections


def test_container_refuses_two_nodes_of_one_name(tmp_path):
    spec = tmp_path / 'spec.yaml'
    spec.write_text(yaml.safe_dump({'nodes': [
        {'package': 'irs_bringup', 'executable': 'driver'},
        {'package': 'irs_bringup', 'executable': 'driver', 'ros_args': ['-p', 'rate:=5.0']}]}))
    res = run('irs_bringup', 'container', spec, cwd=tmp_path, timeout=120)
    assert res.returncode == 2, res
    assert res.stderr == (f"[FATAL] container: {spec}: nodes[1] and nodes[0] are both named "
                          "'driver': give one another name (ros_args: -r __node:=...)\n")
    spec.write_text(yaml.safe_dump({'nodes': [{'package': 'irs_bringup', 'executable': 'drivr'}]}))
    res = run('irs_bringup', 'container', spec, cwd=tmp_path, timeout=120)
    assert res.returncode == 2 and "no composable node 'irs_bringup/drivr' (did you mean " \
        "irs_bringup/driver?)" in res.stderr and res.stderr.count('\n') == 1, res.stderr


def test_sysid_treadmill_refuses_a_torque_car_bag(tmp_path):
    res = run('irs_bringup', 'experiment', 'run', 'torque_braking_abs_low', '--composed',
              '--duration', '0.3', '--no-plots', '--runs-dir', 'runs', cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr
    (bag,) = (tmp_path / 'runs').glob('torque_braking_abs_low-*/bag')
    err = one_line_error(run('irs_sysid', 'sysid', 'treadmill', bag, cwd=tmp_path), 'sysid')
    assert err.startswith(f'sysid: error: {bag}: 0 drive steps up from rest and ')
    assert err.endswith(' coast-downs in /treadmill/drive: nothing to identify the belt from '
                        '(record the sysid_treadmill experiment)\n')


# --------------------------------------------------------------------------- sweeps
def _sweep_file(tmp_path, name='s', axes=None, **extra):
    doc = {'name': name, 'scenario': 'figure10_mrc_with_actuator', 'duration': 0.4,
           'fixed': {'reference.signal.start_time': 0.1},
           'axes': axes or [{'name': 'delay_ms', 'values': [0.0, 20.0],
                             'set': {'rig.actuator_front.delay': 0.001}}],
           'metrics': ['ise_norm'], **extra}
    path = tmp_path / f'{name}.yaml'
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


HUGE = [{'name': n, 'range': {'start': 0.0, 'stop': 1.0, 'num': 10000}, 'set': {p: 0.001}}
        for n, p in (('a', 'rig.actuator_front.delay'), ('b', 'rig.identified.gain'),
                     ('c', 'rig.x0'))]


def test_sweep_size_is_checked_before_anything_runs(tmp_path):
    _sweep_file(tmp_path, 'huge', HUGE, seeds=100000)
    res = run('irs_studies', 'sweep', 'huge.yaml', cwd=tmp_path, timeout=120)
    err = one_line_error(res, 'sweep')
    assert res.stdout.startswith('[sweep] huge: 100,000,000,000,000,000 points (100,000 seed(s))'
                                 ' x 0.4 s = 40,000,000,000,000,000 s of simulated time')
    assert 'above the limit of 100,000 s or 100,000 points' in err and '--force' in err
    _sweep_file(tmp_path, 'long', duration=1e9)
    err = one_line_error(run('irs_studies', 'sweep', 'long.yaml', cwd=tmp_path, timeout=120),
                         'sweep')
    assert '2 points (1 seed(s)) x 1e+09 s = 2,000,000,000 s of simulated time: above' in err
    assert {p for p in tree(tmp_path) if not p.endswith('.yaml')} == set()


def test_huge_sweep_forced_runs_lazily(tmp_path):
    """``--force --limit 3`` runs three points of 10^12 without making the grid."""
    _sweep_file(tmp_path, 'huge', HUGE)
    t0 = time.monotonic()
    res = run('irs_studies', 'sweep', 'huge.yaml', '--force', '--limit', '3', '--serial',
              '--no-plots', '--out', 'o', cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    rows = pq.read_table(tmp_path / 'o' / 'results.parquet').to_pylist()
    assert [(r['a'], r['b'], r['c']) for r in rows] == [(0.0, 0.0, 0.0), (0.0, 0.0, 1 / 9999),
                                                        (0.0, 0.0, 2 / 9999)]
    print(f'\n3 points of a 10^12-point sweep in {time.monotonic() - t0:.1f} s')


def test_sweep_plot_file_must_stay_in_the_results_directory(tmp_path):
    _sweep_file(tmp_path, plots=[{'kind': 'heatmap', 'x': 'delay_ms', 'y': 'delay_ms',
                                  'metric': 'ise_norm', 'file': '../../escape/x.png'}])
    err = one_line_error(run('irs_studies', 'sweep', 's.yaml', '--serial', '--out', 'o/p',
                             cwd=tmp_path, timeout=120), 'sweep')
    assert "plots.0.file: '../../escape/x.png': a plain PNG file name expected" in err
    assert not (tmp_path.parent / 'escape').exists() and not (tmp_path / 'o').exists()
    from irs_common.cli import InputError
    from irs_studies.sweep.sweep_cli import inside
    with pytest.raises(InputError, match='must stay inside the results directory'):
        inside(tmp_path / 'o', '../x.png')


def test_sweep_scheduler_that_is_no_dask_peer_is_one_line(tmp_path):
    server = socket.socket()
    server.bind(('127.0.0.1', 0))
    server.listen(8)
    port = server.getsockname()[1]
    stop = threading.Event()

    def serve():                        # an HTTP-ish peer: answers anything with junk
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            conn.sendall(b'\xff' * 64 + b'HTTP/1.1 200 OK\r\n\r\nhello')
            conn.close()
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        _sweep_file(tmp_path)
        err = one_line_error(run('irs_studies', 'sweep', 's.yaml', '--scheduler',
                                 f'tcp://127.0.0.1:{port}', '--out', 'o', cwd=tmp_path,
                                 timeout=300), 'sweep')
        assert err.startswith(f'sweep: error: --scheduler tcp://127.0.0.1:{port}: no Dask '
                              'scheduler answered there (')
    finally:
        stop.set()
        thread.join(5)
        server.close()


def test_progress_rate_over_a_window_and_estimating_first(monkeypatch):
    import io

    from irs_studies.sweep import runner
    clock = {'t': 100.0}
    monkeypatch.setattr(runner.time, 'monotonic', lambda: clock['t'])
    stream = io.StringIO()
    p = runner.Progress(100, 5, print, warmup=3, stream=stream)
    clock['t'] = 160.0                       # a minute of cluster start-up: no point yet
    assert '| estimating |' in p.line() and ' 0/100 points' in p.line()
    for _ in range(2):
        clock['t'] += 1.0
        p.update({'error': ''})
    assert '| estimating |' in p.line()     # below warmup
    for _ in range(8):
        clock['t'] += 1.0
        p.update({'error': ''})
    line = p.line()                          # 10 points, 9 of them in the 9 s since the first
    assert '10/100 points | 1.00 points/s | 90 s left |' in line, line
    assert '(5 already done)' in line
    for _ in range(40):                      # the rate halves: the window follows within 30 s
        clock['t'] += 2.0
        p.update({'error': 'refused'})
    assert '50/100 points | 0.50 points/s | 100 s left' in p.line(), p.line()
    assert '40 refused' in p.line()


def test_sweep_interrupted_by_ctrl_c_prints_no_traceback_and_resumes(tmp_path):
    # 3 s per point (about 8 s of work on one worker with the compiled cores, 16 s interpreted):
    # the Ctrl-C below lands while points run even when this process gets little CPU (at 1.2 s
    # the compiled cores finished all 120 points first)
    _sweep_file(tmp_path, axes=[{'name': 'delay_ms', 'range': {'start': 0.0, 'stop': 40.0,
                                                                'num': 120},
                                 'set': {'rig.actuator_front.delay': 0.001}}], duration=3.0)
    log = open(tmp_path / 'first.log', 'w')
    proc = subprocess.Popen([resolve_executable('irs_studies', 'sweep'), 's.yaml', '--workers',
                             '1', '--out', 'o', '--no-plots'], cwd=tmp_path, stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        text = lambda: (tmp_path / 'first.log').read_text()   # noqa: E731
        assert wait_until(lambda: 'points/s' in text() or proc.poll() is not None, 300), text()
        assert proc.poll() is None, text()
        assert 'dashboard http://' in text()
        os.killpg(proc.pid, signal.SIGINT)    # Ctrl-C at a terminal: the whole process group
        proc.wait(60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        log.close()
    out = text()
    assert proc.returncode == 130, out
    assert 'Traceback' not in out and INTERNAL not in out, out
    assert 'run the same command again to resume' in out and 'sweep: interrupted (SIGINT)' in out
    from irs_studies.sweep import results
    kept = len(results.done_keys(tmp_path / 'o'))
    assert 0 < kept < 120, kept
    res = run('irs_studies', 'sweep', 's.yaml', '--serial', '--no-plots', '--out', 'o',
              cwd=tmp_path, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    assert f'({kept} already done' in res.stderr + res.stdout
    rows = results.read_results(tmp_path / 'o')
    assert len(rows) == 120 and len({r['point'] for r in rows}) == 120


# ------------------------------------------------------------------ outputs only where asked
def test_no_command_writes_outside_its_output_folder(tmp_path, monkeypatch):
    """Each command in an empty working directory: afterwards only its output folder is new.

    (``figure10 --offline``, ``experiment run --offline``, ``sweep``, ``sweep similitude``:
    above; here ``figures`` and ``torque_car``, in-process with their work replaced.)
    """
    from irs_studies import paper_figures
    from irs_studies.torque_car import cli as torque_cli
    monkeypatch.chdir(tmp_path)
    seen = {}

    def reproduce(parts, img_dir, runs_dir, log=print):
        seen.update(parts=parts, img_dir=img_dir, runs_dir=runs_dir)
        runs_dir.mkdir(parents=True, exist_ok=True)
        return {}, []
    monkeypatch.setattr(paper_figures, 'reproduce', reproduce)
    assert paper_figures.main(['--runs-dir', 'fig', '--only', 'treadmill']) == 0
    assert seen == {'parts': ['treadmill'], 'img_dir': Path('fig/img'),
                    'runs_dir': Path('fig')}
    assert paper_figures.main(['--runs-dir', 'fig', '--img-dir', 'docs_img']) == 0
    assert seen['img_dir'] == Path('docs_img')
    assert tree(tmp_path) == {'fig', 'fig/figures.json'}

    monkeypatch.setattr(torque_cli, 'analyse', lambda paths, out, warn: {
        'braking': {}, 'step_steer': {'torque_step_steer_open': {}}, 'figures': [],
        'bags': {}})
    monkeypatch.setattr(torque_cli, 'step_steer_table', lambda m: '| table |')
    assert torque_cli.main(['some_run', '--out', 'tc']) == 0
    assert tree(tmp_path) == {'fig', 'fig/figures.json', 'tc', 'tc/metrics.json'}


# ------------------------------------------------------------------------ fuzzed input files
KEYS = ['name', 'description', 'clock', 'duration', 'nodes', 'record', 'surface', 'package',
        'executable', 'params', 'params_files', 'remaps', 'process', 'topics', 'scenario',
        'axes', 'values', 'range', 'set', 'seeds', 'metrics', 'plots', 'file', 'cases', 'x', 'y',
        'start', 'stop', 'num', 'kind', 'metric', 'fixed']
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(
                        ['figure10_pi', 'irs_vehicle_sim', 'vehicle_sim', '../x', '', 'lockstep',
                         'rig.x0', 'ise_norm', 'pkg://irs_vehicle_sim/config/rig.yaml',
                         'a b', '\x00']), st.text(max_size=8))
DOCS = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.dictionaries(st.one_of(st.sampled_from(KEYS), st.text(max_size=6)), inner,
                    max_size=5)), max_leaves=20)


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(doc=DOCS)
def test_fuzzed_experiment_and_sweep_files_get_their_own_one_line(tmp_path_factory, doc):
    """No fuzzed file reaches the catch-all: each gets its specific line (or runs)."""
    import contextlib
    import io

    from irs_bringup.experiment_cli import main as experiment_main
    from irs_studies.sweep.sweep_cli import main as sweep_main
    d = tmp_path_factory.mktemp('fuzz')
    f = d / 'f.yaml'
    f.write_text(yaml.safe_dump(doc, allow_unicode=True) if not isinstance(doc, str) else doc)
    for main, prog, args in ((experiment_main, 'experiment',
                              ['run', str(f), '--offline', '--duration', '0.01', '--no-plots',
                               '--runs-dir', str(d / 'runs')]),
                             (sweep_main, 'sweep', [str(f), '--serial', '--limit', '0',
                                                    '--out', str(d / 'out'), '--no-plots'])):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(args)
        text = err.getvalue()
        assert INTERNAL not in text and BUG_HINT not in text, text
        assert code == 0 or (code == 2 and text.startswith(f'{prog}: error: ')
                             and text.count('\n') == 1), (code, text)


# ------------------------------------------------------------------------ real time, runner
@pytest.mark.exclusive
def test_realtime_experiment_through_the_runner_reports_sched_fifo(tmp_path):
    res = run('irs_bringup', 'experiment', 'run', 'realtime_figure10_composed', '--duration', '3',
              '--rt-priority', '50', '--no-plots', '--runs-dir', 'runs', cwd=tmp_path,
              timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr
    report = next(ln for ln in res.stdout.splitlines() if 'SCHED_FIFO priority 50' in ln)
    print('\n' + report)
    granted = os.geteuid() == 0
    assert ('granted to 1 of 1 processes (loop)' in report) == granted, report  # + recorder
    assert 'real-time loop: ' in res.stdout and 'completed' in res.stdout
    (timing,) = (tmp_path / 'runs').glob('realtime_figure10_composed-*/timing.json')
    steps = json.loads(timing.read_text())['steps']
    assert 2900 <= steps <= 3100, steps
