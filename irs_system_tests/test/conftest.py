"""Fixtures for the topic-level tests: an isolated DDS domain, rclpy contexts, node processes."""
import pytest


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
    """Start node processes (``launch(NodeSpec, env=None)``); every one is stopped at teardown."""
    from irs_bringup.processes import NodeProcess

    procs = []

    def start(spec, env=None):
        proc = NodeProcess(spec, tmp_path / 'logs', env=env)
        procs.append(proc)
        return proc

    yield start
    for proc in procs:
        proc.stop()
