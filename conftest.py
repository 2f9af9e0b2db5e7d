"""Test-run plumbing shared by every test directory: a ROS domain per run, the machine lock.

Every test run claims its own ROS_DOMAIN_ID (:mod:`irs_system_tests.domains`; set here, before
any rclpy context or child process starts), so concurrent runs on one machine do not see each
other's topics; ``IRS_TEST_DOMAINS=81-89`` keeps the run to those ids, ``IRS_TEST_DOMAIN_FIXED``
keeps the ROS_DOMAIN_ID of the environment.

``make test`` runs the suite on two pytest-xdist workers. Most tests wait on processes, DDS
discovery and simulated runs more than they compute, so two at a time halve the wall time. A
few measure the graph in real time at 1 kHz and would measure the other worker's load instead:
they carry ``@pytest.mark.exclusive`` and run alone. Every other test holds a shared lock for its
whole run protocol (set-up, call, tear-down, so a module fixture's graph run counts too), an
exclusive test holds it exclusively; a turnstile lock taken first keeps a waiting exclusive test
from being overtaken by the next shared ones (readers-writer lock with writer preference, on
``flock``; the locks go with the process, also a killed one). Without xdist nothing is locked.
"""
from contextlib import contextmanager
import fcntl
import os
from pathlib import Path
import tempfile

import pytest

from irs_system_tests.domains import claim_domain

if 'IRS_TEST_DOMAIN_FIXED' not in os.environ:
    _domain, _domain_lock = claim_domain(os.getpid())   # held as long as this process lives
    os.environ['ROS_DOMAIN_ID'] = str(_domain)
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
# The design-check cache (irs_control/design_check_cache.py) of this run only, shared by its
# workers and the processes they start; never the developer's ~/.cache.
if 'IRS_CACHE_DIR' not in os.environ:
    _run = os.environ.get('PYTEST_XDIST_TESTRUNUID') or str(os.getpid())
    os.environ['IRS_CACHE_DIR'] = os.path.join(tempfile.gettempdir(), f'irs_test_cache_{_run}')


def pytest_configure(config):
    config.addinivalue_line(
        'markers', 'exclusive: measures the machine in real time; no other test runs beside it')


@contextmanager
def machine_lock(run_id: str, exclusive: bool, lock_dir: str | None = None):
    """Hold this test run's machine lock, shared or exclusive, for the ``with`` body."""
    base = Path(lock_dir or tempfile.gettempdir()) / f'irs_test_machine_{run_id}'
    with open(f'{base}.turnstile', 'a') as gate, open(f'{base}.lock', 'a') as lock:
        fcntl.flock(gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        finally:
            fcntl.flock(gate, fcntl.LOCK_UN)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    run_id = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    if run_id is None:
        yield
        return
    with machine_lock(run_id, item.get_closest_marker('exclusive') is not None):
        yield
