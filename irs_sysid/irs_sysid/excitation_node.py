"""``excitation`` node: an open-loop identification input on the steering or the belt drive.

Publishes one :mod:`irs_control.reference` signal (``signal.type``: ``schedule`` for the paper's
voltage steps of Fig. 5, ``chirp`` for swept sines, or step, square, sine, constant) on

* ``target: steering``: ``steering/command`` (irs_msgs/SteeringCommand), ``front_angle`` = the
  signal [rad], ``rear_angle`` = 0 rad;
* ``target: drive``: ``treadmill/drive`` (irs_msgs/TreadmillDriveCommand), ``voltage`` = the
  signal [V].

With ``use_sim_time`` it publishes once per ``/clock`` tick, stamped with that tick, so the rig
pairs it as a lock-step input (name ``steering`` or ``drive`` in the rig's ``lockstep_inputs``);
a tick the rig publishes again is answered again with the same value (the signal is a function
of the tick). Otherwise it publishes at ``rate`` on a wall timer, ``t`` counting from its first
tick. The output is always finite and clipped to ``[-limit, limit]`` (steering) or
``[0, limit]`` (drive: the belt's motor cannot reverse), ``limit`` = 0 meaning the target's own
(0.2618 rad, 12.7 V); a ``limit`` beyond the target's own, or a signal whose range leaves the
bounds, is refused (start-up: one line, exit 2; ``ros2 param set``: the change is
refused). It replaces the lateral controller (steering) or the treadmill regulator
(drive) in an identification experiment; it never closes a loop.
"""
import time

from rclpy.node import Node
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.params import declare_table
from irs_common.ticker import create_ticker
from irs_msgs.msg import SteeringCommand, TreadmillDriveCommand

from .excitation_params import (PARAMS, TARGETS, excitation_problem, excitation_value,
                                output_limit, signal_from_params)

# Builders of the messages published every step (irs_common.msg_builder).
_HEADER, _DRIVE = builder(Header), builder(TreadmillDriveCommand)
_STEERING = builder(SteeringCommand)


class ExcitationNode(Node):
    """Publishes the excitation signal on ``steering/command`` or ``treadmill/drive`` per tick.

    Writable parameters (``ros2 param set``): ``signal.*``, rebuilt at once (set a schedule's
    ``signal.times`` and ``signal.values`` together: until they agree the previous signal stays).
    """

    def __init__(self, **node_options):
        super().__init__('excitation', **node_options)
        self.p = declare_table(self, PARAMS, on_change=self._on_parameter,
                               check=excitation_problem)
        self.signal = signal_from_params(self.p)
        self.bounds = output_limit(self.p)
        self.clipped = 0
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        topic = TARGETS[self.p['target']][0]
        if self.p['target'] == 'drive':
            self.pub = self.create_publisher(TreadmillDriveCommand, topic, qos.COMMAND_PUB)
            self._message = self._drive
        else:
            self.pub = self.create_publisher(SteeringCommand, topic, qos.COMMAND_PUB)
            self._message = self._steering
        self.ticker = create_ticker(self, self.p['rate'], self._publish)
        self.create_service(Trigger, 'excitation/restart', self._on_restart)
        self.get_logger().info(
            f"excitation on {topic}: {self.signal!r}, clipped to [{self.bounds[0]:g}, "
            f"{self.bounds[1]:g}] {TARGETS[self.p['target']][1]}")

    def _on_parameter(self, name, value):
        try:
            self.signal = signal_from_params(self.p)
        except ValueError as exc:
            self.get_logger().warning(f'parameter {name} = {value!r} stored, signal not rebuilt '
                                      f'(the previous one stays): {exc}')
            return
        self.get_logger().info(f'parameter {name} = {value!r} applied: signal rebuilt')

    def _on_restart(self, _request, response):
        self.ticker.restart()
        response.success = True
        response.message = 'the excitation starts again at the next tick'
        return response

    @staticmethod
    def _drive(stamp, value):
        return _DRIVE(header=_HEADER(stamp=stamp), voltage=value)

    @staticmethod
    def _steering(stamp, value):
        return _STEERING(header=_HEADER(stamp=stamp), front_angle=value, rear_angle=0.0)

    def _publish(self, stamp, t):
        raw = self.signal(t)
        value = excitation_value(self.signal, t, self.bounds)
        if value != raw:
            self.clipped += 1
            self.warner.warn('clip', f'excitation {raw!r} at t = {t:.3f} s clipped to {value:g}',
                             time.monotonic())
        self.pub.publish(self._message(stamp, value))


def main(args=None):
    return run_node(ExcitationNode, args)
