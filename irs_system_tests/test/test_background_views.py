"""``experiment run`` makes a run's plots and ``run.rrd`` after it, in the background.

The runner returns as soon as the graph has stopped and the bag is validated, saying where the
plots will appear and which file marks them done; a test waits on that file with a deadline.
"""
import os
import re
import subprocess

from irs_bringup.executables import resolve_executable
from irs_bringup.processes import wait_until

DEADLINE = 300.0          # [s] longest wait for the background views on a loaded machine


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_the_prompt_comes_back_before_the_plots_which_then_appear(tmp_path):
    exe = resolve_executable('irs_bringup', 'experiment')
    res = subprocess.run([exe, 'run', 'figure10_pi', '--composed', '--duration', '0.5',
                          '--runs-dir', 'runs'], cwd=tmp_path, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr
    (run,) = (tmp_path / 'runs').glob('figure10_pi-*')
    done = run / 'views.done'
    assert not done.exists()          # made after the prompt (its imports alone take ~1 s)
    # the run's duration is --duration's, in the folder and in the bag (the file says 8 s)
    import json

    from irs_bag import BagReader
    result = json.loads((run / 'result.json').read_text())
    assert result['completed'] is True and result['duration'] == 0.5, result
    with BagReader(run / 'bag') as reader:
        assert dict(reader.metadata_records())['irs_experiment']['duration'] == '0.5'

    m = re.search(r'plots and run\.rrd: being made in the background \(pid (\d+)\), into '
                  r'(\S+)/ and (\S+)\n.*they are done when (\S+) exists \(log (\S+);',
                  res.stdout)
    assert m, res.stdout[-2000:]
    pid = int(m.group(1))
    assert [m.group(i) for i in (2, 3, 4, 5)] == [
        str(run / p) for p in ('plots', 'run.rrd', 'views.done', 'logs/views.log')]
    assert wait_until(done.exists, DEADLINE, interval=0.1), (run / 'logs/views.log').read_text()
    listed = done.read_text().splitlines()
    pngs = sorted(p.name for p in (run / 'plots').glob('*.png'))
    assert pngs == ['belt.png', 'car_position.png', 'lateral.png', 'steering.png']
    assert sorted(listed) == sorted([str(run / 'plots' / p) for p in pngs] +
                                    [str(run / 'run.rrd')])
    assert all((run / 'plots' / p).stat().st_size > 10000 for p in pngs)
    assert (run / 'run.rrd').stat().st_size > 10000
    assert 'views done:' in (run / 'logs/views.log').read_text()
    assert wait_until(lambda: not _alive(pid), 30.0, interval=0.1), 'views process still runs'


def test_wait_plots_makes_them_before_returning(tmp_path):
    """``--wait-plots`` (and ``run_experiment``'s default): the plots, ``run.rrd`` and
    ``views.done`` are there when it returns.
    """
    from irs_bringup.experiment_cli import build_parser, run_experiment
    assert build_parser().parse_args(['run', 'x', '--wait-plots']).wait_plots
    assert not build_parser().parse_args(['run', 'x']).wait_plots
    lines = []
    result = run_experiment('figure10_pi', runs_dir=tmp_path, deployment='composed', duration=0.5,
                            log=lines.append)
    assert result.completed, result.message
    done = result.run_dir / 'views.done'
    assert done.exists(), lines
    assert (result.run_dir / 'run.rrd').is_file()
    assert len(list((result.run_dir / 'plots').glob('*.png'))) == 4
    assert not any('in the background' in line for line in lines)


def test_start_post_process_then_finish_views_names_every_file(tmp_path):
    """The study's way (``figure10``): the run without plots, then ``start_post_process`` (the
    bag validated, the views in the background) and ``finish_views``, which waits and names the
    files as the foreground ``make_views`` does.
    """
    from irs_bag.views import finish_views
    from irs_bringup.experiment_cli import run_experiment, start_post_process
    lines = []
    result = run_experiment('figure10_pi', runs_dir=tmp_path, deployment='composed', duration=0.5,
                            log=lines.append, plots=False)
    assert result.completed, result.message
    assert not (result.run_dir / 'views.done').exists()
    proc = start_post_process(result, lines.append)
    assert lines[-1] == f'[experiment] bag: {result.bag_dir} (valid)'
    written = finish_views(proc, result.run_dir, lines.append)
    expected = sorted([result.run_dir / 'plots' / f'{p}.png'
                       for p in ('belt', 'car_position', 'lateral', 'steering')]
                      + [result.run_dir / 'run.rrd'])
    assert sorted(written) == expected and all(p.stat().st_size > 10000 for p in written)
    assert sorted(lines[-5:]) == sorted(f'[experiment] wrote {p}' for p in expected)


def test_finish_views_says_when_the_process_wrote_nothing(tmp_path):
    """A views process that ends without ``views.done``: one line with its exit code and log."""
    from irs_bag.views import DONE_FILE, LOG_FILE, finish_views
    proc = subprocess.Popen(['python3', '-c', 'raise SystemExit(3)'])
    lines = []
    assert finish_views(proc, tmp_path, lines.append) == []
    assert lines == [f'[experiment] plots and run.rrd failed: their process ended with exit code '
                     f'3 before writing {tmp_path / DONE_FILE} (log {tmp_path / LOG_FILE})']
    (tmp_path / DONE_FILE).write_text(f'{tmp_path / "a.png"}\nfailed: [experiment] plots failed: '
                                      'no data\n')
    lines.clear()
    done = subprocess.Popen(['true'])
    assert finish_views(done, tmp_path, lines.append) == [tmp_path / 'a.png']
    assert lines == [f'[experiment] wrote {tmp_path / "a.png"}',
                     '[experiment] plots failed: no data']
