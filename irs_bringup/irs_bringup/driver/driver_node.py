"""``driver`` node: the transmitter's throttle, as a speed profile over time.

Publishes ``driver/command`` (irs_msgs/DriverCommand, the car's forward speed over the belt
[m/s]) from the profile in the parameters (``profile.times`` [s], ``profile.speeds`` [m/s],
``profile.interpolation``): once per ``/clock`` tick with ``use_sim_time`` (lock-step runs list
``driver`` among the rig's lock-step inputs), otherwise at ``rate`` on a wall timer, with the
profile's time counted from the node's first tick.

No data inputs: only ``/clock`` (with ``use_sim_time``). A negative ``/clock`` is dropped
(irs_common.sim_time); time going back (``bag play --loop --clock``) restarts the profile's time
base (irs_common.ticker calls :meth:`DriverNode._on_reset`); the profile is a function of that
time, so nothing else is reset. All parameters are read-only.
"""
from rclpy.node import Node
from std_msgs.msg import Header

from irs_common import qos
from irs_common.msg_builder import builder
from irs_common.node_main import run_node
from irs_common.params import declare_table
from irs_common.ticker import create_ticker
from irs_msgs.msg import DriverCommand

from .speed_profile import DRIVER_PARAMS as PARAMS, speed_profile

_HEADER, _COMMAND = builder(Header), builder(DriverCommand)   # irs_common.msg_builder


class DriverNode(Node):
    """Publishes ``driver/command`` from the speed profile, per tick of the ticker."""

    def __init__(self, **node_options):
        super().__init__('driver', **node_options)
        self.p = declare_table(self, PARAMS)
        self.profile = speed_profile(self.p)
        self.pub = self.create_publisher(DriverCommand, 'driver/command', qos.COMMAND_PUB)
        self.time_resets = 0
        self.ticker = create_ticker(self, self.p['rate'], self._publish, on_reset=self._on_reset)

    def _on_reset(self):
        """Time went back: the ticker restarts the profile's time; nothing else is time state."""
        self.time_resets += 1

    def _publish(self, stamp, t):
        self.pub.publish(_COMMAND(header=_HEADER(stamp=stamp), speed=float(self.profile(t))))


def main(args=None):
    return run_node(DriverNode, args)
