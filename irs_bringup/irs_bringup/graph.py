"""Watch the ROS graph: wait for nodes and for publishers/subscriptions to match.

DDS discovery between processes takes 0.4-3 s here; tests and the experiment runner wait on these
conditions (with deadlines) instead of sleeping.
"""
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor


class GraphWatcher:
    """A helper node that spins itself while waiting for graph conditions."""

    def __init__(self, node):
        self.node = node
        self.executor = SingleThreadedExecutor(context=node.context)
        self.executor.add_node(node)

    def spin_until(self, predicate, timeout: float) -> bool:
        """Spin the watcher's node until ``predicate()`` holds or ``timeout`` s pass."""
        deadline = time.monotonic() + timeout
        while not predicate():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            self.executor.spin_once(timeout_sec=min(0.05, remaining))
        return True

    def node_names(self) -> set:
        """Fully qualified names of the nodes in the graph."""
        return {(ns.rstrip('/') + '/' + name) for name, ns in
                self.node.get_node_names_and_namespaces()}

    def wait_for_nodes(self, names, timeout: float = 15.0) -> bool:
        wanted = {n if n.startswith('/') else '/' + n for n in names}
        return self.spin_until(lambda: wanted <= self.node_names(), timeout)

    def wait_for_endpoints(self, topic: str, publishers: int = 0, subscribers: int = 0,
                           timeout: float = 15.0) -> bool:
        """Wait until ``topic`` has at least that many publishers and subscriptions."""
        return self.spin_until(
            lambda: (self.node.count_publishers(topic) >= publishers
                     and self.node.count_subscribers(topic) >= subscribers), timeout)

    def wait_for_matched(self, endpoints, timeout: float = 15.0) -> bool:
        """Wait until every local publisher/subscription in ``endpoints`` has matched a peer."""
        def matched():
            for ep in endpoints:
                count = (ep.get_subscription_count() if hasattr(ep, 'get_subscription_count')
                         else ep.get_publisher_count())
                if count < 1:
                    return False
            return True
        return self.spin_until(matched, timeout)


def make_watcher(name: str = 'irs_graph_watcher', context=None) -> GraphWatcher:
    """Create a watcher node (``rclpy.init`` must have been called on ``context``)."""
    return GraphWatcher(rclpy.create_node(name, context=context))
