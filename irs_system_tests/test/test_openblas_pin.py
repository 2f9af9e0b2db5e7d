"""The environment pins numpy's OpenBLAS kernel on x86-64 CPUs with AVX2 and FMA, in every way a
user enters it (``./irs``, ``source env/setup.bash``, ``source install/setup.bash``), and keeps a
kernel the user chose (irs_system_tests.blas; docs/testing.md, "The same bits on every machine").
"""
import os
from pathlib import Path
import subprocess

import pytest

from irs_system_tests.blas import PINNED_CORE, cpu_can_pin

ROOT = Path(__file__).resolve().parents[2]
QUERY = 'python -c "from irs_system_tests.blas import openblas_core; print(openblas_core())"'
#: what the environment sets: removed, so that each entry must set it again
SET_BY_ENTRY = ('OPENBLAS_CORETYPE', 'VIRTUAL_ENV', 'AMENT_PREFIX_PATH', 'PYTHONPATH',
                'CMAKE_PREFIX_PATH', 'COLCON_PREFIX_PATH')

pytestmark = pytest.mark.skipif(not cpu_can_pin(), reason='the pin needs x86-64 with AVX2, FMA')


def _core(command: str, **env) -> str:
    """The kernel numpy runs in ``python`` started by ``command`` from a bare shell."""
    bare = {k: v for k, v in os.environ.items() if k not in SET_BY_ENTRY}
    bare['PATH'] = '/usr/bin:/bin'
    out = subprocess.run(['bash', '-c', command], cwd=ROOT, env={**bare, **env},
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()[-1]


@pytest.mark.parametrize('entry', ['source env/setup.bash && ', 'source install/setup.bash && ',
                                   './irs exec '])
def test_every_way_in_pins_the_kernel(entry):
    assert _core(entry + QUERY) == PINNED_CORE


def test_a_kernel_the_user_chose_is_kept():
    assert _core('source env/setup.bash && ' + QUERY, OPENBLAS_CORETYPE='Sandybridge') == \
        'Sandybridge'
