"""``reference_generator`` node: the lateral reference, from a function or the driver console.

The paper's two reference sources: a function in the controller code (``source: function``:
step, square, sine or constant, see :mod:`.reference`) or the driver console
(``source: console``: the latest ``console/lateral_position`` value, std_msgs/Float64 [m]).

Publishes ``lateral/reference`` (irs_msgs/LateralReference). With ``use_sim_time`` it publishes
once per ``/clock`` tick, stamped with that tick (lock-step runs pair it with the measurement of
the same stamp); otherwise at ``rate`` on a wall timer.
"""
from rclpy.node import Node
from std_msgs.msg import Float64

from irs_common import qos
from irs_common.node_main import run_node
from irs_common.params import Param, declare_table
from irs_common.stamps import to_sec
from irs_common.ticker import create_ticker
from irs_msgs.msg import LateralReference

from .reference import from_dict

PARAMS = [
    Param('source', 'function', "'function' (signal below) or 'console' (console/lateral_position)",
          '-', read_only=True),
    Param('signal.type', 'step', "'constant', 'step', 'square' or 'sine'", '-', read_only=True),
    Param('signal.amplitude', 0.1, 'amplitude (step height, square/sine amplitude)', 'm', -1.0, 1.0,
          read_only=True),
    Param('signal.offset', 0.0, 'offset (value before start_time)', 'm', -1.0, 1.0, read_only=True),
    Param('signal.start_time', 1.0, 'time the signal starts', 's', 0.0, 1e6, read_only=True),
    Param('signal.period', 8.0, 'period of square and sine', 's', 1e-3, 1e6, read_only=True),
    Param('rate', 1000.0, 'publication rate without sim time', 'Hz', 0.1, 10000.0, read_only=True),
]

_FIELDS = {'constant': ('offset',), 'step': ('amplitude', 'start_time', 'offset'),
           'square': ('amplitude', 'period', 'offset', 'start_time'),
           'sine': ('amplitude', 'period', 'offset', 'start_time')}


def signal_from_params(p: dict):
    """Reference signal from the flat ``signal.*`` parameters."""
    kind = p['signal.type']
    if kind not in _FIELDS:
        raise ValueError(f"signal.type must be one of {sorted(_FIELDS)}, got {kind!r}")
    if kind == 'constant':
        return from_dict({'type': 'constant', 'value': p['signal.offset']})
    return from_dict({'type': kind, **{f: p[f'signal.{f}'] for f in _FIELDS[kind]}})


class ReferenceGeneratorNode(Node):
    def __init__(self):
        super().__init__('reference_generator')
        self.p = declare_table(self, PARAMS)
        if self.p['source'] not in ('function', 'console'):
            raise ValueError(f"source must be 'function' or 'console', got {self.p['source']!r}")
        self.signal = signal_from_params(self.p)
        self.console_value = 0.0
        self.pub = self.create_publisher(LateralReference, 'lateral/reference', qos.COMMAND)
        if self.p['source'] == 'console':
            self.create_subscription(Float64, 'console/lateral_position', self._on_console,
                                     qos.COMMAND)
        create_ticker(self, self.p['rate'], self._publish)

    def _on_console(self, msg):
        self.console_value = msg.data

    def _publish(self, stamp):
        ref = LateralReference()
        ref.header.stamp = stamp
        if self.p['source'] == 'console':
            ref.lateral_position = float(self.console_value)
            ref.source = LateralReference.SOURCE_CONSOLE
        else:
            ref.lateral_position = float(self.signal(to_sec(stamp)))
            ref.source = LateralReference.SOURCE_FUNCTION
        self.pub.publish(ref)


def main(args=None):
    return run_node(ReferenceGeneratorNode, args)
