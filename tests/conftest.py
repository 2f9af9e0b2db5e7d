"""Fixtures for the topic-level tests: an isolated DDS domain, rclpy contexts, node processes."""
import fcntl
import os

import pytest

#: ROS domain ids Fast DDS can use on one machine (port arithmetic: 0-101 and 215-232); 0 is
#: left out, it is every shell's default (a hand-started graph, ``make demo``).
VALID_DOMAINS = list(range(1, 102)) + list(range(215, 233))
_domain_lock = None      # the open lock file of our domain: held as long as this process lives


def claim_domain(pid: int, lock_dir: str = '/tmp') -> tuple:
    """``(domain id, open lock file)``: the first free domain from ``pid``'s place in
    :data:`VALID_DOMAINS` on, held with an exclusive ``flock`` on
    ``<lock_dir>/irs_test_domain_<id>.lock`` so that two concurrent runs never share one (the
    lock goes with the process, also a killed one). ``RuntimeError`` if every domain is taken.
    """
    n = len(VALID_DOMAINS)
    for i in range(n):
        domain = VALID_DOMAINS[(pid + i) % n]
        f = open(os.path.join(lock_dir, f'irs_test_domain_{domain}.lock'), 'a')
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            continue
        return domain, f
    raise RuntimeError(
        f'all {n} ROS domain ids are held by other test runs ({lock_dir}/irs_test_domain_*.lock)'
    )


# Every test run gets its own ROS_DOMAIN_ID (set before any rclpy context or child process
# starts), so concurrent runs on one machine do not see each other's topics.
# IRS_TEST_DOMAIN_FIXED keeps the ROS_DOMAIN_ID of the environment.
if 'IRS_TEST_DOMAIN_FIXED' not in os.environ:
    _domain, _domain_lock = claim_domain(os.getpid())
    os.environ['ROS_DOMAIN_ID'] = str(_domain)
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


@pytest.fixture
def ros():
    """An initialised rclpy context (fresh per test) and a graph watcher on it."""
    import rclpy
    from rclpy.context import Context

    from irs_bringup.run.graph import make_watcher

    context = Context()
    rclpy.init(context=context)
    watcher = make_watcher(context=context)
    try:
        yield watcher
    finally:
        watcher.node.destroy_node()
        rclpy.try_shutdown(context=context)


@pytest.fixture
def launch(tmp_path):
    """Start node processes (``launch(NodeSpec, env=None)``); every one is stopped at teardown."""
    from irs_bringup.run.processes import NodeProcess

    procs = []

    def start(spec, env=None):
        proc = NodeProcess(spec, tmp_path / 'logs', env=env)
        procs.append(proc)
        return proc

    yield start
    for proc in procs:
        proc.stop()
