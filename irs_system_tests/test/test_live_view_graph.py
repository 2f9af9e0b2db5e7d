"""``experiment run --view``: the live_view node streams a running graph to a rerun sink."""
import signal
import socket
import subprocess
from pathlib import Path

import numpy as np

from irs_bag.columns import read_columns
from irs_bag.rerun_entities import ENTITY_PATHS
from irs_bringup.experiment_cli import DEFAULT_VIEW_URL, run_experiment
from irs_system_tests.child_signals import default_signals, ignored_signals

DURATION = 3.0           # [s] simulated (lock-step)


def _entity(rrd, path, column):
    """``(time [s], values)`` of one entity's temporal rows in an .rrd file."""
    from rerun.chunk import RrdReader
    t, v = [], []
    for c in RrdReader(str(rrd)).stream().to_chunks():
        if c.entity_path.lstrip('/') != path or c.is_static:
            continue
        batch = c.to_record_batch()
        t += [x.total_seconds() for x in batch.column('time').to_pylist()]
        v += [row[0] for row in batch.column(column).to_pylist()]
    order = np.argsort(t)
    return np.asarray(t)[order], np.asarray(v)[order]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def start_rerun_server(port: int, save: Path) -> subprocess.Popen:
    """``rerun --port P --save FILE``: the viewer's receiving end, headless.

    The binary itself, not the ``rerun`` console script (a Python wrapper that turns a SIGINT
    into a SIGKILL of the binary), with the default signal dispositions whatever this test run
    inherited (:mod:`irs_system_tests.child_signals`).
    """
    import rerun_cli
    exe = Path(rerun_cli.__file__).with_name('rerun')
    return subprocess.Popen([str(exe), '--port', str(port), '--save', str(save)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            preexec_fn=default_signals)


def stop_rerun_server(sink, timeout: float = 30.0) -> None:
    """SIGINT: the server stops (its file holds what it received); not within ``timeout``
    [s]: killed, and the test fails naming the signals it ignored.
    """
    sink.send_signal(signal.SIGINT)
    try:
        sink.wait(timeout=timeout)
        return
    except subprocess.TimeoutExpired:
        ignored = ignored_signals(sink.pid)
        sink.kill()
        sink.wait()
    raise AssertionError(f'rerun server still running {timeout} s after SIGINT '
                         f'(ignored: {sorted(ignored)})')


def test_the_rerun_server_stops_on_sigint_when_the_test_run_ignores_it(tmp_path):
    """A test run started with SIGINT ignored (a background job of a non-interactive shell,
    ``nohup``) still stops its rerun server with SIGINT.
    """
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        sink = start_rerun_server(_free_port(), tmp_path / 'idle.rrd')
    finally:
        signal.signal(signal.SIGINT, old)
    try:
        assert 'SIGINT' not in ignored_signals(sink.pid)
    finally:
        stop_rerun_server(sink, timeout=20.0)
    assert sink.returncode == -signal.SIGINT


def test_view_streams_the_entities_of_run_rrd_while_the_graph_runs(tmp_path):
    """A lock-step Figure 10 run with ``--view <url>`` streaming over gRPC to a rerun server
    (``rerun --port P --save live.rrd``: the viewer's receiving end, headless): the live
    recording holds every entity of run.rrd, series rows from the run's start at no more than
    100 Hz (one message in 10 of the 1 kHz topics; best effort may lose some, how many is a
    bench figure), and its lateral values are the bag's own.
    """
    from irs_bag.live_view_params import DEFAULT_URL, TOPICS
    assert DEFAULT_VIEW_URL == DEFAULT_URL
    live, port = tmp_path / 'live.rrd', _free_port()
    sink = start_rerun_server(port, live)
    try:
        result = run_experiment('figure10_mrc_with_actuator', runs_dir=tmp_path,
                                duration=DURATION, view=f'rerun+http://127.0.0.1:{port}/proxy',
                                view_topics=TOPICS,
                                log=lambda *_: None)
    finally:
        stop_rerun_server(sink)
    assert result.completed, result.message
    assert result.exit_codes.get('live_view') == 0, result.exit_codes
    assert (result.run_dir / 'run.rrd').is_file()
    from irs_bag.rerun_export import rrd_entity_paths
    assert set(ENTITY_PATHS) <= rrd_entity_paths(live)
    assert rrd_entity_paths(result.run_dir / 'run.rrd') <= rrd_entity_paths(live) | {'world',
                                                                                       ''}
    t, y = _entity(live, 'series/lateral/ground_truth', 'Scalars:scalars')
    # How much of a best-effort stream a loaded machine delivers is a bench figure
    # (bench/live_view.py); here: rows from the start on, at most the decimated rate.
    assert 20 <= len(t) <= DURATION * 100 + 2, len(t)
    assert 0.0 <= t[0] and t[-1] <= DURATION + 1e-9
    bag_y = read_columns(result.bag_dir, {'ground_truth/sensor_point': {'y': 'point.y'}})
    by = bag_y['ground_truth/sensor_point']['y']
    assert set(y) <= set(by)           # exact: CDR doubles
    # The view follows the car, not a constant, from the start: the runner starts the run once
    # the view's subscriptions have matched, so its first value is one of the bag's first rows
    # (best effort may still lose a few), and the part it saw holds the step. The part is found
    # by value: the bag's rows from the view's first value to its last.
    first, last = np.flatnonzero(by == y[0])[0], np.flatnonzero(by == y[-1])[-1]
    assert first < 100, f'the view saw the run from row {first} on'
    assert last > 1000 and np.ptp(by[first:last + 1]) > 0.002    # past the step at 0.5 s
    assert np.ptp(y) >= 0.5 * np.ptp(by[first:last + 1])
    tc, _ = _entity(live, 'world/car', 'Boxes3D:centers')
    assert 10 <= len(tc) <= DURATION * 30 + 10, len(tc)


def test_view_with_offline_or_a_bad_url_is_refused_in_one_line(capsys):
    import pytest
    from irs_bringup.experiment_cli import main
    with pytest.raises(SystemExit) as info:
        main(['run', 'figure10_pi', '--offline', '--view'])
    assert info.value.code == 2
    assert '--offline runs no graph' in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(['run', 'figure10_pi', '--view', 'localhost:9876'])
    assert info.value.code == 2
    assert 'neither a rerun URL' in capsys.readouterr().err
    with socket.socket() as idle:            # a port bound but not listening: no viewer
        idle.bind(('127.0.0.1', 0))
        port = idle.getsockname()[1]
        with pytest.raises(SystemExit) as info:
            main(['run', 'figure10_pi', '--view', f'rerun+http://127.0.0.1:{port}/proxy'])
    assert info.value.code == 2
    assert f'no rerun viewer listens at 127.0.0.1:{port}' in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(['run', 'figure10_pi', '--view-topics', 'pose'])
    assert info.value.code == 2
    assert '--view-topics needs --view' in capsys.readouterr().err


def test_view_argument_picks_a_url_or_a_file(tmp_path):
    """``--view`` alone: rerun's default URL; a value ending in .rrd: a file for ``save``."""
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_cli import build_parser
    from irs_bringup.experiment_runner import ExperimentRunner
    args = build_parser().parse_args(['run', 'figure10_pi', '--view'])
    assert args.view == DEFAULT_VIEW_URL
    assert build_parser().parse_args(['run', 'figure10_pi']).view is None
    exp = load_experiment('figure10_pi')
    spec = ExperimentRunner(exp, runs_dir=tmp_path, view='x/live.rrd')._view_spec()
    assert (spec.package, spec.executable) == ('irs_bag', 'live_view')
    assert spec.params['save'] == str(Path('x/live.rrd').resolve())     # the runner's cwd
    assert 'url' not in spec.params
    spec = ExperimentRunner(exp, runs_dir=tmp_path, view=DEFAULT_VIEW_URL)._view_spec()
    assert spec.params['url'] == DEFAULT_VIEW_URL and 'save' not in spec.params
    assert 'topics' not in spec.params                     # the node's default: all
    args = build_parser().parse_args(['run', 'figure10_pi', '--view', '--view-topics',
                                      'ground_truth/odom, steering/state'])
    assert args.view_topics == ['ground_truth/odom', 'steering/state']
    spec = ExperimentRunner(exp, runs_dir=tmp_path, view=DEFAULT_VIEW_URL,
                            view_topics=args.view_topics)._view_spec()
    assert spec.params['topics'] == ['ground_truth/odom', 'steering/state']


def _last_static(rrd, path, column):
    """The value of the last static chunk of an entity's component in an .rrd file."""
    from rerun.chunk import RrdReader
    last = None
    for c in RrdReader(str(rrd)).stream().to_chunks():
        if c.entity_path.lstrip('/') == path and c.is_static:
            batch = c.to_record_batch()
            if column in batch.schema.names:
                last = batch.column(column).to_pylist()[0]
    return last


def test_a_view_started_by_hand_draws_the_car_and_arm_of_the_rig_beside_it(launch, tmp_path):
    """``live_view`` started by hand (no ``metadata``) asks ``vehicle_sim`` for its parameters
    and logs the static entities again with its car size and arm base; the defaults first.
    """
    from irs_bag.run_info import CAR_LENGTH, CAR_WIDTH
    from irs_bringup.processes import NodeSpec, wait_until

    rig = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                          params={'clock_mode': 'lockstep', 'car.length': 0.6,
                                  'car.width': 0.3, 'arm.base_x': 0.05}))
    live = tmp_path / 'live.rrd'
    view = launch(NodeSpec('irs_bag', 'live_view', params={'save': str(live)}))
    assert wait_until(lambda: '/vehicle_sim answered' in view.output(), 60.0), \
        view.tail() + '\n' + rig.tail()
    assert view.stop() == 0, view.tail()
    assert 'car 0.6 x 0.3 m' in view.output(), view.tail()
    from rerun.chunk import RrdReader
    sizes = [c.to_record_batch().column('Boxes3D:half_sizes').to_pylist()[0]
             for c in RrdReader(str(live)).stream().to_chunks()
             if c.entity_path.lstrip('/') == 'world/car' and c.is_static
             and 'Boxes3D:half_sizes' in c.to_record_batch().schema.names]
    assert [[round(v, 6) for v in s[0]] for s in sizes] == [
        [CAR_LENGTH / 2, CAR_WIDTH / 2, 0.01], [0.3, 0.15, 0.01]], sizes
    base = _last_static(live, 'world/arm/base', 'Points3D:positions')
    from irs_models.arm_kinematics import ArmGeometry
    assert ArmGeometry().base_x != 0.05
    assert [round(v, 6) for v in base[0]] == [0.05, round(ArmGeometry().base_y, 6), 0.0], base


def test_a_view_started_by_hand_with_no_viewer_says_so_in_one_line(launch):
    """``live_view`` started by hand to a URL where nothing listens warns once, as it starts
    (before rerun's connect, which takes 5 s then), naming the port and what to do; rerun itself
    stays silent until the end of the run.
    """
    from irs_bringup.processes import NodeSpec, wait_until
    with socket.socket() as idle:            # a port bound but not listening: no viewer
        idle.bind(('127.0.0.1', 0))
        port = idle.getsockname()[1]
        view = launch(NodeSpec('irs_bag', 'live_view',
                               params={'url': f'rerun+http://127.0.0.1:{port}/proxy'}))
        assert wait_until(lambda: 'no rerun viewer' in view.output(), 60.0), view.tail()
    said = [ln for ln in view.output().splitlines() if 'no rerun viewer' in ln]
    assert len(said) == 1 and said[0].startswith('[WARN]'), view.tail()
    assert f'127.0.0.1:{port}' in said[0] and 'save:=' in said[0], said
    view.signal_group(signal.SIGKILL)    # (rerun would wait 5 s for a viewer at the exit)
