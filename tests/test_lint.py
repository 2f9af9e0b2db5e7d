"""Linting as a test: pyflakes over every package, test and tool (unused imports, undefined names)."""
from pathlib import Path
import re
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]
TREES = ['irs_common', 'irs_models', 'irs_sensing', 'irs_treadmill', 'irs_vehicle_sim', 'irs_control',
         'irs_bringup', 'tests']


def test_pyflakes_finds_nothing():
    res = subprocess.run([sys.executable, '-m', 'pyflakes', *TREES], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr


def test_cores_do_not_import_rclpy():
    """Cores and libraries stay ROS-free: only node modules, the graph tools and tests import rclpy."""
    allowed = {'irs_common/irs_common/qos.py', 'irs_common/irs_common/node_main.py',
               'irs_common/irs_common/ticker.py', 'irs_common/irs_common/executor.py',
               'irs_common/irs_common/sim_time.py', 'irs_common/irs_common/time_jump.py',
               'irs_bringup/irs_bringup/run/graph.py',
               'irs_bringup/irs_bringup/run/experiment_runner.py', 'irs_bringup/irs_bringup/bag/recorder_node.py',
               'irs_bringup/irs_bringup/bag/bag_play.py', 'irs_bringup/irs_bringup/bag/bench_replay.py'}
    offenders = []
    for path in ROOT.glob('irs_*/irs_*/**/*.py'):
        rel = str(path.relative_to(ROOT))
        imports_rclpy = re.search(r'^\s*(import rclpy|from rclpy)', path.read_text(), re.M)
        if imports_rclpy and rel not in allowed \
                and not rel.endswith('_node.py'):
            offenders.append(rel)
    assert not offenders, f'rclpy imported outside node wrappers: {offenders}'
