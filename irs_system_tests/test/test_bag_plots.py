"""``bag plots`` and ``bag rerun`` on a small synthetic bag; clean errors on broken bags."""
import math
import subprocess

import pytest

from irs_bringup.executables import resolve_executable

N = 300
DT_NS = 1_000_000
PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


def _stamp(msg, k):
    msg.header.stamp.sec = (k * DT_NS) // 10**9
    msg.header.stamp.nanosec = (k * DT_NS) % 10**9
    msg.header.frame_id = 'treadmill'
    return msg


def make_bag(path, topics=None, clock=False, metadata=None):
    """A bag with every topic the plots and the rerun export use, N samples at 1 kHz (plus
    /clock at every step with ``clock``, as a lock-step experiment records it).
    """
    from geometry_msgs.msg import PointStamped, PoseStamped
    from rosgraph_msgs.msg import Clock
    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from irs_bag.writer import BagWriter
    from irs_msgs.msg import (BeltSpeed, LateralReference, SteeringActuatorState,
                              SteeringCommand, TreadmillState)
    from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

    geom = ArmGeometry()
    with BagWriter(path, chunk_size=64 * 1024) as w:
        if metadata is not None:
            w.add_metadata('irs_experiment', metadata)
        for k in range(N):
            t = k * DT_NS * 1e-9
            y = 0.1 * math.sin(2 * math.pi * t)
            x, psi = 0.05 * t, 0.02 * math.cos(2 * math.pi * t)
            msgs = {}
            p = _stamp(PointStamped(), k)
            p.point.x, p.point.y = x + 0.2, y
            msgs['/ground_truth/sensor_point'] = p
            p2 = _stamp(PointStamped(), k)
            p2.point.y = y + 1e-3
            msgs['/lateral_position'] = p2
            ref = _stamp(LateralReference(), k)
            ref.lateral_position = 0.1 if k > N // 3 else 0.0
            msgs['/lateral/reference'] = ref
            cmd = _stamp(SteeringCommand(), k)
            cmd.front_angle = 0.1 * math.sin(4 * math.pi * t)
            msgs['/steering/command'] = cmd
            st = _stamp(SteeringActuatorState(), k)
            st.front_commanded, st.front_achieved = cmd.front_angle, 0.9 * cmd.front_angle
            msgs['/steering/state'] = st
            belt = _stamp(BeltSpeed(), k)
            belt.speed, belt.encoder_count = 1.0 + 0.1 * t + 0.0075 * (k % 2), k
            msgs['/belt/speed'] = belt
            ts = _stamp(TreadmillState(), k)
            ts.belt_speed, ts.drive_voltage = belt.speed, 12.0
            msgs['/treadmill/state'] = ts
            od = _stamp(Odometry(), k)
            od.pose.pose.position.x, od.pose.pose.position.y = x, y
            od.pose.pose.orientation.z, od.pose.pose.orientation.w = (math.sin(psi / 2),
                                                                      math.cos(psi / 2))
            msgs['/ground_truth/odom'] = od
            ps = _stamp(PoseStamped(), k)
            ps.pose.position.x, ps.pose.position.y = x, y
            msgs['/pose'] = ps
            js = _stamp(JointState(), k)
            js.name = ['arm_joint1', 'arm_joint2', 'arm_joint3']
            js.position = list(inverse_kinematics(x, y, psi, geom))
            msgs['/arm/joint_states'] = js
            if clock:
                msgs = {'/clock': Clock(clock=js.header.stamp), **msgs}
            for topic, msg in msgs.items():
                if topics is None or topic in topics:
                    w.write(topic, _type_name(msg),
                            serialize_message(msg), 10**9 + k * DT_NS)
    return path


def test_an_extra_clock_topic_changes_nothing(small_bag, tmp_path):
    """Lock-step experiments record /clock: the Figure 10 series, the plots and the rerun
    export of such a bag are those of the same bag without it.
    """
    import numpy as np

    from irs_bag.plots import load_columns, make_plots
    from irs_bag.reader import BagReader
    from irs_bag.rerun_export import export_rrd
    from irs_bag.run_series import lateral_run

    with_clock = make_bag(tmp_path / 'with_clock', clock=True)
    with BagReader(with_clock) as r:
        assert r.topics['/clock'].message_count == N
    a, b = lateral_run(small_bag), lateral_run(with_clock)
    assert set(a) == set(b) and len(a['time']) == N
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    ca, cb = load_columns(small_bag), load_columns(with_clock)
    assert set(ca) == set(cb)
    for suffix in ca:
        for k in ca[suffix]:
            assert np.array_equal(ca[suffix][k], cb[suffix][k], equal_nan=True), (suffix, k)
    assert [p.name for p in make_plots(with_clock, tmp_path / 'p')] == \
        [p.name for p in make_plots(small_bag, tmp_path / 'q')]
    assert export_rrd(with_clock, tmp_path / 'c.rrd') == export_rrd(small_bag, tmp_path / 'd.rrd')


def _type_name(msg):
    mod = type(msg).__module__.split('.')
    return f'{mod[0]}/msg/{type(msg).__name__}'


@pytest.fixture(scope='module')
def small_bag(tmp_path_factory):
    return make_bag(tmp_path_factory.mktemp('plots') / 'bag')


def test_make_plots_writes_valid_pngs(small_bag, tmp_path):
    from irs_bag.plots import make_plots
    paths = make_plots(small_bag, tmp_path / 'out')
    assert sorted(p.name for p in paths) == ['belt.png', 'car_position.png', 'lateral.png',
                                             'steering.png']
    for p in paths:
        data = p.read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 5000, p


def test_plots_only_with_the_topics_present(tmp_path):
    from irs_bag.plots import NoPlottableTopics, make_plots
    bag = make_bag(tmp_path / 'belt_only', topics={'/belt/speed'})
    assert [p.name for p in make_plots(bag, tmp_path / 'o1')] == ['belt.png']
    empty = make_bag(tmp_path / 'no_plot_topics', topics={'/arm/joint_states'})
    with pytest.raises(NoPlottableTopics, match='none of the plotted topics'):
        make_plots(empty, tmp_path / 'o2')


def test_rerun_export_round_trip(small_bag, tmp_path):
    from irs_bag.rerun_export import ENTITY_PATHS, export_rrd, rrd_entity_paths
    rrd = tmp_path / 'run.rrd'
    rows = export_rrd(small_bag, rrd)
    assert rrd.is_file() and rrd.stat().st_size > 1000
    assert set(rows) == set(ENTITY_PATHS)
    # 2-D view decimated to 50 Hz: 0.3 s of data -> 15 rows; series at 200 Hz -> 60 rows
    assert rows['world/arm'] == 15 and rows['world/car'] == 15
    assert rows['series/lateral/ground_truth'] == 60
    assert set(ENTITY_PATHS) <= rrd_entity_paths(rrd)


def rrd_arm_strips(rrd):
    """The ``world/arm`` line strips of an .rrd file, in time order: [[(x, y, z) ...] ...]."""
    from rerun.chunk import RrdReader
    strips = []
    for c in RrdReader(str(rrd)).stream().to_chunks():
        if c.entity_path.lstrip('/') == 'world/arm':
            batch = c.to_record_batch()
            if 'time' not in batch.schema.names:      # the static colour and radius
                continue
            times = batch.column('time').cast('int64').to_pylist()
            rows = batch.column('LineStrips3D:strips').to_pylist()
            strips += [(t, row[0]) for t, row in zip(times, rows)]
    return [s for _, s in sorted(strips, key=lambda x: x[0])]


def test_arm_drawn_through_elbow_to_tip(small_bag, tmp_path):
    """The rerun export draws the arm as base -> elbow -> tip: the base at the geometry's base,
    the elbow l1 away at angle theta1, the tip where forward kinematics puts it (the car's
    position: offset 0), for every decimated joint state.
    """
    from irs_bag.reader import BagReader
    from irs_bag.rerun_export import export_rrd
    from irs_models.arm_kinematics import ArmGeometry, forward_kinematics
    geom = ArmGeometry(l1=1.1, l2=0.95, base_x=0.05, base_y=0.9)
    rrd = tmp_path / 'arm.rrd'
    rows = export_rrd(small_bag, rrd, geometry=geom)
    strips = rrd_arm_strips(rrd)
    assert len(strips) == rows['world/arm'] == 15
    with BagReader(small_bag) as r:
        joints = [js for _, js in r.decoded(['/arm/joint_states'])]
    decimated = joints[::N // 15]          # 50 Hz of 1 kHz: every 20th state
    assert len(decimated) == 15
    for strip, js in zip(strips, decimated):
        th1 = js.position[0]
        fk = forward_kinematics(*js.position, geom)
        expect = [(geom.base_x, geom.base_y, 0.0),
                  (geom.base_x + geom.l1 * math.cos(th1), geom.base_y + geom.l1 * math.sin(th1),
                   0.0),
                  (fk.x_tip, fk.y_tip, 0.0)]
        assert len(strip) == 3
        for got, want in zip(strip, expect):
            assert got == pytest.approx(want, abs=1e-5)   # float32 in the file
        # both links have their lengths: the elbow is a joint of the drawn arm
        assert math.dist(strip[0], strip[1]) == pytest.approx(geom.l1, abs=1e-5)
        assert math.dist(strip[1], strip[2]) == pytest.approx(geom.l2, abs=1e-5)


def _bag(*args):
    return subprocess.run([resolve_executable('irs_bag', 'bag'), *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def test_cli_plots_rerun_and_errors(small_bag, tmp_path):
    res = _bag('plots', small_bag, '--out', tmp_path / 'p')
    assert res.returncode == 0, res.stderr
    assert len(res.stdout.split()) == 4
    res = _bag('rerun', small_bag, '--out', tmp_path / 'r.rrd')
    assert res.returncode == 0, res.stderr
    assert (tmp_path / 'r.rrd').stat().st_size > 0

    # a truncated copy of the bag: its complete chunks are plotted/played, one warning line
    trunc = tmp_path / 'trunc'
    trunc.mkdir()
    src = next(small_bag.glob('*.mcap')).read_bytes()
    (trunc / 'trunc_0.mcap').write_bytes(src[:len(src) * 2 // 3])
    for args in (('plots', trunc, '--out', tmp_path / 'tp'),
                 ('rerun', trunc, '--out', tmp_path / 't.rrd'),
                 ('play', trunc, '--dry-run')):   # info/validate: tests/test_recorder.py
        res = _bag(*args)
        assert res.returncode == 0, (args, res.stdout, res.stderr)
        assert 'Traceback' not in res.stdout + res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert 'warning' in res.stderr and 'recovered prefix' in res.stderr, res.stderr
    assert len(list((tmp_path / 'tp').glob('*.png'))) == 4
    # not a bag: one line naming it, exit code 2, nothing written
    for args in (('plots', tmp_path / 'missing', '--out', tmp_path / 'mp'),
                 ('rerun', tmp_path / 'missing', '--out', tmp_path / 'm.rrd'),
                 ('play', tmp_path / 'missing')):
        res = _bag(*args)
        assert res.returncode == 2, (args, res.stdout, res.stderr)
        assert 'Traceback' not in res.stdout + res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert 'error' in res.stderr and str(tmp_path / 'missing') in res.stderr
    assert not (tmp_path / 'mp').exists() and not (tmp_path / 'm.rrd').exists()

    # usage errors: exit code 2
    assert _bag('plots', small_bag).returncode == 2
    assert _bag('frobnicate').returncode == 2
    res = _bag('--help')
    assert res.returncode == 0 and 'play' in res.stdout


def _lines(ax):
    return {ln.get_label(): ln for ln in ax.get_lines()}


def test_plots_show_what_matters(tmp_path):
    """Titles name the run and its controller; sensed and ground truth in distinct styles with
    the truth drawn over a translucent sensed line; the top view zoomed to the path with x and
    y on their own axes; the belt's averaged speed beside the raw encoder steps.
    """
    import json

    import numpy as np

    from irs_bag.plots import make_figures
    params = {'lateral_controller': {'mode': 'pi', 'kp': 0.5, 'ki': 2.0},
              'vehicle_sim': {'car.length': 0.5}}
    run = tmp_path / 'step_run'
    bag = make_bag(run / 'bag', metadata={'experiment_name': 'step',
                                          'node_parameters': json.dumps(params)})
    figs = make_figures(bag)
    assert set(figs) == {'lateral', 'steering', 'belt', 'car_position'}
    for fig in figs.values():
        assert fig.get_suptitle() == 'step_run | PI (kp 0.5, ki 2)'

    lat = _lines(figs['lateral'].axes[0])
    truth, sensed = lat['y_s ground truth'], lat['y_s sensed (arm)']
    assert truth.get_color() != sensed.get_color()
    assert truth.get_linewidth() > sensed.get_linewidth()
    assert truth.get_zorder() > sensed.get_zorder() and sensed.get_alpha() < 1
    assert lat['reference'].get_linestyle() == '--'

    steer = _lines(figs['steering'].axes[0])
    cmd, inp = steer['command (controller)'], steer['servo input']
    assert cmd.get_linewidth() > inp.get_linewidth() and inp.get_linestyle() == '--'

    top, ax_x, ax_y = figs['car_position'].axes
    xs = np.concatenate([ln.get_xdata() for ln in top.get_lines()[:2]])
    ys = np.concatenate([ln.get_ydata() for ln in top.get_lines()[:2]])
    (x0, x1), (y0, y1) = top.get_xlim(), top.get_ylim()
    assert x0 < xs.min() and xs.max() < x1 and y0 < ys.min() and ys.max() < y1
    span = max(np.ptp(xs), np.ptp(ys))
    assert x1 - x0 < 1.5 * span and y1 - y0 < 1.5 * span    # not the 2.44 m belt
    assert ax_x.get_ylabel() == 'x [m]' and ax_y.get_ylabel() == 'y [m]'

    speed = _lines(figs['belt'].axes[0])
    raw = speed['belt speed, encoder (raw)'].get_ydata()
    avg = speed['belt speed, 0.1 s moving average'].get_ydata()
    assert np.ptp(np.diff(raw)) > 0.01 and np.ptp(np.diff(avg)) < 0.002


def test_run_info_names_the_controller():
    from irs_bag.run_info import controller_label, run_info_from_metadata, run_name
    assert controller_label({'lateral_controller': {'mode': 'mrc'}}) == \
        'MRC with actuator model'
    assert controller_label({'lateral_controller': {'mode': 'mrc', 'include_actuator': False,
                                                    'plant': 'bicycle'}}) == \
        'MRC without actuator model, design plant bicycle'
    assert controller_label({'excitation': {}}) == 'open loop (excitation)'
    assert run_info_from_metadata('r', None).controller == 'controller unknown'
    assert run_info_from_metadata('r', {'node_parameters': 'not json'}).controller == \
        'controller unknown'
    assert run_name('runs/fig10-2026/bag') == 'fig10-2026'
    assert run_name('runs/fig10-2026/bag/bag_0.mcap') == 'fig10-2026'


def test_views_read_the_bag_once(small_bag, tmp_path, monkeypatch):
    """``experiment run``'s plots and run.rrd come from one pass over the bag's messages."""
    from irs_bag.reader import BagReader
    from irs_bag.views import write_views
    passes = []
    real = BagReader.messages

    def counted(self, *args, **kwargs):
        passes.append(args)
        return real(self, *args, **kwargs)
    monkeypatch.setattr(BagReader, 'messages', counted)
    written = write_views(small_bag, tmp_path / 'run', log=pytest.fail)
    assert sorted(p.name for p in written) == ['belt.png', 'car_position.png', 'lateral.png',
                                               'run.rrd', 'steering.png']
    assert len(passes) == 1
