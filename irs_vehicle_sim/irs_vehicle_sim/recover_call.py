"""``rig/recover`` from a command line: call it and wait until the rig runs again (rclpy client).

The call itself answers at once (:mod:`.safe_stop`: the rig then holds the car while it brings
the belt up to speed); :func:`recover` also waits until ``rig/status`` says ``SAFE_RUNNING`` with
the car on the belt, so that a person or a script knows the rig is running when it returns.
A rig that cannot be found within ``DISCOVERY_TIMEOUT`` s (DDS discovery takes up to about 3 s),
that refuses, or that does not run within ``timeout`` s is a :class:`~irs_common.cli.RunFailed`
(``experiment: error: recover: ...``, exit code 1).
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
    deadline = time.monotonic() + discovery_timeout

    def spin_until(predicate) -> bool:
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.05)
        return True
    try:
        if not spin_until(client.service_is_ready):
            raise RunFailed(f'recover: no rig/recover service within {discovery_timeout:g} s '
                            '(is vehicle_sim or rig_hardware running in real time, in this '
                            'ROS_DOMAIN_ID?)')
        deadline = time.monotonic() + timeout
        future = client.call_async(Trigger.Request())
        if not spin_until(future.done):
            raise RunFailed(f'recover: rig/recover did not answer within {timeout:g} s')
        answer = future.result()
        if not answer.success:
            raise RunFailed(f'recover: the rig refused: {answer.message}')
        log(f'recover: {answer.message}')
        n = len(status)
        if not spin_until(lambda: any(
                s.safe_state == RigStatus.SAFE_RUNNING and s.car_on_belt for s in status[n:])):
            raise RunFailed(f'recover: the rig is not running {timeout:g} s after the call')
        log('recover: the rig runs again')
    finally:
        executor.shutdown(timeout_sec=0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
