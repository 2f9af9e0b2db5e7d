"""Service calls from a test that survive a lost reply.

rmw_fastrtps answers a request only to a client whose reply reader the server's reply writer has
matched; a client sees the service as ready once its own endpoints have matched the server's,
which can be earlier (DDS discovery is per side). A call made right after the service became
ready can then be carried out and its reply lost. :func:`call_idempotent` sends such a call
again; it is for calls that may run twice (parameter gets and sets, a fault reset), not for
ones that act again (``rig/recover`` moves the car back: :mod:`irs_vehicle_sim.recover_call`).
"""

__all__ = ['call_idempotent', 'call_trigger', 'get_param', 'set_params']


def call_idempotent(ros, request, attempts: int = 4, timeout: float = 5.0):
    """The result of ``request()`` (a call that returns a future), sent again when its answer
    has not come within ``timeout`` [s]; ``AssertionError`` after ``attempts`` calls.
    ``ros`` is the test's :class:`irs_bringup.graph.GraphWatcher`.
    """
    for _attempt in range(attempts):
        future = request()
        if ros.spin_until(future.done, timeout):
            return future.result()
    raise AssertionError(f'no answer in {attempts} calls of {timeout} s')


def call_trigger(ros, name: str, ready_timeout: float = 20.0):
    """The response of ``std_srvs/Trigger`` service ``name``, a call that may run twice (a
    reset), sent again if its reply is lost.
    """
    from std_srvs.srv import Trigger
    client = ros.node.create_client(Trigger, name)
    assert ros.spin_until(client.service_is_ready, ready_timeout), f'{name} not available'
    return call_idempotent(ros, lambda: client.call_async(Trigger.Request()))


def set_params(ros, node_name: str, **values):
    """``SetParametersResult`` list of setting ``values`` on node ``node_name`` through its
    parameter service (``__`` in a keyword stands for ``.``: ``regulator__x_ref``).
    """
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    client = AsyncParameterClient(ros.node, node_name)
    assert client.wait_for_services(timeout_sec=20.0), f'{node_name}: no parameter services'
    params = [Parameter(k.replace('__', '.'), value=v) for k, v in values.items()]
    return call_idempotent(ros, lambda: client.set_parameters(params)).results


def get_param(ros, node_name: str, name: str):
    """The ``ParameterValue`` of parameter ``name`` of node ``node_name``."""
    from rclpy.parameter_client import AsyncParameterClient
    client = AsyncParameterClient(ros.node, node_name)
    assert client.wait_for_services(timeout_sec=20.0), f'{node_name}: no parameter services'
    return call_idempotent(ros, lambda: client.get_parameters([name])).values[0]
