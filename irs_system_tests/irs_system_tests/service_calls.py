"""Service calls from a test that survive a lost reply.

rmw_fastrtps answers a request only to a client whose reply reader the server's reply writer has
matched; a client sees the service as ready once its own endpoints have matched the server's,
which can be earlier (DDS discovery is per side). A call made right after the service became
ready can then be carried out and its reply lost. :func:`call_idempotent` sends such a call
again; it is for calls that may run twice (parameter gets and sets, a fault reset), not for
ones that act again (``rig/recover`` moves the car back: :mod:`irs_vehicle_sim.recover_call`).
"""

__all__ = ['call_idempotent']


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
