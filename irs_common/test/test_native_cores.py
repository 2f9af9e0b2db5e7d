"""The compiled cores' finder: it imports a build only when every source is the one compiled."""
import importlib.machinery
import json
from pathlib import Path
import subprocess
import sys

import pytest

from irs_common import native_cores


@pytest.fixture()
def tree(tmp_path):
    """A workspace root with every source of MODULES and a build whose manifest matches it."""
    root, build = tmp_path / 'root', tmp_path / 'build'
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    modules = {}
    for name, source in native_cores.MODULES:
        src = root / source
        src.parent.mkdir(parents=True, exist_ok=True)
        src.write_text(f'# {name}\n')
        ext = build / (name.replace('.', '/') + suffix)
        ext.parent.mkdir(parents=True, exist_ok=True)
        ext.write_bytes(b'')
        modules[name] = {'source': source, 'extension': str(ext.relative_to(build)),
                         'sha256': native_cores.source_digest(src)}
    manifest = {'suffix': suffix, 'modules': modules, 'shared': {}}
    (build / 'manifest.json').write_text(json.dumps(manifest))
    return root, build, manifest


def test_a_build_matching_every_source_is_fresh(tree):
    root, build, _ = tree
    assert native_cores.stale_reason(build, root) is None


def test_one_edited_source_makes_the_whole_build_stale(tree):
    root, build, _ = tree
    name, source = native_cores.MODULES[5]
    (root / source).write_text('# edited\n')
    assert native_cores.stale_reason(build, root) == (
        f'{source} changed since it was compiled (`make build` compiles it again)')


@pytest.mark.parametrize('damage, words', [
    (lambda root, build, m: (build / 'manifest.json').unlink(), 'no compiled build'),
    (lambda root, build, m: (build / 'manifest.json').write_text('{'), 'unreadable'),
    (lambda root, build, m: (build / 'manifest.json').write_text(
        json.dumps(dict(m, suffix='.cpython-312-x86_64-linux-gnu.so'))), 'built for'),
    (lambda root, build, m: (build / 'manifest.json').write_text(
        json.dumps(dict(m, modules=dict(list(m['modules'].items())[1:])))), 'other modules'),
    (lambda root, build, m: (build / m['modules']['irs_vehicle_sim.rig']['extension']).unlink(),
     'missing from'),
    (lambda root, build, m: (root / native_cores.MODULES[0][1]).unlink(), 'not found'),
])
def test_a_damaged_or_foreign_build_is_stale_and_says_why(tree, damage, words):
    root, build, manifest = tree
    damage(root, build, manifest)
    assert words in native_cores.stale_reason(build, root)


def _last_line_in_a_new_process(code: str, env_extra: dict) -> str:
    import os
    env = dict(os.environ, **env_extra)
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.strip().splitlines()[-1]


def test_a_module_imported_before_install_keeps_the_process_interpreted(tree):
    """Installing after a compiled module's source is imported would mix the two: refused."""
    root, build, _ = tree
    code = ('import sys; from pathlib import Path; from irs_common import native_cores as n; '
            'sys.meta_path[:] = [f for f in sys.meta_path '
            "if type(f).__name__ != '_CompiledFinder']; "
            "sys.modules['irs_control.discrete_rst'] = object(); "
            f'print(n.install(Path({str(build)!r}), Path({str(root)!r})))')
    status = _last_line_in_a_new_process(code, {'IRS_PURE_PYTHON': ''})
    assert status == ('interpreted: irs_control.discrete_rst was imported before '
                      'native_cores.install()')


def test_irs_pure_python_keeps_every_process_interpreted(tree):
    root, build, _ = tree
    code = ('from pathlib import Path; from irs_common import native_cores as n; '
            f'print(n.install(Path({str(build)!r}), Path({str(root)!r})))')
    status = _last_line_in_a_new_process(code, {'IRS_PURE_PYTHON': '1'})
    assert status == 'interpreted: IRS_PURE_PYTHON is set'


def test_the_build_script_uses_its_own_workspaces_module_list(monkeypatch):
    """Another workspace's ``irs_common`` imported first (a sourced shell, the venv's ``.pth``)
    does not reach ``env/build_native.py``: it loads this checkout's module by its path.
    """
    import importlib.util
    import types

    import irs_common
    root = Path(native_cores.ROOT)
    other = types.ModuleType('irs_common.native_cores')
    other.ROOT = root.parent / 'another_workspace'
    monkeypatch.setitem(sys.modules, 'irs_common.native_cores', other)
    monkeypatch.setattr(irs_common, 'native_cores', other)
    spec = importlib.util.spec_from_file_location('build_native', root / 'env' / 'build_native.py')
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert Path(script.native_cores.ROOT) == root
    assert script.native_cores.MODULES == native_cores.MODULES


def test_the_finder_adds_no_costly_import_to_a_process_start():
    """The venv's ``.pth`` runs :func:`install` in every process: it must not pull in
    ``importlib.abc`` (and through it ``importlib.resources``, ``tempfile`` and ``typing``).
    """
    code = ('import sys; from irs_common import native_cores; '
            "print([m for m in ('importlib.abc', 'importlib.resources', 'tempfile', 'typing') "
            'if m in sys.modules])')
    assert _last_line_in_a_new_process(code, {}) == '[]'
