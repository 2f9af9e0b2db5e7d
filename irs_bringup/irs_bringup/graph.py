"""Watch the ROS graph: wait for nodes and for publishers/subscriptions to match; call
``rig/start`` so that a lost answer is called for again (:func:`call_rig_start`).

DDS discovery between processes takes up to a participant announcement period and more here
(0.5 s with the environment's Fast DDS profile, 3 s with Fast DDS's defaults: docs/setup.md);
tests and the experiment runner wait on these conditions (with deadlines) instead of sleeping.
"""
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import Trigger

from irs_common.start_gate import ALREADY_RUNNING

#: How long a ``rig/start`` call waits for its answer before calling again [s]. A DDS service's
#: answer is lost, not late, when the server has not yet matched the caller's response reader:
#: rmw_fastrtps drops it after waiting for the match for the response writer's 0.1 s
#: ``max_blocking_time`` ("client will not receive response"), while the caller's own view
#: already showed the service ready (discovery is per side).
START_ANSWER_WAIT = 2.0


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


def call_rig_start(watcher: GraphWatcher, client, trying_for: float = 10.0,
                   check=lambda: None) -> tuple[bool, str]:
    """Call ``rig/start`` (std_srvs/Trigger) through ``client`` until the rig answers success,
    for ``trying_for`` s (a hardware rig's devices may still be coming up); ``(ok, message)``.

    An answer not in within :data:`START_ANSWER_WAIT` is taken as lost and the call is made
    again; a later :data:`~irs_common.start_gate.ALREADY_RUNNING` then means the unanswered call
    started the rig. ``check()`` runs at every spin (the experiment runner's stop check raises).
    """
    deadline = time.monotonic() + trying_for
    unanswered = False
    while True:
        future = client.call_async(Trigger.Request())
        if watcher.spin_until(lambda: check() or future.done(), START_ANSWER_WAIT):
            answer = future.result()
            if answer.success or (unanswered and answer.message == ALREADY_RUNNING):
                return True, answer.message
            message = answer.message
        else:
            client.remove_pending_request(future)
            unanswered = True
            message = f'no answer within {START_ANSWER_WAIT:g} s'
        if time.monotonic() > deadline:
            return False, message
        time.sleep(0.2)


def make_watcher(name: str = 'irs_graph_watcher', context=None) -> GraphWatcher:
    """Create a watcher node (``rclpy.init`` must have been called on ``context``)."""
    return GraphWatcher(rclpy.create_node(name, context=context))
