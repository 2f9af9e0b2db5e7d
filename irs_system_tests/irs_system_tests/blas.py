"""Which OpenBLAS kernel numpy runs: the bits of a run depend on it.

numpy's wheel bundles OpenBLAS built for many CPUs (``DYNAMIC_ARCH``); at load it picks the
kernel of the CPU it finds (``Haswell`` on AVX2, ``SkylakeX`` on AVX-512, ...), unless
``OPENBLAS_CORETYPE`` names one. Kernels round differently (a 4x4 ``Ad @ x`` differs in the last
bit between ``Haswell`` and ``SkylakeX`` in some steps), so a lock-step run is the same to the
bit on every machine only with the same kernel. ``env/venv_local_setup.sh.in`` pins ``Haswell``
on every x86-64 CPU with AVX2 and FMA (docs/testing.md, "The same bits on every machine").
"""
from __future__ import annotations

import ctypes
from pathlib import Path

#: the kernel env/venv_local_setup.sh.in pins on x86-64 CPUs with AVX2 and FMA
PINNED_CORE = 'Haswell'
#: the names the kernel query has in the OpenBLAS builds numpy ships (64-bit interface first)
_QUERIES = ('scipy_openblas_get_corename64_', 'openblas_get_corename64_',
            'openblas_get_corename')


def openblas_core() -> str | None:
    """The kernel name of numpy's bundled OpenBLAS in this process; None if not found."""
    import numpy
    libs = sorted((Path(numpy.__file__).parent.parent / 'numpy.libs').glob('*openblas*'))
    for lib_path in libs:
        lib = ctypes.CDLL(str(lib_path))
        for name in _QUERIES:
            query = getattr(lib, name, None)
            if query is not None:
                query.restype = ctypes.c_char_p
                return query().decode()
    return None


def cpu_can_pin() -> bool:
    """True on a Linux x86-64 CPU with AVX2 and FMA: the CPUs that run the pinned kernel."""
    try:
        text = Path('/proc/cpuinfo').read_text()
    except OSError:
        return False
    flags = next((ln.split(':', 1)[1].split() for ln in text.splitlines()
                  if ln.startswith('flags')), [])
    return 'avx2' in flags and 'fma' in flags
