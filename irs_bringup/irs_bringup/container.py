"""``container``: several IRS nodes in one process on one executor (composition).

rclpy has no component container; this is its counterpart for our nodes. Each node class is
registered under its executable's name in the ``irs_components`` entry-point group of its
package's ``setup.py``, so ``vehicle_sim`` composed is the very class ``ros2 run irs_vehicle_sim
vehicle_sim`` runs alone. The nodes stay separate ROS nodes talking over topics (Fast DDS
delivers between them inside the process without the network stack); they share one
:class:`irs_common.executor.LeanExecutor`, so one thread runs every callback. Each node gets its
own ``--ros-args`` (name, parameter files, overrides, remaps), as ``ros2 run`` would give it.

Usage::

    ros2 run irs_bringup container <spec.yaml>      # (./irs run irs_bringup container ...)

with a spec file such as::

    nodes:
      - package: irs_vehicle_sim
        executable: vehicle_sim
        ros_args: [--params-file, rig.yaml, -p, 'clock_mode:=realtime']
      - package: irs_sensing
        executable: arm_pose_estimator
        ros_args: [--params-file, sensing.yaml]

The experiment runner writes such a file for every ``process:`` group of an experiment.
"""
import argparse
from importlib.metadata import entry_points
from pathlib import Path
import sys

import yaml

GROUP = 'irs_components'


class ContainerError(ValueError):
    """The spec file is unreadable or names an unknown node."""


def component_class(package: str, executable: str):
    """The Node subclass registered as ``executable`` by ``package`` (entry points)."""
    for ep in entry_points(group=GROUP, name=executable):
        if ep.value.split('.')[0] == package:
            return ep.load()
    known = sorted(f'{ep.value.split(".")[0]}/{ep.name}' for ep in entry_points(group=GROUP))
    raise ContainerError(f"no composable node '{package}/{executable}'; known: {known}")


def load_spec(path) -> list:
    """``[(package, executable, ros_args)]`` from a spec file (module docstring)."""
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ContainerError(f'{path}: {exc}') from None
    nodes = doc.get('nodes') if isinstance(doc, dict) else None
    if not isinstance(nodes, list) or not nodes:
        raise ContainerError(f'{path}: expected a non-empty list under nodes:')
    out = []
    for i, entry in enumerate(nodes):
        if not isinstance(entry, dict) or not {'package', 'executable'} <= set(entry):
            raise ContainerError(f'{path}: nodes[{i}] needs package and executable')
        args = entry.get('ros_args') or []
        if not isinstance(args, list):
            raise ContainerError(f'{path}: nodes[{i}].ros_args must be a list')
        out.append((str(entry['package']), str(entry['executable']), [str(a) for a in args]))
    return out


def main(argv=None) -> int:
    from irs_common.node_main import run_nodes
    argv = sys.argv[1:] if argv is None else argv
    own = argv[:argv.index('--ros-args')] if '--ros-args' in argv else argv
    parser = argparse.ArgumentParser(prog='container', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('spec', help='YAML file listing the nodes and their --ros-args')
    args = parser.parse_args(own)
    try:
        nodes = [(component_class(pkg, exe), ros) for pkg, exe, ros in load_spec(args.spec)]
    except ContainerError as exc:
        print(f'[FATAL] container: {exc}', file=sys.stderr)
        return 2
    factories = [lambda cls=cls, ros=ros: cls(cli_args=['--ros-args', *ros]) for cls, ros in nodes]
    global_ros_args = argv[len(own):]        # '--ros-args ...' for every node, e.g. a log level
    return run_nodes(factories, args=['container', *global_ros_args])


if __name__ == '__main__':
    sys.exit(main())
