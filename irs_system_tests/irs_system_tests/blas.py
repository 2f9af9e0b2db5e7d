"""Which OpenBLAS kernel numpy runs: the bits of a run depend on it.

numpy's wheel bundles OpenBLAS built for many CPUs (``DYNAMIC_ARCH``); at load it picks the
kernel of the CPU it finds (``Haswell`` on AVX2, ``SkylakeX`` on AVX-512, ...), unless
``OPENBLAS_CORETYPE`` names one. Kernels round differently (a 4x4 ``Ad @ x`` differs in the last
bit between ``Haswell`` and ``SkylakeX`` in some steps), so a lock-step run is the same to the
bit on two machines only when they run the same kernel (docs/testing.md, "The same bits on
every machine").
"""
from __future__ import annotations

import ctypes
from pathlib import Path

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
