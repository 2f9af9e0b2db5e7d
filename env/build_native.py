"""Compile the offline loop's cores with mypyc into build/native (irs_common.native_cores).

Usage (``make build``): ``.venv/bin/python env/build_native.py``. Writes the extension of each
module of ``irs_common.native_cores.MODULES``, mypyc's shared library and ``manifest.json`` (each
source's SHA-256) into ``build/native``, nothing into the source tree, and the one-line
``irs_native_cores.pth`` into the venv, which installs the finder at every interpreter start.
Does nothing when the manifest already matches the sources. If mypyc or a C compiler is
missing, or the compile fails, it says so in one line (the compiler's output is in
``build/native.log``), exits 0, and the cores stay interpreted.
"""
from __future__ import annotations

import contextlib
import importlib.machinery
import importlib.util
import json
import os
from pathlib import Path
import shutil
import sys
import sysconfig
import tempfile
import time

ROOT = Path(__file__).resolve().parents[1]


def _this_workspaces_native_cores():
    """``irs_common/native_cores.py`` of this checkout, by its path: ``import irs_common`` may
    find another workspace's (a shell that sourced it sets PYTHONPATH, and the venv's ``.pth``
    imports it at start).
    """
    path = ROOT / 'irs_common' / 'irs_common' / 'native_cores.py'
    spec = importlib.util.spec_from_file_location('_irs_native_cores_of_this_workspace', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


native_cores = _this_workspaces_native_cores()

LOG = ROOT / 'build' / 'native.log'
#: Run at every start of the venv's Python: the finder, if this workspace is on the path.
PTH_LINE = ("import sys; exec('try:\\n import irs_common.native_cores as m\\nexcept ImportError:"
            "\\n pass\\nelse:\\n m.install()')\n")


def _install_pth() -> None:
    pth = Path(sysconfig.get_paths()['purelib']) / 'irs_native_cores.pth'
    if not pth.is_file() or pth.read_text() != PTH_LINE:
        pth.write_text(PTH_LINE)


@contextlib.contextmanager
def _c_files_in_parallel():
    """Compile the C files of one extension on every core, not one after another.

    mypyc's build is a single extension of about 25 C files (``multi_file``: one per module and
    its runtime's), and setuptools compiles the files of an extension in sequence
    (``build_ext --parallel`` only runs extensions side by side). This wraps
    ``CCompiler.compile`` for the ``with`` body: the same steps as setuptools' own
    (``_setup_compile``, ``_get_cc_args``, ``_compile`` per object), with the ``_compile``
    calls on a thread pool. pybind11's ``ParallelCompile`` does the same; it is not a
    dependency of this project.
    """
    from concurrent.futures import ThreadPoolExecutor
    from distutils.ccompiler import CCompiler
    serial = CCompiler.compile

    def compile(self, sources, output_dir=None, macros=None, include_dirs=None, debug=False,
                extra_preargs=None, extra_postargs=None, depends=None):
        macros, objects, extra_postargs, pp_opts, build = self._setup_compile(
            output_dir, macros, include_dirs, sources, depends, extra_postargs)
        cc_args = self._get_cc_args(pp_opts, debug, extra_preargs)

        def one(obj):
            if obj in build:      # setuptools skips an object it has no source for, too
                src, ext = build[obj]
                self._compile(obj, src, ext, cc_args, extra_postargs, pp_opts)

        with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
            list(pool.map(one, objects))       # list(): the first failure raises here
        return objects

    CCompiler.compile = compile
    try:
        yield
    finally:
        CCompiler.compile = serial


def _compile(out: Path, work: Path) -> None:
    """mypyc and the C compiler, their output into :data:`LOG`; raises on failure."""
    from mypyc.build import mypycify
    from setuptools import Distribution
    sources = [str(ROOT / source) for _, source in native_cores.MODULES]
    extensions = mypycify(sources + ['--ignore-missing-imports', '--follow-imports=silent',
                                     '--cache-dir', str(ROOT / 'build' / 'mypy_cache')],
                          opt_level='3', multi_file=True, target_dir=str(work / 'c'))
    dist = Distribution({'ext_modules': extensions, 'script_args': [
        'build_ext', '--build-lib', str(work / 'lib'), '--build-temp', str(work / 'obj')]})
    dist.parse_command_line()
    with _c_files_in_parallel():
        dist.run_commands()
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(work / 'lib', out)


@contextlib.contextmanager
def _descriptors_to(log):
    """Standard output and error, of this process and of the C compiler it starts, into ``log``."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    os.dup2(log.fileno(), 1)
    os.dup2(log.fileno(), 2)
    try:
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)


def build(out: Path = Path(native_cores.BUILD_DIR)) -> str:
    """Compile into ``out`` unless it is up to date; returns a one-line account."""
    _install_pth()
    if native_cores.stale_reason(out, ROOT) is None:
        return f'compiled cores in {out.relative_to(ROOT)} are up to date'
    try:
        import mypyc.build  # noqa: F401 -- present?
        import setuptools  # noqa: F401
    except ImportError as exc:
        return f'the cores stay interpreted: {exc}'
    started = time.monotonic()
    LOG.parent.mkdir(parents=True, exist_ok=True)
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix='irs_native_') as tmp, open(LOG, 'w') as log:
        os.chdir(ROOT)
        try:
            with _descriptors_to(log):
                _compile(out, Path(tmp))
        except (SystemExit, Exception) as exc:  # noqa: BLE001 -- any failure: stay interpreted
            return (f'the cores stay interpreted: the mypyc build failed ({type(exc).__name__}: '
                    f'{exc}; {LOG.relative_to(ROOT)} has its output)')
        finally:
            os.chdir(cwd)
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    modules = {name: {'source': source, 'extension': name.replace('.', '/') + suffix,
                      'sha256': native_cores.source_digest(ROOT / source)}
               for name, source in native_cores.MODULES}
    shared = {p.name[:-len(suffix)]: p.name for p in out.glob(f'*__mypyc{suffix}')}
    (out / 'manifest.json').write_text(json.dumps(
        {'suffix': suffix, 'modules': modules, 'shared': shared}, indent=1) + '\n')
    reason = native_cores.stale_reason(out, ROOT)
    if reason is not None:
        return f'the cores stay interpreted: {reason}'
    return (f'compiled {len(modules)} core modules with mypyc into {out.relative_to(ROOT)} '
            f'in {time.monotonic() - started:.0f} s')


if __name__ == '__main__':
    print(build())
