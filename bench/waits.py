"""What a user waits for, timed as a user meets it: ``make demo`` on a clean clone, the paper's
figures, and (asked for) ``make test``. A section of ``bench/run.py`` (``--only waits``).

- ``make demo, clean clone``: ``git clone`` of this tree's ``HEAD`` into a temporary folder, then
  ``make demo`` there (set-up with the wheel cache as it is, colcon build, the three Figure 10
  runs); the set-up and the runs are timed apart (``make build`` first, then ``make demo``);
- ``figures``: ``irs_studies figures`` (what ``make figures`` runs) into a temporary folder, so
  that ``docs/img`` is left alone; the time of each part as the command prints it;
- ``make test`` (with ``--waits-test``): the whole suite in the clean clone after ``make demo``,
  the pytest time from pytest's own summary line.

Beside them, in the same minutes, a floor of the machine's speed for Python: the rate of a fixed
pure-Python loop (:func:`python_floor`), so that waits measured at different loads compare by
their ratio to it. Commands run with the caller's environment and their own ROS domain.
"""
import re
import subprocess
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def python_floor(seconds: float = 1.0) -> float:
    """Iterations/s of a small pure-Python float loop (a function call and three float operations
    per iteration, as the cores' scalar laws), run for about ``seconds``.
    """
    def step(x: float, u: float) -> float:
        return 0.999 * x + 0.001 * u

    n, x, t0 = 0, 0.0, time.perf_counter()
    while True:
        for _ in range(10_000):
            x = step(x, 1.0)
        n += 10_000
        elapsed = time.perf_counter() - t0
        if elapsed >= seconds:
            return n / elapsed


def _timed(cmd, cwd, log_path: Path) -> tuple[float, int, str]:
    """Run ``cmd`` in ``cwd``, its output to ``log_path``: (wall seconds, exit code, output)."""
    t0 = time.monotonic()
    with open(log_path, 'w') as log:
        rc = subprocess.call(cmd, cwd=cwd, stdout=log, stderr=subprocess.STDOUT)
    wall = time.monotonic() - t0
    return wall, rc, log_path.read_text(errors='replace')


def _row(name: str, wall: float, rc: int, **extra) -> dict:
    row = {'name': name, 'wall_s': wall, 'exit_code': rc, **extra}
    print(f'{name:40s} {wall:7.1f} s  exit {rc}', flush=True)
    return row


def waits(with_test: bool = False) -> list:
    """The rows of the section (see the module docstring)."""
    rows = [{'name': 'python floor (before)', 'iterations_per_s': python_floor()}]
    work = Path(tempfile.mkdtemp(prefix='irs_waits_'))
    clone = work / 'repo'
    subprocess.check_call(['git', 'clone', '-q', str(ROOT), str(clone)])
    commit = subprocess.check_output(['git', 'rev-parse', '--short', 'HEAD'], cwd=clone,
                                     text=True).strip()
    wall_b, rc_b, _ = _timed(['make', 'build'], clone, work / 'build.log')
    wall_d, rc_d, _ = _timed(['make', 'demo'], clone, work / 'demo.log')
    rows.append(_row(f'make demo, clean clone ({commit})', wall_b + wall_d, rc_b or rc_d,
                     setup_s=wall_b, runs_s=wall_d))
    print(f'    set-up {wall_b:.1f} s, the three Figure 10 runs {wall_d:.1f} s', flush=True)
    wall, rc, out = _timed([str(ROOT / 'irs'), 'run', 'irs_studies', 'figures',
                            '--runs-dir', str(work / 'figures'), '--img-dir',
                            str(work / 'figures' / 'img')], ROOT, work / 'figures.log')
    parts = {m.group(1): float(m.group(2)) for m in re.finditer(
        r'== (\w+)\n(?:.*\n)*?\s+done in (\d+) s', out)}
    rows.append(_row('figures (make figures)', wall, rc, parts_s=parts))
    if parts:
        print('    ' + ', '.join(f'{p} {s:.0f} s' for p, s in parts.items()), flush=True)
    if with_test:
        wall, rc, out = _timed(['make', 'test'], clone, work / 'test.log')
        found = re.findall(r'(\d+) passed.* in ([\d.]+)s', out)
        pytest_s = float(found[-1][1]) if found else float('nan')
        rows.append(_row('make test, clean clone after make demo', wall, rc, pytest_s=pytest_s,
                         passed=int(found[-1][0]) if found else 0))
    rows.append({'name': 'python floor (after)', 'iterations_per_s': python_floor()})
    print(f"python floor before/after: {rows[0]['iterations_per_s']:.3g} / "
          f"{rows[-1]['iterations_per_s']:.3g} iterations/s; logs in {work}", flush=True)
    return rows
