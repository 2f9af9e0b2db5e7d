"""Every node resolves through the ament index as ``ros2 run`` does, joins the graph, exits 0.

``ros2 run <pkg> <exe>`` = ament index prefix of <pkg> + ``lib/<pkg>/<exe>``. We resolve it the
same way here with ``ament_index_python`` directly (not through our own resolver) and compare.
"""
import os
import subprocess

from ament_index_python.packages import get_package_prefix, get_packages_with_prefixes
import pytest

from irs_bringup.executables import resolve_executable
from irs_bringup.processes import NodeSpec

NODES = [  # package, executable, node name, extra parameters to start it standalone
    ('irs_vehicle_sim', 'vehicle_sim', 'vehicle_sim', {}),
    ('irs_sensing', 'arm_pose_estimator', 'arm_pose_estimator', {}),
    ('irs_treadmill', 'treadmill_regulator', 'treadmill_regulator', {}),
    ('irs_control', 'lateral_controller', 'lateral_controller', {}),
    ('irs_control', 'reference_generator', 'reference_generator', {}),
    ('irs_bringup', 'driver', 'driver', {}),
    ('irs_bag', 'recorder', 'recorder', {}),
]
TOOLS = [('irs_vehicle_sim', 'vehicle_tf'), ('irs_control', 'rst_design'),
         ('irs_bringup', 'experiment'), ('irs_bag', 'bag')]
PACKAGES = ['irs_msgs', 'irs_common', 'irs_sensing', 'irs_treadmill', 'irs_vehicle_sim',
            'irs_control', 'irs_bringup']


def ros2_run_path(package, executable):
    """What ros2run does: the package prefix from the ament index, then lib/<package>/<exe>."""
    return os.path.join(get_package_prefix(package), 'lib', package, executable)


def test_every_package_is_in_the_ament_index():
    indexed = get_packages_with_prefixes()
    for pkg in PACKAGES:
        assert pkg in indexed, f'{pkg} missing from the ament index'
        assert os.path.isfile(os.path.join(indexed[pkg], 'share', pkg, 'package.xml'))


@pytest.mark.parametrize('package,executable', [n[:2] for n in NODES] + TOOLS)
def test_executable_resolves_like_ros2_run(package, executable):
    path = ros2_run_path(package, executable)
    assert os.path.isfile(path) and os.access(path, os.X_OK), path
    assert resolve_executable(package, executable) == path


@pytest.mark.parametrize('package,executable', TOOLS)
def test_tool_help_exits_zero(package, executable):
    res = subprocess.run([ros2_run_path(package, executable), '--help'], capture_output=True,
                         text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert 'usage' in res.stdout.lower()


@pytest.mark.parametrize('package,executable,name,params', NODES,
                         ids=[n[1] for n in NODES])
def test_node_joins_graph_and_exits_cleanly_on_sigint(ros, launch, package, executable, name,
                                                      params):
    proc = launch(NodeSpec(package, executable, params=params))
    assert proc.cmd[0] == ros2_run_path(package, executable)
    joined = ros.wait_for_nodes([name], timeout=30.0)
    assert joined, f'{name} did not join the graph; output:\n{proc.tail()}'
    assert proc.poll() is None, f'{name} died:\n{proc.tail()}'
    code = proc.stop(timeout=15.0)
    out = proc.output()
    assert code == 0, f'{name} exited with {code}:\n{out[-3000:]}'
    assert 'Traceback' not in out, out[-3000:]
