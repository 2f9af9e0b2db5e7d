"""``rig/recover`` from a command line: call it and wait until the rig runs again (rclpy client).

The call itself answers at once (:mod:`.safe_stop`: the rig then holds the car while it brings
the belt up to speed); :func:`recover` also waits until ``rig/status`` says ``SAFE_RUNNING`` with
the car on the belt, so that a person or a script knows the rig is running when it returns.
"""
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import Trigger

from irs_common import qos
from irs_msgs.msg import RigStatus


def recover(timeout: float = 30.0, log=print) -> bool:
    """Call ``rig/recover`` and wait up to ``timeout`` [s] for the rig to run; True if it does."""
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node('irs_recover', context=context)
    status = []
    node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS_LIVE)
    client = node.create_client(Trigger, 'rig/recover')
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + timeout

    def spin_until(predicate) -> bool:
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.05)
        return True
    try:
        if not spin_until(client.service_is_ready):
            log('recover: no rig/recover service (is vehicle_sim running in real time?)')
            return False
        future = client.call_async(Trigger.Request())
        if not spin_until(future.done):
            log('recover: rig/recover did not answer')
            return False
        answer = future.result()
        log(f'recover: {answer.message}')
        if not answer.success:
            return False
        n = len(status)
        running = spin_until(lambda: any(
            s.safe_state == RigStatus.SAFE_RUNNING and s.car_on_belt for s in status[n:]))
        log('recover: the rig runs again' if running else
            f'recover: not running after {timeout:g} s')
        return running
    finally:
        executor.shutdown(timeout_sec=0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
