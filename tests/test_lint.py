"""Linting as a test: ruff over the whole tree (one configuration, ruff.toml), ROS-free cores."""
from pathlib import Path
import re
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]


def ruff(*args, stdin=None):
    return subprocess.run([sys.executable, '-m', 'ruff', *args], cwd=ROOT, input=stdin,
                          capture_output=True, text=True, timeout=300)


def test_ruff_finds_nothing():
    """Every package, test and tool: pycodestyle at 99 columns, pyflakes, pydocstyle, quotes."""
    res = ruff('check', '--no-cache', '.')
    assert res.returncode == 0, res.stdout + res.stderr


def test_ruff_configuration_is_the_one_in_the_tree():
    """The check above can fail: ruff.toml's rules flag a bad snippet.

    A line over 99 columns, double quotes, an unused import, a class without a docstring.
    """
    bad = 'import os\n\n\nclass A:\n    x = "' + 'y' * 100 + '"\n'
    res = ruff('check', '--no-cache', '--output-format', 'concise', '--stdin-filename',
               'irs_common/irs_common/example.py', '-', stdin=bad)
    assert res.returncode == 1, res.stdout + res.stderr
    for code in ('E501', 'Q000', 'F401', 'D101'):
        assert code in res.stdout, (code, res.stdout)


def test_cores_do_not_import_rclpy():
    """Cores and libraries stay ROS-free: only nodes, the graph tools and tests import rclpy."""
    allowed = {'irs_common/irs_common/qos.py', 'irs_common/irs_common/node_main.py',
               'irs_common/irs_common/ticker.py', 'irs_common/irs_common/executor.py',
               'irs_common/irs_common/intra_process.py',
               'irs_common/irs_common/sim_time.py', 'irs_common/irs_common/time_jump.py',
               'irs_bringup/irs_bringup/graph.py',
               'irs_bringup/irs_bringup/experiment_runner.py',
               'irs_bag/irs_bag/player.py',
               'irs_system_tests/irs_system_tests/msg_echo.py',
               'irs_system_tests/irs_system_tests/service_calls.py',
               'irs_vehicle_sim/irs_vehicle_sim/recover_call.py'}
    offenders = []
    for path in ROOT.glob('irs_*/irs_*/**/*.py'):
        rel = str(path.relative_to(ROOT))
        imports_rclpy = re.search(r'^\s*(import rclpy|from rclpy)', path.read_text(), re.M)
        if imports_rclpy and rel not in allowed \
                and not rel.endswith('_node.py'):
            offenders.append(rel)
    assert not offenders, f'rclpy imported outside node wrappers: {offenders}'


def test_no_tracked_file_is_named_like_an_option():
    """A file named ``--help`` is what a tool writes when it takes an option for its output."""
    res = subprocess.run(['git', 'ls-files', '-z'], cwd=ROOT, capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    names = [p for p in res.stdout.split('\0') if p]
    assert names, 'git ls-files listed nothing'
    offenders = [p for p in names if any(part.startswith('-') for part in p.split('/'))]
    assert not offenders, offenders
