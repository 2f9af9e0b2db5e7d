"""ROS domain ids of test runs (``irs_system_tests.domains``): a claimed id is the run's alone,
and an id a run chose itself (``IRS_TEST_DOMAIN_FIXED``) is passed by the runs that claim.

Each process's locks are ``flock`` locks on files in a temporary directory; a child process
holds the competing lock, as another run would.
"""
import subprocess
import sys

import pytest

from irs_system_tests.domains import DomainError, claim_domain, hold_domain

HOLD = """
import sys, time
from irs_system_tests.domains import claim_domain, hold_domain
kind, domain, lock_dir = sys.argv[1], int(sys.argv[2]), sys.argv[3]
held = (claim_domain(0, (domain,), lock_dir) if kind == 'claim'
        else hold_domain(domain, lock_dir))
print('held', flush=True)
sys.stdin.read()
"""


@pytest.fixture
def other_run(tmp_path):
    """Start another 'run' holding ``domain`` (``claim`` or ``hold``) until the test ends."""
    procs = []

    def start(kind, domain):
        p = subprocess.Popen([sys.executable, '-c', HOLD, kind, str(domain), str(tmp_path)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert p.stdout.readline().strip() == 'held'
        procs.append(p)
    yield start
    for p in procs:
        p.stdin.close()
        p.wait(10)


def test_a_claiming_run_passes_by_a_fixed_run_s_id(tmp_path, other_run):
    other_run('hold', 5)
    domain, lock = claim_domain(0, (5, 6), str(tmp_path))
    assert domain == 6
    lock.close()
    with pytest.raises(DomainError):
        claim_domain(0, (5,), str(tmp_path))


def test_fixed_runs_may_share_their_id(tmp_path, other_run):
    other_run('hold', 5)
    lock, warning = hold_domain(5, str(tmp_path))
    assert lock is not None and warning is None
    lock.close()


def test_a_fixed_run_on_a_claimed_id_is_warned_in_one_line(tmp_path, other_run):
    other_run('claim', 5)
    lock, warning = hold_domain(5, str(tmp_path))
    assert lock is None
    assert warning.startswith('ROS_DOMAIN_ID 5 is held by another test or benchmark run')
    assert '\n' not in warning
    lock, warning = hold_domain(6, str(tmp_path))
    assert lock is not None and warning is None
