"""``rig/recover`` from a command line: call it and wait until the rig runs again (rclpy client).

The call itself answers at once (:mod:`.safe_stop`: the rig then holds the car while it brings
the belt up to speed); :func:`recover` also waits until ``rig/status`` says ``SAFE_RUNNING`` with
the car on the belt, so that a person or a script knows the rig is running when it returns.
A rig that cannot be found within ``DISCOVERY_TIMEOUT`` s (DDS discovery takes up to about 3 s),
that refuses, or that does not run within ``timeout`` s is a :class:`~irs_common.cli.RunFailed`
(``experiment: error: recover: ...``, exit code 1).

An answer can be lost: rmw_fastrtps drops the answer to a request that reaches the server before
the server has matched the caller's answer reader ("client will not receive response"), and a
caller that has just found the service is such a caller. ``rig/status`` then tells what the call
did: once it shows the rig recovering (:func:`recovery_index`), an answer still missing
:data:`ANSWER_WAIT` s later counts as lost and the call as taken (:func:`take_answer`).
"""
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.cli import RunFailed
from irs_msgs.msg import RigStatus

#: How long the rig's service is looked for [s].
DISCOVERY_TIMEOUT = 5.0
#: How long an answer is waited for once ``rig/status`` shows the call taken [s].
ANSWER_WAIT = 2.0
_STOPPED = (RigStatus.SAFE_STOPPING, RigStatus.SAFE_STOPPED)


def recovery_index(statuses) -> int | None:
    """Index of the first of ``statuses`` (``rig/status`` since the call, in order) that shows
    the rig recovering: ``SAFE_RECOVERING`` (``vehicle_sim``), or ``SAFE_RUNNING`` after a stopped
    state (``rig_hardware``, which has no recovering state); None if none does.
    """
    stopped = False
    for i, s in enumerate(statuses):
        if s.safe_state == RigStatus.SAFE_RECOVERING or (
                stopped and s.safe_state == RigStatus.SAFE_RUNNING):
            return i
        stopped = stopped or s.safe_state in _STOPPED
    return None


def take_answer(spin_until, future, taken, timeout: float, answer_wait: float = ANSWER_WAIT):
    """The rig's answer to the call ``future`` (a ``Trigger.Response``), or None when ``taken()``
    (``rig/status`` shows a recovery: :func:`recovery_index`) became true and no answer followed
    within ``answer_wait`` s: the answer was lost (module docstring).
    ``spin_until(predicate, seconds)`` spins the caller's executor until ``predicate()`` or the
    time is up, and returns ``predicate()``.

    Raises
    ------
    RunFailed
        Neither an answer nor a recovery within ``timeout`` s.
    """
    if not spin_until(lambda: future.done() or taken(), timeout):
        raise RunFailed(f'recover: rig/recover did not answer within {timeout:g} s')
    if future.done() or spin_until(future.done, answer_wait):
        return future.result()
    return None


def recover(timeout: float = 30.0, log=print,
            discovery_timeout: float = DISCOVERY_TIMEOUT) -> None:
    """Call ``rig/recover`` and wait up to ``timeout`` [s] for the rig to run; ``RunFailed``
    (module docstring) if it does not.
    """
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('irs_recover', context=context)
    status = []
    node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS_LIVE)
    client = node.create_client(Trigger, 'rig/recover')
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin_until(predicate, seconds: float) -> bool:
        deadline = time.monotonic() + seconds
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.05)
        return True
    try:
        if not spin_until(client.service_is_ready, discovery_timeout):
            raise RunFailed(f'recover: no rig/recover service within {discovery_timeout:g} s '
                            '(is vehicle_sim or rig_hardware running in real time, in this '
                            'ROS_DOMAIN_ID?)')
        t_call = time.monotonic()
        n = len(status)
        future = client.call_async(Trigger.Request())
        answer = take_answer(spin_until, future,
                             lambda: recovery_index(status[n:]) is not None, timeout)
        if answer is None:
            client.remove_pending_request(future)
            log('recover: the answer was lost; rig/status shows the rig recovering')
            n += recovery_index(status[n:])     # running again from there on
        elif not answer.success:
            raise RunFailed(f'recover: the rig refused: {answer.message}')
        else:
            log(f'recover: {answer.message}')
            n = len(status)
        left = max(0.0, timeout - (time.monotonic() - t_call))
        if not spin_until(lambda: any(
                s.safe_state == RigStatus.SAFE_RUNNING and s.car_on_belt for s in status[n:]),
                left):
            raise RunFailed(f'recover: the rig is not running {timeout:g} s after the call')
        log('recover: the rig runs again')
    finally:
        executor.shutdown(timeout_sec=0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
