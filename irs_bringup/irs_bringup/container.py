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

with a spec file listing each node's package, executable and ``--ros-args`` (format:
:func:`load_spec`); the experiment runner writes one for every ``process:`` group.
"""
import argparse
from importlib.metadata import entry_points
from pathlib import Path
import sys

import yaml

from irs_common import yaml_io
from irs_common.cli import (BUG_HINT, EXIT_BUG, InputError, Interrupted, SignalGuard, did_you_mean,
                            one_line, plain_text)

GROUP = 'irs_components'


class ContainerError(InputError):
    """The spec file is unreadable, names an unknown node, or two nodes of one name."""


def _entry_point(package: str, executable: str):
    """The entry point of ``package/executable`` in :data:`GROUP` (its module not imported)."""
    for ep in entry_points(group=GROUP, name=executable):
        if ep.value.split('.')[0] == package:
            return ep
    known = [f'{ep.value.split(".")[0]}/{ep.name}' for ep in entry_points(group=GROUP)]
    raise ContainerError(did_you_mean(f'{package}/{executable}', known, 'composable node'))


def component_class(package: str, executable: str):
    """The Node subclass registered as ``executable`` by ``package`` (entry points)."""
    return _entry_point(package, executable).load()


def _node_name(executable: str, ros_args: list) -> str:
    """The node's name: its ``-r __node:=<name>`` remap, else the executable's name (every IRS
    node is named after its executable).
    """
    for i, arg in enumerate(ros_args[:-1]):
        if arg in ('-r', '--remap') and ros_args[i + 1].startswith('__node:='):
            return ros_args[i + 1].split(':=', 1)[1]
    return executable


def _resolve(ref: str, base: Path) -> Path:
    """A file the spec names: ``pkg://<package>/<path>``, or a path relative to ``base``."""
    from .experiment_schema import resolve_params_ref
    if not ref.startswith('pkg://') and not Path(ref).is_absolute():
        ref = str(base / ref)
    try:
        return resolve_params_ref(ref)
    except ValueError as exc:
        raise ContainerError(str(exc)) from None


def _resolve_files(args: list, base: Path) -> list:
    """``args`` with the file after each ``--params-file`` resolved (:func:`_resolve`)."""
    return [str(_resolve(a, base)) if i and args[i - 1] == '--params-file' else a
            for i, a in enumerate(args)]


def load_spec(path) -> list:
    """``[(package, executable, ros_args)]`` from a spec file; every node
    registered in :data:`GROUP`, no two with one name.

    A spec file::

        nodes:
          - package: irs_vehicle_sim
            executable: vehicle_sim
            ros_args: [--params-file, rig.yaml, -p, 'clock_mode:=realtime']
          - package: irs_sensing
            executable: arm_pose_estimator
            ros_args: [--params-file, sensing.yaml]

    A parameter file given as ``pkg://<package>/<path>`` is taken from that package's share
    directory, a relative path from the spec's directory; the spec itself may be a ``pkg://``
    reference too (``container pkg://irs_bringup/config/realtime_loop.yaml`` is the Figure 10 loop
    in real time). The experiment runner writes such a file for every ``process:`` group of an
    experiment.
    """
    if str(path).startswith('pkg://'):
        path = _resolve(str(path), Path.cwd())
    try:
        doc = yaml_io.safe_load(Path(path).read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ContainerError(f'{path}: {" ".join(str(exc).split())}') from None
    nodes = doc.get('nodes') if isinstance(doc, dict) else None
    if not isinstance(nodes, list) or not nodes:
        raise ContainerError(f'{path}: expected a non-empty list under nodes:')
    out, names = [], {}
    for i, entry in enumerate(nodes):
        if not isinstance(entry, dict) or not {'package', 'executable'} <= set(entry):
            raise ContainerError(f'{path}: nodes[{i}] needs package and executable')
        args = entry.get('ros_args') or []
        if not isinstance(args, list):
            raise ContainerError(f'{path}: nodes[{i}].ros_args must be a list')
        package, executable = str(entry['package']), str(entry['executable'])
        try:
            args = _resolve_files([str(a) for a in args], Path(path).parent)
            _entry_point(package, executable)
        except ContainerError as exc:
            raise ContainerError(f'{path}: nodes[{i}]: {exc}') from None
        name = _node_name(executable, args)
        if name in names:
            raise ContainerError(f"{path}: nodes[{i}] and nodes[{names[name]}] are both named "
                                 f"'{name}': give one another name (ros_args: -r __node:=...)")
        names[name] = i
        out.append((package, executable, args))
    return out


class _Factory:
    """Builds one node of the spec: its class loaded when called (in ``run_nodes``)."""

    def __init__(self, package, executable, ros_args):
        self.package, self.executable = package, executable
        self.ros_args = ['--ros-args', *ros_args]

    def __call__(self):
        return component_class(self.package, self.executable)(cli_args=self.ros_args)


def main(argv=None) -> int:
    guard = SignalGuard()
    try:
        guard.install()                  # a signal from the first line on: no traceback
        argv = sys.argv[1:] if argv is None else argv
        own = argv[:argv.index('--ros-args')] if '--ros-args' in argv else argv
        parser = argparse.ArgumentParser(prog='container', description=plain_text(__doc__),
                                         formatter_class=argparse.RawDescriptionHelpFormatter)
        parser.add_argument('spec', help='YAML file listing the nodes and their --ros-args')
        args = parser.parse_args(own)
        try:
            factories = [_Factory(*node) for node in load_spec(args.spec)]
        except ContainerError as exc:
            print(f'[FATAL] container: {exc}', file=sys.stderr)
            return 2
        from irs_common.node_main import run_nodes
        global_ros_args = argv[len(own):]    # '--ros-args ...' for every node, e.g. a log level
    except Interrupted:
        guard.restore()
        return 0
    except Exception as exc:  # noqa: BLE001 -- the catch-all of the container's own start
        print(f'[FATAL] container: internal error: {type(exc).__name__}: {one_line(exc)[:300]}; '
              f'{BUG_HINT}', file=sys.stderr)
        return EXIT_BUG
    return run_nodes(factories, args=['container', *global_ros_args], guard=guard)


if __name__ == '__main__':
    sys.exit(main())
