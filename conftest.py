"""Test-run plumbing shared by every test directory: a ROS domain per run, the machine lock.

Every test run claims its own ROS_DOMAIN_ID (:mod:`irs_system_tests.domains`; set here, before
any rclpy context or child process starts), so concurrent runs on one machine do not see each
other's topics; ``IRS_TEST_DOMAINS=81-89`` keeps the run to those ids, ``IRS_TEST_DOMAIN_FIXED``
keeps the ROS_DOMAIN_ID of the environment (shared-locked, so that claiming runs pass it by).

``make test`` runs the suite on two pytest-xdist workers. Most tests wait on processes, DDS
discovery and simulated runs more than they compute, so two at a time halve the wall time. A
few measure the graph in real time at 1 kHz and would measure the other worker's load instead:
they carry ``@pytest.mark.exclusive`` and run alone. Every other test holds a shared lock for its
whole run protocol (set-up, call, tear-down, so a module fixture's graph run counts too), an
exclusive test holds it exclusively; a turnstile lock taken first keeps a waiting exclusive test
from being overtaken by the next shared ones (readers-writer lock with writer preference, on
``flock``; the locks go with the process, also a killed one). A worker keeps the exclusive lock
from one exclusive test to the next one it runs (:class:`MachineTurn`): a module of exclusive
tests then waits once for the other worker's test to end, not once per test. Without xdist
nothing is locked.

An exclusive test that fails is judged by the floor measured right after it
(:mod:`irs_system_tests.floor_verdict`): when the machine could not run even the floor's
minimal 1 kHz loop then, the test runs once more when the floor holds again, and is reported as
a skip that says so if it does not within 90 s.
"""
from contextlib import ExitStack, contextmanager
import fcntl
import os
from pathlib import Path
import sys
import tempfile

import pytest

from irs_system_tests.domains import claim_domain, hold_domain

pytest_plugins = ['irs_system_tests.floor_verdict']

if 'IRS_TEST_DOMAIN_FIXED' not in os.environ:
    _domain, _domain_lock = claim_domain(os.getpid())   # held as long as this process lives
    os.environ['ROS_DOMAIN_ID'] = str(_domain)
else:       # the environment's id, shared-locked so that claiming runs pass it by
    _domain_lock, _warning = hold_domain(int(os.environ.get('ROS_DOMAIN_ID') or 0))
    if _warning:
        print(f'conftest: {_warning}', file=sys.stderr)
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
# A node process that does not stop leaves its native stacks too (irs_bringup.processes).
os.environ.setdefault('IRS_NATIVE_STACKS', '1')
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


class MachineTurn:
    """A worker's machine lock through its sequence of tests.

    A shared test takes the shared lock for its own run. An exclusive test takes the exclusive
    lock unless the worker holds it already, and keeps it when the worker's next test is
    exclusive too; otherwise it lets it go at its end.
    """

    def __init__(self, run_id: str, lock_dir: str | None = None):
        self.run_id, self.lock_dir = run_id, lock_dir
        self._held = ExitStack()         # the exclusive lock while a run of exclusive tests lasts
        self.holding = False

    @contextmanager
    def test(self, exclusive: bool, next_exclusive: bool):
        """Hold the lock ``exclusive`` needs for the ``with`` body (one test's run protocol)."""
        if not exclusive:
            with machine_lock(self.run_id, False, self.lock_dir):
                yield
            return
        if not self.holding:
            self._held.enter_context(machine_lock(self.run_id, True, self.lock_dir))
            self.holding = True
        try:
            yield
        finally:
            if not next_exclusive:
                self.holding = False
                self._held.close()


_turn: MachineTurn | None = None


def _exclusive(item) -> bool:
    return item is not None and item.get_closest_marker('exclusive') is not None


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    global _turn
    run_id = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    if run_id is None:
        yield
        return
    if _turn is None:
        _turn = MachineTurn(run_id)
    with _turn.test(_exclusive(item), _exclusive(nextitem)):
        yield
