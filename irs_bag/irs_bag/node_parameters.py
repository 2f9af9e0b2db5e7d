"""The parameters of the other nodes of a graph, asked once per node, for the recorder's bag.

A bag recorded by hand (the recorder started beside nodes started one by one) has no experiment
file behind it: what the nodes were configured with is in their parameters only. The recorder
(``node_parameters: true``) asks each node that appears in the graph, once, through the
standard parameter services every rclpy node serves (``<node>/list_parameters``, then
``<node>/get_parameters``), and writes the answer into the bag as one MCAP metadata record per
node:

    name ``irs_node_parameters``; ``node``: the node's full name (``/lateral_controller``),
    ``parameters``: a JSON object ``{parameter: value}`` (dotted names, as in a params file)

:func:`node_parameters_from_records` reads them back as ``{node name: {parameter: value}}``,
the form of the experiment runner's ``node_parameters`` (:mod:`irs_bag.run_info`).

The ``live_view`` node started by hand asks the same way and draws the arm and the car with the
rig's geometry. The calls are asynchronous (the node's executor takes the responses);
:meth:`ParameterAsker.poll` runs on a timer of the node every ``POLL_PERIOD`` s: it notes new
nodes, sends the next request of each, and writes what has come back. A node that does not
answer within ``TIMEOUT_S`` is asked again on a later poll, at most ``ATTEMPTS`` times.
"""
from __future__ import annotations

import json
import time
from typing import Callable, Dict, Iterable, List, Optional, Tuple

#: Name of the MCAP metadata records.
RECORD = 'irs_node_parameters'
#: How often the graph is looked at for nodes to ask [s].
POLL_PERIOD = 0.5
#: A request not answered within this long is given up and sent again on a later poll [s].
TIMEOUT_S = 5.0
#: How often one node is asked before it is left out.
ATTEMPTS = 3


def node_parameters_from_records(records: Iterable[Tuple[str, Dict[str, str]]]) -> dict:
    """``{node name without namespace: {parameter: value}}`` from a bag's metadata records
    (``(name, data)`` pairs); records of other names and unreadable ones are skipped.
    """
    out: dict = {}
    for name, data in records:
        if name != RECORD:
            continue
        try:
            params = json.loads(data.get('parameters', ''))
        except json.JSONDecodeError:
            continue
        node = str(data.get('node', '')).rsplit('/', 1)[-1]
        if node and isinstance(params, dict):
            out[node] = params
    return out


def _full_name(name: str, namespace: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


class _Asking:
    """One node's requests in flight: its two clients, the future and when it was sent."""

    __slots__ = ('node', 'list_client', 'get_client', 'future', 'names', 'sent', 'attempts')

    def __init__(self, node: str):
        self.node = node
        self.list_client = self.get_client = self.future = None
        self.names: Optional[List[str]] = None
        self.sent = 0.0
        self.attempts = 0


class ParameterAsker:
    """Asks each node of ``owner``'s graph for its parameters once; ``write(node, params)``
    gets each answer (``params``: ``{name: value}``, each ``rcl_interfaces/ParameterValue``
    made a plain Python value by ``to_python``: ``rclpy.parameter.parameter_value_to_python``,
    which the node passes in, so that this module needs no rclpy). ``missing``: what the warning
    says of a node that never answered.
    """

    def __init__(self, owner, write: Callable[[str, dict], None],
                 to_python: Callable[[object], object],
                 clock: Callable[[], float] = time.monotonic,
                 missing: str = 'its parameters are not in the bag'):
        self.owner, self.write, self.to_python, self.clock = owner, write, to_python, clock
        self.missing = missing
        self.own = _full_name(owner.get_name(), owner.get_namespace())
        self.done: set = set()
        self.asking: Dict[str, _Asking] = {}

    def poll(self) -> None:
        """Note new nodes, advance each node's requests, write the answers."""
        for name, namespace in self.owner.get_node_names_and_namespaces():
            full = _full_name(name, namespace)
            if full != self.own and full not in self.done and full not in self.asking:
                self.asking[full] = _Asking(full)
        for asking in list(self.asking.values()):
            self._advance(asking)

    def close(self) -> None:
        """Destroy the clients of the requests still in flight."""
        for asking in list(self.asking.values()):
            self._drop_clients(asking)
        self.asking.clear()

    def _advance(self, a: _Asking) -> None:
        from rcl_interfaces.srv import GetParameters, ListParameters
        if a.future is not None and not a.future.done():
            if self.clock() - a.sent < TIMEOUT_S:
                return
            self._retry(a, 'did not answer within %g s' % TIMEOUT_S)
            return
        if a.future is not None:                       # an answer came
            response, a.future = a.future.result(), None
            if a.names is None:
                a.names = list(response.result.names)
            else:
                params = {n: self.to_python(v) for n, v in zip(a.names, response.values)}
                self._finish(a)
                self.write(a.node, params)
                return
        if a.names is None:
            if a.list_client is None:
                a.list_client = self.owner.create_client(ListParameters,
                                                         f'{a.node}/list_parameters')
            if a.list_client.service_is_ready():
                a.future = a.list_client.call_async(ListParameters.Request())
                a.sent = self.clock()
        else:
            if a.get_client is None:
                a.get_client = self.owner.create_client(GetParameters,
                                                        f'{a.node}/get_parameters')
            if a.get_client.service_is_ready():
                a.future = a.get_client.call_async(GetParameters.Request(names=a.names))
                a.sent = self.clock()

    def _retry(self, a: _Asking, why: str) -> None:
        a.attempts += 1
        self._drop_clients(a)
        a.names = a.future = None
        if a.attempts >= ATTEMPTS:
            self._finish(a)
            self.owner.get_logger().warning(
                f'{a.node}: {self.missing} ({why}, {ATTEMPTS} times)')

    def _finish(self, a: _Asking) -> None:
        self._drop_clients(a)
        self.asking.pop(a.node, None)
        self.done.add(a.node)

    def _drop_clients(self, a: _Asking) -> None:
        for client in (a.list_client, a.get_client):
            if client is not None:
                self.owner.destroy_client(client)
        a.list_client = a.get_client = None
