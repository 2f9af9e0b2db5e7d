"""Fixtures for the topic-level tests: an isolated DDS domain, rclpy contexts, node processes."""
import os

import pytest

# Every test run gets its own ROS_DOMAIN_ID (set before any rclpy context or child process
# starts), so concurrent runs on one machine do not see each other's topics.
if 'IRS_TEST_DOMAIN_FIXED' not in os.environ:
    os.environ['ROS_DOMAIN_ID'] = str(10 + os.getpid() % 90)
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


@pytest.fixture
def ros():
    """An initialised rclpy context (fresh per test) and a graph watcher on it."""
    import rclpy
    from rclpy.context import Context

    from irs_bringup.graph import make_watcher

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
    """Start node processes (``launch(NodeSpec)``); every one is stopped at teardown."""
    from irs_bringup.processes import NodeProcess

    procs = []

    def start(spec):
        proc = NodeProcess(spec, tmp_path / 'logs')
        procs.append(proc)
        return proc

    yield start
    for proc in procs:
        proc.stop()
