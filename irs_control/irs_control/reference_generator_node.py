"""``reference_generator`` node: the lateral reference, from a function or the driver console.

The paper's two reference sources: a function in the controller code (``source: function``:
step, square, sine, constant, schedule or chirp, see :mod:`.reference`) or the driver console
(``source: console``: the latest ``console/lateral_position`` value, std_msgs/Float64 [m]).

Publishes ``lateral/reference`` (irs_msgs/LateralReference). With ``use_sim_time`` it publishes
once per ``/clock`` tick, stamped with that tick (lock-step runs pair it with the measurement of
the same stamp); otherwise at ``rate`` on a wall timer. The signal's time counts from the start of
the run (simulation time, or the node's first tick in real time; ``reference/restart``,
std_srvs/Trigger, starts it again), not from the Unix epoch.

Bad console values are refused and ``lateral/reference`` is always finite and within the limit;
bad input, time going back and the writable parameters: :class:`ReferenceGeneratorNode`.
"""
import time

from rclpy.node import Node
from std_msgs.msg import Float64, Header
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.params import declare_table
from irs_common.ticker import create_ticker
from irs_msgs.msg import LateralReference

from .reference import console_reference
from .reference_params import PARAMS, reference_problem, reference_signal

# Builders of the message published every step (irs_common.msg_builder).
_HEADER, _REFERENCE = builder(Header), builder(LateralReference)


class ReferenceGeneratorNode(Node):
    """Publishes ``lateral/reference`` from a signal or the console, per tick.

    Bad input: a console value that is NaN, +-inf or beyond ``console_limit`` is refused
    (:func:`.reference.console_reference`): the last valid console value (0 m before any) stays the
    reference, with a throttled warning, so ``lateral/reference`` is always finite and within the
    limit. Time going back (``/clock`` of ``bag play --loop --clock``) restarts the signal's time
    base (irs_common.ticker); the signal is a function of that time and the console value is not
    time state, so nothing else is reset. A bad ``/clock`` (negative) is dropped by
    irs_common.sim_time.

    Writable parameters (``ros2 param set``): ``signal.*``; the signal is rebuilt at once. A signal
    whose range (:func:`.reference_params.signal_range`) leaves +-1 m is refused, at start-up and
    for every change.
    """

    def __init__(self, **node_options):
        super().__init__('reference_generator', **node_options)
        self.p = declare_table(self, PARAMS, on_change=self._on_parameter,
                               check=reference_problem)
        if self.p['source'] not in ('function', 'console'):
            raise ValueError(f"source must be 'function' or 'console', got {self.p['source']!r}")
        self.signal = reference_signal(self.p)
        self.console_value = 0.0
        self.console_refused = 0
        self.time_resets = 0
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.pub = self.create_publisher(LateralReference, 'lateral/reference', qos.COMMAND_PUB)
        if self.p['source'] == 'console':
            self.create_subscription(Float64, 'console/lateral_position', self._on_console,
                                     qos.COMMAND)
        self.ticker = create_ticker(self, self.p['rate'], self._publish, on_reset=self._on_reset)
        self.create_service(Trigger, 'reference/restart', self._on_restart)

    def _on_parameter(self, name, value):
        try:
            self.signal = reference_signal(self.p)    # self.p is kept current by declare_table
        except ValueError as exc:     # e.g. schedule times set, values not yet: keep the old one
            self.get_logger().warning(f'parameter {name} = {value!r} stored, signal not rebuilt '
                                      f'(the previous one stays): {exc}')
            return
        self.get_logger().info(f'parameter {name} = {value!r} applied: signal rebuilt')

    def _on_reset(self):
        """Time went back: the ticker restarts the signal's time; nothing else is time state."""
        self.time_resets += 1

    def _on_restart(self, _request, response):
        self.ticker.restart()
        response.success = True
        response.message = 'the reference starts again at the next tick'
        return response

    def _on_console(self, msg):
        value, reason = console_reference(msg.data, self.console_value, self.p['console_limit'])
        if reason is not None:
            self.console_refused += 1
            self.warner.warn('console', reason, time.monotonic())
        self.console_value = value

    def _publish(self, stamp, t):
        if self.p['source'] == 'console':
            value, source = float(self.console_value), LateralReference.SOURCE_CONSOLE
        else:
            value, source = float(self.signal(t)), LateralReference.SOURCE_FUNCTION
        self.pub.publish(_REFERENCE(header=_HEADER(stamp=stamp), lateral_position=value,
                                    source=source))


def main(args=None):
    return run_node(ReferenceGeneratorNode, args)
