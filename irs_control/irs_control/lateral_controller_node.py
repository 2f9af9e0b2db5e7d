"""``lateral_controller`` node: MRC/RST or PI lateral control of the sensor point.

Subscribes ``lateral_position`` (geometry_msgs/PointStamped, y = sensed lateral displacement of
the sensor point [m]) and ``lateral/reference`` (irs_msgs/LateralReference); publishes
``steering/command`` (irs_msgs/SteeringCommand, front axle) stamped with the measurement's stamp,
every step, and ``lateral/status`` (irs_msgs/LateralControllerStatus) every
``status_decimation`` steps and whenever the state changes (telemetry, not part of the loop).

One control step per measurement (the measurement stream sets the rate; ``dt`` must equal its
period, 1 kHz by default). With ``reference_sync`` (lock-step runs) a measurement is answered
only once the reference with the same stamp has arrived, so the run does not depend on DDS
delivery order; otherwise the latest reference is used. A NaN/inf measurement, or a measurement
older than ``stale_timeout`` (checked on a timer), gives zero steer and a STALE/INVALID status;
the controller restarts from rest when valid measurements return.
"""
import math
import time

from geometry_msgs.msg import PointStamped
from rclpy.node import Node

from irs_common import qos
from irs_common.node_main import run_node
from irs_common.input_checks import ThrottledWarner
from irs_common.params import Param, declare_table
from irs_common.stamp_sync import StampSync
from irs_common.stamps import to_ns
from irs_msgs.msg import LateralControllerStatus, LateralReference, SteeringCommand

from .controller_factory import CONTROLLER_DEFAULTS, make_controller

D = CONTROLLER_DEFAULTS
PARAMS = [
    Param('mode', D['mode'], "control law: 'mrc' (RST model reference) or 'pi'", '-', read_only=True),
    Param('dt', D['dt'], 'controller period = measurement period', 's', 1e-5, 1.0, read_only=True),
    Param('plant', D['plant'], "design plant: 'identified' (paper Eq. 6) or a vehicle preset name",
          '-', read_only=True),
    Param('speed', D['speed'], 'forward speed the design assumes (presets only)', 'm/s', 0.01, 50.0,
          read_only=True),
    Param('ds', D['ds'], 'sensor distance ahead of the c.g. the design assumes (presets only)', 'm',
          0.0, 10.0, read_only=True),
    Param('plant_gain', D['plant_gain'], 'high-frequency gain b0 of the identified plant with '
          'actuator; 0 = paper reconstruction 363.394', 'm/(rad s^3)', 0.0, 1e9, read_only=True),
    Param('include_actuator', D['include_actuator'], 'design with the actuator lag in the plant',
          '-', read_only=True),
    Param('actuator_pole', D['actuator_pole'], 'actuator lag pole magnitude (4.6 Hz ~ 29)', 'rad/s',
          0.01, 1e4, read_only=True),
    Param('reference_model_num', D['reference_model_num'], 'reference model Bm(s), highest power '
          'first (paper Eq. 21)', '1/s^k', read_only=True),
    Param('reference_model_den', D['reference_model_den'], 'reference model Am(s), monic, highest '
          'power first (paper Eq. 21)', '1/s^k', read_only=True),
    Param('observer', D['observer'], 'observer polynomial Ao(s), highest power first; [0.0] = '
          'paper choice ((s+12)^2 with actuator, s+12 without)', '1/s^k', read_only=True),
    Param('cancel_zeros', D['cancel_zeros'], "plant zeros to cancel: 'stable' or 'none'", '-',
          read_only=True),
    Param('kp', D['kp'], 'PI proportional gain', 'rad/m', 0.0, 1e6, read_only=True),
    Param('ki', D['ki'], 'PI integral gain', 'rad/(m s)', 0.0, 1e6, read_only=True),
    Param('steer_limit', D['steer_limit'], 'steer command limit (15 deg)', 'rad', 0.0, 1.6,
          read_only=True),
    Param('anti_windup', D['anti_windup'], 'keep the controller state consistent with the '
          'saturated steer', '-', read_only=True),
    Param('stale_timeout', 0.05, 'measurement age after which zero steer is commanded', 's',
          0.001, 10.0),
    Param('reference_sync', False, 'pair each measurement with the reference of the same stamp '
          '(lock-step runs)', '-', read_only=True),
    Param('default_reference', 0.0, 'reference used until one arrives', 'm', -1.0, 1.0),
    Param('status_decimation', 10, 'publish lateral/status every this many steps (and on a state '
          'change); 0 = on state changes only', '1', 0, 1_000_000, read_only=True),
]


class LateralControllerNode(Node):
    """Thin wrapper around the controller built by :func:`make_controller`."""

    def __init__(self, **node_options):
        super().__init__('lateral_controller', **node_options)
        self.p = declare_table(self, PARAMS)
        spec = make_controller({k: self.p[k] for k in CONTROLLER_DEFAULTS})
        self.controller = spec.controller
        self.get_logger().info(spec.summary)
        self.reference = self.p['default_reference']
        self.sync = StampSync(('y', 'ref')) if self.p['reference_sync'] else None
        self.last_stamp_ns = -1
        self.last_answer = None
        self.last_meas_time = None
        self.state = LateralControllerStatus.STATE_STALE
        self.published_state = None
        self.steps = 0
        # rclpy's throttled logging inspects the caller's source on every call (~1 ms): at 1 kHz
        # that alone overloads the loop, so per-step warnings are throttled before rclpy.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.pub_cmd = self.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)
        self.pub_status = self.create_publisher(LateralControllerStatus, 'lateral/status', qos.SENSOR)
        self.create_subscription(PointStamped, 'lateral_position', self._on_measurement, qos.SENSOR)
        self.create_subscription(LateralReference, 'lateral/reference', self._on_reference,
                                 qos.COMMAND)
        self.create_timer(max(self.p['stale_timeout'] / 2.0, 0.001), self._check_stale)

    def _on_reference(self, msg):
        if self.sync is not None:
            for _, vals in self.sync.add('ref', to_ns(msg.header.stamp), msg.lateral_position):
                self._control_step(vals['y'], vals['ref'])
        else:
            self.reference = msg.lateral_position

    def _on_measurement(self, msg):
        if self.sync is not None:
            for _, vals in self.sync.add('y', to_ns(msg.header.stamp), msg):
                self._control_step(vals['y'], vals['ref'])
        else:
            self._control_step(msg, self.reference)

    def _control_step(self, msg, reference):
        stamp_ns = to_ns(msg.header.stamp)
        if stamp_ns <= self.last_stamp_ns:
            if stamp_ns == self.last_stamp_ns and self.last_answer is not None:
                for pub, out in self.last_answer:   # a repeated step: repeat the answer
                    pub.publish(out)
            return  # older than the last step: out of order, ignored
        self.last_stamp_ns = stamp_ns
        y = msg.point.y
        status = LateralControllerStatus()
        status.header = msg.header
        status.mode = self.p['mode']
        status.reference = float(reference)
        status.measurement = float(y)
        if not (math.isfinite(y) and math.isfinite(reference)):
            self.state = LateralControllerStatus.STATE_INVALID
            self.warner.warn('invalid', f'invalid measurement {y!r} or reference {reference!r}: '
                             'zero steer', time.monotonic())
            self._publish(msg.header, 0.0, status, 0.0, False)
            return
        if self.state != LateralControllerStatus.STATE_RUNNING:
            self.controller.reset()  # restart from rest after a stale/invalid period
            self.state = LateralControllerStatus.STATE_RUNNING
        self.last_meas_time = self.get_clock().now()
        out = self.controller.step(reference, y)
        status.error = float(reference - y)
        self._publish(msg.header, out.u_sat, status, out.u_unsat, out.saturated)

    def _publish(self, header, steer, status, unsat, saturated):
        cmd = SteeringCommand()
        cmd.header = header
        cmd.front_angle = float(steer)
        cmd.rear_angle = 0.0
        self.pub_cmd.publish(cmd)
        self.last_answer = [(self.pub_cmd, cmd)]
        every = self.p['status_decimation']
        self.steps += 1
        if self.state != self.published_state or (every and self.steps % every == 1 % every):
            status.state = self.published_state = self.state
            status.output_unsaturated = float(unsat)
            status.output = float(steer)
            status.saturated = bool(saturated)
            self.pub_status.publish(status)
            self.last_answer.append((self.pub_status, status))

    def _check_stale(self):
        if self.state != LateralControllerStatus.STATE_RUNNING or self.last_meas_time is None:
            return
        age = (self.get_clock().now() - self.last_meas_time).nanoseconds * 1e-9
        if age > self.p['stale_timeout']:
            self.state = LateralControllerStatus.STATE_STALE
            self.get_logger().warning(f'lateral measurement stale ({age:.3f} s old): zero steer')
            status = LateralControllerStatus()
            status.header.stamp = self.get_clock().now().to_msg()
            status.mode = self.p['mode']
            status.reference = float(self.reference)
            status.measurement = math.nan
            status.error = math.nan
            self._publish(status.header, 0.0, status, 0.0, False)


def main(args=None):
    return run_node(LateralControllerNode, args)
