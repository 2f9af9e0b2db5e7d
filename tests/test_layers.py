"""The package layers of docs/architecture.md ("How the code is laid out"), enforced.

Every module of every ``irs_*`` package (``irs_*/irs_*/**/*.py``, not the tests) is parsed with
``ast`` and each of its imports, at any depth (a lazy import inside a function counts), is
checked against :data:`ALLOWED`: a package imports only the packages below it. Two finer rules:
``irs_models`` and the ROS-free modules of ``irs_common`` import no ROS package at all, and a
core package reaches into ``irs_common`` or ``irs_models`` only, never into another core.
Tests are not checked: a test may use a sibling core as a fixture (declared as a test_depend).
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CORES = ('irs_sensing', 'irs_treadmill', 'irs_vehicle_sim', 'irs_control')
#: package -> the IRS packages its modules may import (its own is always allowed).
ALLOWED = {
    'irs_models': set(),
    'irs_common': set(),
    **{core: {'irs_models', 'irs_common', 'irs_msgs'} for core in CORES},
    'irs_bringup': {'irs_models', 'irs_common', 'irs_msgs', *CORES},
}
#: irs_common modules that the bottom layer may lean on: no ROS import, directly or through
#: another irs_common module.
ROS_FREE_COMMON = {'answer_cache', 'field_checks', 'input_checks', 'loop_timing', 'orientation',
                   'stamp_gate', 'stamp_sync'}
#: Top-level names that are ROS: rclpy and generated interfaces. (``ament_index_python``, a
#: pure-Python lookup of installed files, is not: the presets find their YAML through it.)
ROS_PREFIXES = ('rclpy', 'rcl_interfaces', 'builtin_interfaces', 'irs_msgs')
ROS_SUFFIXES = ('_msgs', '_srvs', '_interfaces')


def imported_modules(path: Path, package_dir: tuple):
    """``(line, absolute module name)`` of every import in ``path``; ``package_dir`` is the
    module's folder as a dotted path (``('irs_bringup', 'paper')``) for relative imports.
    """
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level:
            base = package_dir[:len(package_dir) - (node.level - 1)]
            if node.module:
                out.append((node.lineno, '.'.join(base + (node.module,))))
            else:
                out += [(node.lineno, '.'.join(base + (alias.name,))) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.lineno, node.module))
    return out


def is_ros(module: str) -> bool:
    top = module.split('.')[0]
    return top.startswith(ROS_PREFIXES) or top.endswith(ROS_SUFFIXES)


def violations(root: Path) -> list:
    """Every import against the layers under ``root``, as ``'path:line: what'`` strings."""
    found = []
    for path in sorted(root.glob('irs_*/irs_*/**/*.py')):
        rel = path.relative_to(root)
        package = rel.parts[0]
        if package not in ALLOWED or rel.parts[1] != package:
            continue
        module = path.stem
        ros_free = package == 'irs_models' or (package == 'irs_common'
                                               and module in ROS_FREE_COMMON)
        for line, name in imported_modules(path, rel.parts[1:-1]):
            top = name.split('.')[0]
            where = f'{rel}:{line}'
            if top.startswith('irs_') and top != package and top not in ALLOWED[package]:
                found.append(f'{where}: {package} imports {name} (allowed: '
                             f'{sorted(ALLOWED[package]) or "no IRS package"})')
            if ros_free and is_ros(name):
                found.append(f'{where}: {package}.{module} must stay ROS-free, imports {name}')
            if ros_free and top == 'irs_common' and name.split('.')[1:2] \
                    and name.split('.')[1] not in ROS_FREE_COMMON:
                found.append(f'{where}: {package}.{module} must stay ROS-free, imports {name}')
    return found


def test_imports_follow_the_layers():
    assert violations(ROOT) == []


def test_every_package_is_in_the_table():
    packages = {p.name for p in ROOT.glob('irs_*') if (p / 'package.xml').is_file()}
    assert packages - {'irs_msgs'} == set(ALLOWED), 'add the new package to ALLOWED and the docs'


def test_a_backwards_import_is_found(tmp_path):
    """The checker itself: a simulator module importing the estimator, a model importing a core
    (lazily), a model importing rclpy and a ROS-free irs_common module importing a ROS one are
    all reported; a relative import inside a package is not.
    """
    for package, text in (('irs_vehicle_sim', 'from irs_sensing.pose_estimator import x\n'),
                          ('irs_models', 'def f():\n    import irs_control.metrics\n'),
                          ('irs_common', 'from . import stamp_sync\n')):
        (tmp_path / package / package).mkdir(parents=True, exist_ok=True)
        (tmp_path / package / package / 'mod.py').write_text(text)
    (tmp_path / 'irs_models' / 'irs_models' / 'ros.py').write_text('import rclpy\n')
    (tmp_path / 'irs_common' / 'irs_common' / 'orientation.py').write_text(
        'from .params import Param\n')
    found = violations(tmp_path)
    assert len(found) == 4, found
    assert any('irs_vehicle_sim imports irs_sensing.pose_estimator' in f for f in found)
    assert any('irs_models imports irs_control.metrics' in f for f in found)
    assert any('must stay ROS-free, imports rclpy' in f for f in found)
    assert any('orientation must stay ROS-free, imports irs_common.params' in f for f in found)
