"""Every package's ``package.xml`` declares what its code imports (REP 149 / rosdep keys).

The modules of each package (not its tests, not ``setup.py``) are parsed with ``ast``; every
top-level name they import, lazily or not, that is not the standard library and not the package
itself must be covered by an ``exec_depend`` (or ``depend``) of the manifest: a ROS package by
its own name, a Python library by its rosdep key (:data:`ROSDEP_KEYS`; libraries that rosdep
knows only from PyPI carry rosdep's ``-pip`` suffix). A key the code no longer needs is reported
too, so the manifest cannot drift either way.
"""
import ast
from pathlib import Path
import sys
import xml.etree.ElementTree as ET

ROOT = Path(__file__).resolve().parents[1]

#: Python import name -> rosdep key.
ROSDEP_KEYS = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib', 'pydantic': 'python3-pydantic',
    'pyarrow': 'python3-pyarrow', 'distributed': 'python3-distributed', 'dask': 'python3-dask',
    'pandas': 'python3-pandas', 'serial': 'python3-serial',
    'mypy_extensions': 'python3-mypy-extensions',
    'control': 'python3-control-pip', 'mcap': 'python3-mcap-pip',
    'mcap_ros2': 'python3-mcap-ros2-pip', 'rerun': 'python3-rerun-sdk-pip',
    'pymodbus': 'python3-pymodbus-pip', 'rosbags': 'python3-rosbags-pip',
    'foxglove': 'python3-foxglove-sdk-pip', 'tornado': 'python3-tornado',
    'pytest': 'python3-pytest', '_pytest': 'python3-pytest',
}
#: Imported by every package's setup.py only (a build tool, not a run-time dependency).
BUILD_ONLY = {'setuptools'}


def packages() -> list:
    return sorted(p for p in ROOT.glob('irs_*') if (p / 'package.xml').is_file()
                  and (p / p.name).is_dir())


def imported_tops(package: Path) -> set:
    """Top-level names imported by the package's modules (absolute imports only)."""
    names = set()
    for path in (package / package.name).rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names |= {alias.name.split('.')[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names.add(node.module.split('.')[0])
    return names - set(sys.stdlib_module_names) - BUILD_ONLY - {package.name, '__future__'}


def declared(package: Path) -> set:
    root = ET.parse(package / 'package.xml').getroot()
    return {e.text.strip() for tag in ('exec_depend', 'depend') for e in root.iter(tag)}


def needed_keys(package: Path) -> set:
    return {ROSDEP_KEYS.get(name, name) for name in imported_tops(package)}


def test_every_import_is_declared():
    missing = {p.name: sorted(needed_keys(p) - declared(p)) for p in packages()}
    assert {k: v for k, v in missing.items() if v} == {}


def test_nothing_is_declared_that_the_code_does_not_import():
    # rclpy's generated interfaces pull builtin_interfaces etc. in by name; they are declared
    # where a module imports them, so the rule holds both ways
    extra = {p.name: sorted(declared(p) - needed_keys(p)) for p in packages()}
    assert {k: v for k, v in extra.items() if v} == {}


def test_every_third_party_import_has_a_key():
    """A new library needs its rosdep key here (or it is a ROS package named as imported)."""
    ros_like = {n for p in packages() for n in imported_tops(p)
                if n.startswith(('irs_', 'rcl', 'rosgraph', 'builtin', 'ament'))
                or n.endswith(('_msgs', '_srvs', '_interfaces'))}
    unknown = {n for p in packages() for n in imported_tops(p)} - ros_like - set(ROSDEP_KEYS)
    assert unknown == set()


def test_the_check_can_fail(tmp_path):
    pkg = tmp_path / 'irs_demo'
    (pkg / 'irs_demo').mkdir(parents=True)
    (pkg / 'irs_demo' / 'm.py').write_text('import numpy\n\ndef f():\n    import mcap.reader\n')
    (pkg / 'package.xml').write_text(
        '<package format="3"><name>irs_demo</name><exec_depend>python3-numpy</exec_depend>'
        '<exec_depend>std_msgs</exec_depend></package>')
    assert needed_keys(pkg) - declared(pkg) == {'python3-mcap-pip'}
    assert declared(pkg) - needed_keys(pkg) == {'std_msgs'}
