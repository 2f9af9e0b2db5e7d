"""The sweep tool: Dask equals one by one, resume, Monte Carlo draws, bad files.

Short on purpose: points of 0.4 s of simulated time (400 closed-loop steps each, the step at
0.1 s).
"""
import math
from pathlib import Path
import subprocess
import sys

import pytest
import yaml

from irs_studies.sweep import results
from irs_studies.sweep.axes import sweep_points
from irs_studies.sweep.point import run_point
from irs_studies.sweep.runner import prepare, run_sweep
from irs_studies.sweep.sweep_cli import write_outputs
from irs_studies.sweep.sweep_file import SweepError, load_sweep

SMALL = """\
name: small
description: test sweep
scenario: figure10_mrc_with_actuator
duration: 0.4
fixed: {reference.signal.start_time: 0.1, rig.actuator_front.enable_radio_frame: false}
axes:
  - name: design
    cases:
      with: {controller.include_actuator: true}
      pi: {controller.mode: pi}
  - name: delay_ms
    unit: ms
    values: [0.0, 40.0]
    set: {rig.actuator_front.delay: 0.001}
  - name: gain_factor
    uniform: {low: 0.8, high: 1.2}
    set: {rig.identified.gain: 12.530842}
seeds: [3, 4]
metrics: [ise_norm, peak_steer_cmd_deg, off_belt, stable, phase_margin_deg]
plots:
  - {kind: heatmap, x: delay_ms, y: design, metric: peak_steer_cmd_deg}
  - {kind: boundary, x: delay_ms, y: seed, metric: stable, threshold: 0.5, facet: design}
"""


def _same(a, b):
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a)
                      and math.isnan(b))


def _rows_equal(xs, ys):
    assert [r['point'] for r in xs] == [r['point'] for r in ys]
    for x, y in zip(xs, ys):
        diff = {k: (x[k], y[k]) for k in x if not _same(x[k], y.get(k))}
        assert not diff, f"{x['point']}: {diff}"


@pytest.fixture(scope='module')
def small(tmp_path_factory):
    d = tmp_path_factory.mktemp('sweep')
    (d / 'small.yaml').write_text(SMALL)
    sweep, path = load_sweep(str(d / 'small.yaml'))
    return prepare(sweep, path), d


@pytest.fixture(scope='module')
def one_by_one(small):
    prep, _ = small
    return [run_point(prep.cfg, prep.duration, p, list(prep.sweep.metrics)) for p in prep.points]


def test_points_and_monte_carlo_draws(small):
    prep, _ = small
    pts = prep.points
    assert len(pts) == 2 * 2 * 2                     # design x delay x seeds (MC axis: no x)
    assert [p['point'] for p in pts] == [p['point'] for p in sweep_points(prep.sweep)]
    draws = {p['seed']: p['gain_factor'] for p in pts}
    assert all(0.8 <= v < 1.2 for v in draws.values()) and draws[3] != draws[4]
    for p in pts:   # the draw depends on the seed only, and reaches the rig
        assert p['gain_factor'] == draws[p['seed']]
        assert p['overrides']['rig.identified.gain'] == pytest.approx(12.530842 * draws[p['seed']])
        assert p['overrides']['rig.seed'] == p['seed']


def test_dask_two_workers_equals_one_by_one(small, one_by_one, tmp_path):
    prep, _ = small
    assert not any(r['error'] for r in one_by_one), one_by_one
    rows = run_sweep(prep, tmp_path / 'dask', workers=2, log=lambda s: None)
    _rows_equal(rows, one_by_one)
    _rows_equal(results.read_results(tmp_path / 'dask'), one_by_one)
    # the axes did something: the 40 ms delay changes the response and the margin
    by = {(r['design'], r['delay_ms'], r['seed']): r for r in rows}
    assert by['with', 40.0, 3]['phase_margin_deg'] < by['with', 0.0, 3]['phase_margin_deg']
    assert by['with', 40.0, 3]['peak_steer_cmd_deg'] != by['with', 0.0, 3]['peak_steer_cmd_deg']


def test_resume_skips_points_already_done(small, one_by_one, tmp_path):
    prep, _ = small
    out = tmp_path / 'resume'
    first = run_sweep(prep, out, serial=True, limit=3, log=lambda s: None)
    assert len(first) == 3
    # a marker in the kept rows: a resumed run must not recompute (and overwrite) them
    kept = results.read_parts(out)
    for f in results.parts_dir(out).glob('*.parquet'):
        f.unlink()
    results.write_part(out, [{**r, 'error': 'kept'} for r in kept])
    rows = run_sweep(prep, out, serial=True, log=lambda s: None)
    assert len(rows) == len(prep.points)
    assert sum(r['error'] == 'kept' for r in rows) == 3
    _rows_equal([{**r, 'error': ''} for r in rows], one_by_one)


def test_summary_and_plots(small, one_by_one, tmp_path):
    prep, _ = small
    written = write_outputs(one_by_one, prep.sweep, tmp_path, log=lambda s: None)
    assert [p.name for p in written] == ['summary.md', 'sweep_small_peak_steer_cmd_deg.png',
                                         'sweep_small_stable.png']
    assert all(p.stat().st_size > 10000 for p in written[1:])
    text = (tmp_path / 'summary.md').read_text()
    assert '## peak_steer_cmd_deg [deg]' in text and '| design \\ delay_ms | 0 | 40 |' in text


def test_refused_point_is_a_row_not_a_crash(small):
    prep, _ = small
    p = dict(prep.points[0])
    p['overrides'] = {**p['overrides'], 'controller.actuator_pole': -1.0}
    row = run_point(prep.cfg, prep.duration, p, ['ise_norm', 'stable'])
    assert 'actuator_pole' in row['error'] and math.isnan(row['ise_norm'])


def test_a_sine_reference_has_no_step_metrics_but_keeps_its_margins(small):
    """The step metrics refuse a reference that is no step (the reason is in ``error``); the
    point's linear metrics and ``off_belt`` are measured all the same.
    """
    prep, _ = small
    p = dict(prep.points[0])
    p['overrides'] = {**p['overrides'], 'reference.signal.type': 'sine',
                      'reference.signal.period': 0.2}
    row = run_point(prep.cfg, prep.duration, p, ['ise_norm', 'stable', 'phase_margin_deg',
                                                  'off_belt'])
    assert 'the reference is no step' in row['error'] and math.isnan(row['ise_norm']), row
    assert row['stable'] == 1.0 and row['phase_margin_deg'] > 10 and row['off_belt'] == 0.0


def _set(key, value):
    def change(doc):
        doc[key] = value
        if key in ('axes', 'metrics'):
            doc.pop('plots')       # the plots name the original axes and metrics
    return change


def _axis(**axis):
    return _set('axes', [{'name': 'x', **axis}])


BAD = [
    (_set('metrics', ['ise_norm', 'wobble']), 'unknown metric'),
    (_set('axes', []), 'axes'),
    (_axis(values=[1.0], set={'vehicle.x0': 1.0}), 'expected <node>.<parameter>'),
    (_axis(values=[1.0], set={'rig.no_such': 1.0}), "has no parameter 'no_such'"),
    (_axis(values=[1.0]), "'set' must name"),
    (_axis(values=[1.0], range={'start': 0, 'stop': 1, 'num': 2}, set={'rig.x0': 1.0}),
     'exactly one of'),
    (_axis(log_range={'start': 0, 'stop': 1, 'num': 2}, set={'rig.x0': 1.0}), 'start > 0'),
    (_axis(values=[1.0], set={'driver.x': 1.0}), 'has no driver node'),
    (_axis(values=[1.0], set={'rig.x0': 1.0}, wobble=1), 'wobble'),
    (_set('scenario', 'no_such_experiment'), "no experiment 'no_such_experiment'"),
    (_set('seeds', 0), 'seed count'),
    (_set('seeds', True), 'seed'),
    (_set('duration', -1.0), 'duration'),
    (_set('name', '../x'), 'plain name'),
    ('metrics: [ise_norm', 'not valid YAML'),
]


@pytest.mark.parametrize('change,expected', BAD)
def test_bad_sweep_file_one_line(tmp_path, change, expected):
    f = tmp_path / 'bad.yaml'
    if isinstance(change, str):
        f.write_text(change)
    else:
        doc = yaml.safe_load(SMALL)
        change(doc)
        f.write_text(yaml.safe_dump(doc))
    with pytest.raises(SweepError) as err:
        sweep, path = load_sweep(str(f))
        prepare(sweep, path)
    assert expected in str(err.value) and '\n' not in str(err.value), str(err.value)


def test_cli_bad_input_one_line(tmp_path):
    f = tmp_path / 'bad.yaml'
    f.write_text(SMALL.replace('ise_norm,', 'wobble,'))
    for args in ([str(f)], [str(tmp_path / 'missing.yaml')], [str(f), '--workers', '0']):
        p = subprocess.run([sys.executable, '-m', 'irs_studies.sweep.sweep_cli', *args,
                            '--out', str(tmp_path / 'o')], capture_output=True, text=True,
                           timeout=120)
        assert p.returncode == 2, p
        assert p.stderr.startswith('sweep: ') and p.stderr.count('\n') == 1, p.stderr
        assert 'Traceback' not in p.stderr


def test_results_of_another_sweep_file_refused(small, tmp_path):
    _, d = small
    out = tmp_path / 'o'
    out.mkdir()
    (out / 'sweep.yaml').write_text('name: other\n')
    p = subprocess.run([sys.executable, '-m', 'irs_studies.sweep.sweep_cli',
                        str(Path(d) / 'small.yaml'), '--out', str(out), '--serial'],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and 'different sweep file' in p.stderr, p


def test_similitude_cli_compares_eq6_with_eq7_10_in_dimensionless_form(tmp_path, capsys):
    """The table of Eq. 6 and Eqs. 7-10 as s L/V with the equal-L/V and Froude speeds, and the
    three figures.
    """
    import argparse

    import matplotlib.image as mpimg

    from irs_studies.sweep import similitude_cli
    args = argparse.Namespace(scale='irs_2wd', speed=1.2, out=tmp_path)
    assert similitude_cli.run(args) == 0
    out = capsys.readouterr().out
    assert '| Eq. 6 (IRS 1:10) | 1.2 | 0.300 | 0.250 | 1.10 | -2.00, -5.00 | -0.60, -1.20 |' in out
    assert '| Eq. 7 (full_size_sedan) | 12 | 2.865 | 0.239 | 0.00 | -1.46, -1.20 |' in out
    assert '| 1.26 | 3.88 |' in out        # equal-L/V and Froude speeds of the 0.30 m car
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ['similitude_eq6_eq7_10.png', 'sweep_similitude_speed.png',
                     'sweep_similitude_step.png']
    h, w = mpimg.imread(tmp_path / 'similitude_eq6_eq7_10.png').shape[:2]
    assert h > 400 and w > 1000
