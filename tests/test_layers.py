"""The layers of docs/architecture.md ("How the code is laid out"), enforced at module level.

Every module of every ``irs_*`` package (``irs_*/irs_*/**/*.py``, not the tests) and of
``bench/`` is parsed with ``ast``; every import, at any depth (a lazy import inside a function
counts), is an arrow from that module to the module it names. Three rules hold:

1. **Packages import only the packages below them** (:data:`ALLOWED`); the cores never import
   each other; ``irs_models`` and the ROS-free modules of ``irs_common`` import no ROS package.
2. **No circle**: the arrows between modules, inside a package and between packages, form no
   loop, so every package and folder has a layer order (a topological order of its modules).
3. **Every package is in the table**, so a new package states its layer.

Tests are not checked: a test may use a sibling core as a fixture (declared as a test_depend).
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CORES = ('irs_sensing', 'irs_treadmill', 'irs_vehicle_sim', 'irs_control')
_BASE = {'irs_models', 'irs_common', 'irs_msgs'}
#: package -> the IRS packages its modules may import (its own is always allowed), bottom up.
ALLOWED = {
    'irs_models': set(),
    'irs_common': set(),
    **{core: set(_BASE) for core in CORES},
    # the hardware node sits with the cores; its emulators step the simulated rig (ONLY_FROM)
    'irs_hardware': {*_BASE, 'irs_vehicle_sim'},
    'irs_bag': set(_BASE),
    'irs_bringup': {*_BASE, *CORES, 'irs_hardware', 'irs_bag'},
    'irs_sysid': {*_BASE, *CORES, 'irs_hardware', 'irs_bag', 'irs_bringup'},
    'irs_studies': {*_BASE, *CORES, 'irs_hardware', 'irs_bag', 'irs_bringup', 'irs_sysid'},
    'irs_system_tests': {*_BASE, *CORES, 'irs_hardware', 'irs_bag', 'irs_bringup', 'irs_sysid',
                         'irs_studies'},
}
#: package -> (a package it may import only from these subpackages, the subpackages)
ONLY_FROM = {'irs_hardware': ('irs_vehicle_sim', ('emulator',))}
#: irs_common modules that the bottom layer may lean on: no ROS import, directly or through
#: another irs_common module.
ROS_FREE_COMMON = {'answer_cache', 'field_checks', 'input_checks', 'loop_timing', 'orientation',
                   'stamp_gate', 'stamp_sync', 'yaml_io'}
#: Top-level names that are ROS: rclpy and generated interfaces. (``ament_index_python``, a
#: pure-Python lookup of installed files, is not: the presets find their YAML through it.)
ROS_PREFIXES = ('rclpy', 'rcl_interfaces', 'builtin_interfaces', 'irs_msgs')
ROS_SUFFIXES = ('_msgs', '_srvs', '_interfaces')


def imported_modules(path: Path, package_dir: tuple):
    """``(line, absolute module name)`` of every import in ``path``; ``package_dir`` is the
    module's folder as a dotted path (``('irs_bag',)``) for relative imports. ``from a import
    b`` yields ``a.b`` (a submodule or a name in ``a``; :func:`module_graph` tells which).
    """
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package_dir[:len(package_dir) - (node.level - 1)]
                module = '.'.join(base + ((node.module,) if node.module else ()))
            else:
                module = node.module
            out += [(node.lineno, f'{module}.{alias.name}') for alias in node.names]
    return out


def is_ros(module: str) -> bool:
    top = module.split('.')[0]
    return top.startswith(ROS_PREFIXES) or top.endswith(ROS_SUFFIXES)


def modules(root: Path) -> dict:
    """``{dotted module name: path}`` of every package module and bench script under ``root``."""
    found = {}
    for path in sorted(root.glob('irs_*/irs_*/**/*.py')):
        rel = path.relative_to(root)
        if rel.parts[0] != rel.parts[1]:
            continue
        parts = rel.parts[1:-1] + (() if path.stem == '__init__' else (path.stem,))
        found['.'.join(parts)] = path
    for path in sorted((root / 'bench').glob('*.py')):
        found[f'bench.{path.stem}'] = path
    return found


def _target(name: str, known: dict) -> str | None:
    """The longest known module that ``name`` is, or lies in; bench scripts import each other
    by their bare names (``import floor``).
    """
    parts = name.split('.')
    for n in range(len(parts), 0, -1):
        candidate = '.'.join(parts[:n])
        if candidate in known:
            return candidate
        if n == 1 and f'bench.{candidate}' in known:
            return f'bench.{candidate}'
    return None


def module_graph(root: Path) -> dict:
    """``{module: {imported module: first line}}`` between the modules of :func:`modules`
    (a package's ``__init__`` counts as a module of its own).
    """
    known = modules(root)
    graph = {}
    for name, path in known.items():
        package_dir = tuple(name.split('.')) if path.stem == '__init__' \
            else tuple(name.split('.')[:-1])
        edges = graph.setdefault(name, {})
        for line, imported in imported_modules(path, package_dir):
            target = _target(imported, known)
            if target is not None and target != name:
                edges.setdefault(target, line)
    return graph


def circles(graph: dict) -> list:
    """Every strongly connected set of two or more modules (Tarjan), sorted."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def violations(root: Path) -> list:
    """Every import against the package layers under ``root``, as ``'path:line: what'``."""
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
            only = ONLY_FROM.get(package)
            if only and top == only[0] and rel.parts[2] not in only[1]:
                found.append(f'{where}: {package} imports {name} outside its '
                             f'{"/".join(only[1])} subpackage')
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


def test_no_circle_between_modules():
    graph = module_graph(ROOT)
    found = circles(graph)
    assert found == [], '\n'.join(
        ' <-> '.join(group) + ': ' + '; '.join(
            f'{a} -> {b} (line {graph[a][b]})' for a in group for b in group if b in graph[a])
        for group in found)


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


def test_a_circle_is_found(tmp_path):
    """The circle finder itself: a lazy import back from a bag module to another, through a
    relative ``from . import``, and two bench scripts importing each other by bare name, are two
    circles; a chain without a way back is none.
    """
    bag = tmp_path / 'irs_bag' / 'irs_bag'
    bag.mkdir(parents=True)
    (bag / '__init__.py').write_text('')
    (bag / 'reader.py').write_text('from .validate import validate\n')
    (bag / 'validate.py').write_text('def f():\n    from . import reader\n')
    (bag / 'info.py').write_text('from .reader import x\n')
    (tmp_path / 'bench').mkdir()
    (tmp_path / 'bench' / 'run.py').write_text('def f():\n    import sweep\n')
    (tmp_path / 'bench' / 'sweep.py').write_text('from run import write\n')
    assert circles(module_graph(tmp_path)) == [['bench.run', 'bench.sweep'],
                                               ['irs_bag.reader', 'irs_bag.validate']]
