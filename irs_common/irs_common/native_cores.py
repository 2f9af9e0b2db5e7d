"""The offline loop's cores compiled by mypyc, imported in place of their source when fresh.

``make build`` compiles the modules of the offline closed loop's hot path (:data:`MODULES`) with
mypyc into ``build/native`` (``env/build_native.py``), beside a manifest of each source's
SHA-256. :func:`install` puts a finder first on ``sys.meta_path`` that imports those modules from
their compiled extension instead of their source, **only if every source is the one compiled**:
the modules of one mypyc build call each other natively, so a compiled module must never meet an
edited source of another. An edited source, a missing or foreign build (another Python, another
checkout), or ``IRS_PURE_PYTHON`` set (to anything but ``0``) leaves the interpreted modules in
place; :data:`status` says which and why, and ``python -m irs_common.which_cores`` prints it.

``make build`` also puts ``irs_native_cores.pth`` into the venv, which calls :func:`install` at
every interpreter start, so every process of the workspace (nodes, tests, sweeps' workers) runs
the compiled cores. A module imported before :func:`install` keeps that process interpreted
(installing then would mix the two).

The compiled modules compute the same floats as their source, to the bit (CPython's ``float``
operations and ``math`` are C ``double`` operations and libm either way, and the C compiler
neither fuses nor reorders them: no ``-ffast-math``, no FMA target);
``irs_system_tests/test/test_native_cores_bits.py`` compares Figure 10's runs both ways. A
compiled class differs from its source where Python code reaches into it:

- its typed attributes and arguments check their type: a parameter set built directly from
  Python with a string or None for a number raises ``TypeError`` ("float object expected"),
  and a bool given for a number is taken as 0 or 1, where the interpreted class names the field
  in a ``ValueError``. Values from parameter files, experiment files and ROS parameters are
  checked against the nodes' declared types before either (docs/input_checks.md);
- it cannot be subclassed by interpreted code (``ClosedLoop`` can: the HIL loops derive from
  it), nor copied or pickled unless it is a dataclass;
- it has no ``__dict__``.

It runs first in every process of the venv, so it imports only the standard library's cheapest
modules: ``os.path`` for paths, no ``pathlib``, and a finder that follows
``importlib.abc.MetaPathFinder``'s protocol without importing it (``importlib.abc`` imports
``importlib.resources``, ``pathlib``, ``tempfile`` and ``typing``, which every process would
then pay for; docs/setup.md#the-environment). Paths are strings; the functions take any
path-like.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys

#: The compiled modules, as (module, source path relative to the workspace root).
MODULES = (
    ('irs_common.input_checks', 'irs_common/irs_common/input_checks.py'),
    ('irs_models.arm_kinematics', 'irs_models/irs_models/arm_kinematics.py'),
    ('irs_models.identified', 'irs_models/irs_models/identified.py'),
    ('irs_sensing.differentiator', 'irs_sensing/irs_sensing/differentiator.py'),
    ('irs_sensing.pose_estimator', 'irs_sensing/irs_sensing/pose_estimator.py'),
    ('irs_control.discrete_rst', 'irs_control/irs_control/discrete_rst.py'),
    ('irs_control.discrete_pi', 'irs_control/irs_control/discrete_pi.py'),
    ('irs_treadmill.regulator', 'irs_treadmill/irs_treadmill/regulator.py'),
    ('irs_treadmill.safety', 'irs_treadmill/irs_treadmill/safety.py'),
    ('irs_vehicle_sim.actuator', 'irs_vehicle_sim/irs_vehicle_sim/actuator.py'),
    ('irs_vehicle_sim.arm_sensor', 'irs_vehicle_sim/irs_vehicle_sim/arm_sensor.py'),
    ('irs_vehicle_sim.belt', 'irs_vehicle_sim/irs_vehicle_sim/belt.py'),
    ('irs_vehicle_sim.car_on_belt', 'irs_vehicle_sim/irs_vehicle_sim/car_on_belt.py'),
    ('irs_vehicle_sim.radio_link', 'irs_vehicle_sim/irs_vehicle_sim/radio_link.py'),
    ('irs_vehicle_sim.rig', 'irs_vehicle_sim/irs_vehicle_sim/rig.py'),
    ('irs_bringup.offline_twin.lateral_loop',
     'irs_bringup/irs_bringup/offline_twin/lateral_loop.py'),
)

#: The workspace root (this file is ``<root>/irs_common/irs_common/native_cores.py``; the
#: develop-mode install links to it).
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
#: Where ``env/build_native.py`` writes the extensions and ``manifest.json``.
BUILD_DIR = os.path.join(ROOT, 'build', 'native')

#: ``'compiled'``, or ``'interpreted: <why>'`` after :func:`install`; None before.
status: str | None = None


def source_digest(path: str | os.PathLike) -> str:
    """SHA-256 of a source file, hex."""
    with open(path, 'rb') as f:
        return hashlib.sha256(f.read()).hexdigest()


def _extension_suffix() -> str:
    return importlib.machinery.EXTENSION_SUFFIXES[0]


def stale_reason(build_dir: str | os.PathLike = BUILD_DIR,
                 root: str | os.PathLike = ROOT) -> str | None:
    """Why the build in ``build_dir`` cannot stand in for the sources under ``root``, or None."""
    build_dir, root = os.fspath(build_dir), os.fspath(root)
    manifest_path = os.path.join(build_dir, 'manifest.json')
    if not os.path.isfile(manifest_path):
        return f'no compiled build ({manifest_path} not found; `make build` writes it)'
    try:
        with open(manifest_path) as f:
            manifest = json.load(f)
        modules = manifest['modules']
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return f'{manifest_path}: unreadable ({exc})'
    if manifest.get('suffix') != _extension_suffix():
        return f'built for {manifest.get("suffix")!r}, this Python loads {_extension_suffix()!r}'
    if sorted(modules) != sorted(name for name, _ in MODULES):
        return 'the build holds other modules than native_cores.MODULES'
    for name, source in MODULES:
        src = os.path.join(root, source)
        if not os.path.isfile(src):
            return f'{source}: not found'
        if source_digest(src) != modules[name]['sha256']:
            return f'{source} changed since it was compiled (`make build` compiles it again)'
        if not os.path.isfile(os.path.join(build_dir, modules[name]['extension'])):
            return f'{modules[name]["extension"]}: missing from {build_dir}'
    return None


class _CompiledFinder:
    """Finds :data:`MODULES` (and the build's shared library) in the compiled build.

    A meta path finder by protocol (``find_spec``), as ``importlib.abc.MetaPathFinder``
    describes it; the import system asks for nothing else.
    """

    def __init__(self, build_dir: str, extensions: dict) -> None:
        self._build_dir = build_dir
        self._extensions = extensions

    def find_spec(self, fullname, path=None, target=None):  # noqa: ARG002 -- the protocol's
        relative = self._extensions.get(fullname)
        if relative is None:
            return None
        location = os.path.join(self._build_dir, relative)
        loader = importlib.machinery.ExtensionFileLoader(fullname, location)
        return importlib.util.spec_from_file_location(fullname, location, loader=loader)

    def invalidate_caches(self) -> None:
        """Nothing is cached (``importlib.invalidate_caches`` calls this)."""


def install(build_dir: str | os.PathLike = BUILD_DIR, root: str | os.PathLike = ROOT) -> str:
    """Import :data:`MODULES` compiled from now on, if the build is fresh; returns :data:`status`.

    Does nothing (and says why) when ``IRS_PURE_PYTHON=1``, the build is stale or missing, or
    one of the modules is imported already. Idempotent.
    """
    global status
    if any(isinstance(f, _CompiledFinder) for f in sys.meta_path):
        return status or 'compiled'
    reason = None
    if os.environ.get('IRS_PURE_PYTHON', '') not in ('', '0'):
        reason = 'IRS_PURE_PYTHON is set'
    if reason is None:
        reason = stale_reason(build_dir, root)
    if reason is None:
        loaded = [name for name, _ in MODULES if name in sys.modules]
        if loaded:
            reason = f'{loaded[0]} was imported before native_cores.install()'
    if reason is not None:
        status = f'interpreted: {reason}'
        return status
    with open(os.path.join(build_dir, 'manifest.json')) as f:
        manifest = json.load(f)
    extensions = {name: entry['extension'] for name, entry in manifest['modules'].items()}
    extensions.update(manifest.get('shared', {}))
    sys.meta_path.insert(0, _CompiledFinder(os.fspath(build_dir), extensions))
    status = 'compiled'
    return status


def is_compiled(module) -> bool:
    """True if ``module`` was loaded from a compiled extension."""
    return isinstance(getattr(module, '__loader__', None), importlib.machinery.ExtensionFileLoader)

