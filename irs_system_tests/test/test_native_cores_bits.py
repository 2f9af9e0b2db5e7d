"""The compiled cores are the interpreted ones to the bit, and the workspace runs them.

``make build`` compiles the offline loop's cores with mypyc (``irs_common.native_cores``); every
process of the workspace then imports them compiled. The three Figure 10 runs of the offline
twin, run once compiled and once with ``IRS_PURE_PYTHON=1``, give the same bytes in every
signal. Under ``IRS_PURE_PYTHON=1`` (a workspace that chose the interpreted cores) the first test
is skipped; a build that failed or went stale fails it, naming why.
"""
import os
import subprocess
import sys

import pytest

from irs_common import native_cores

RUNS = ('figure10_mrc_with_actuator', 'figure10_mrc_without_actuator', 'figure10_pi')

_PROGRAM = f"""
import hashlib
from irs_common import native_cores
from irs_bringup.offline_twin.from_experiment import offline_run
import irs_vehicle_sim.rig
print(native_cores.status, native_cores.is_compiled(irs_vehicle_sim.rig))
for name in {RUNS!r}:
    run = offline_run(name)
    print(name, hashlib.sha256(b''.join(run[k].tobytes() for k in sorted(run))).hexdigest())
"""


def _digests(pure: bool) -> tuple:
    env = dict(os.environ, IRS_PURE_PYTHON='1' if pure else '')
    out = subprocess.run([sys.executable, '-c', _PROGRAM], env=env, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    status = out[0]
    return status, dict(line.split() for line in out[1:])


def test_this_workspace_runs_the_compiled_cores():
    if os.environ.get('IRS_PURE_PYTHON', '') not in ('', '0'):
        pytest.skip('IRS_PURE_PYTHON is set: this workspace runs the interpreted cores')
    assert native_cores.status == 'compiled', native_cores.status
    told = subprocess.run([sys.executable, '-m', 'irs_common.which_cores'], capture_output=True,
                          text=True, check=True).stdout
    assert told == 'compiled\n'


def test_compiled_and_interpreted_cores_give_the_same_figure10_bits():
    compiled_status, compiled = _digests(pure=False)
    interpreted_status, interpreted = _digests(pure=True)
    assert interpreted_status == 'interpreted: IRS_PURE_PYTHON is set False'
    if native_cores.status == 'compiled':
        assert compiled_status == 'compiled True'
    assert sorted(compiled) == sorted(RUNS)
    assert compiled == interpreted
