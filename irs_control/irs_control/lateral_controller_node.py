"""``lateral_controller`` node: MRC/RST or PI lateral control of the sensor point.

One control step per measurement of the sensor point's lateral displacement y [m]
(``lateral_position``, 1 kHz by default): the controller's steer [rad] goes out on
``steering/command`` stamped with the measurement's stamp, ``lateral/status`` carries the
telemetry. With ``reference_sync`` (lock-step) a measurement waits for the reference of the same
stamp, so the run does not depend on DDS delivery order. Bad, stale, future-stamped or out-of-order
input gives zero steer or is dropped, never a non-finite command; an unstable design is refused at
start-up, and so is a negative delay margin with the steer's transport delay ``check_delay``
(:mod:`.design_check`). The node exists so that the controller core runs in the graph unchanged;
topics, the bad-input rule, the design check and the writable parameters:
:class:`LateralControllerNode`.
"""
import math
import time

from geometry_msgs.msg import PointStamped
from rclpy.node import Node
from std_msgs.msg import Header

from irs_common import qos
from irs_common.answer_cache import AnswerCache
from irs_common.node_main import run_node
from irs_common.input_checks import ThrottledWarner
from irs_common.msg_builder import builder
from irs_common.node_edge import EdgeGate, StaleTimer
from irs_common.params import declare_table
from irs_common.stamp_gate import OK, REPEAT, RESET, StampGate
from irs_common.stamp_sync import StampSync
from irs_common.stamps import clock_now_ns, to_ns
from irs_msgs.msg import LateralControllerStatus, LateralReference, SteeringCommand

from .controller_factory import make_controller
from .design_check import require_stable
from .discrete_rst import STATE_RUNNING
from .lateral_params import PARAMS, controller_config

# Builders of the messages published every step (irs_common.msg_builder).
_COMMAND, _STATUS = builder(SteeringCommand), builder(LateralControllerStatus)
_HEADER = builder(Header)

class LateralControllerNode(Node):
    """Thin wrapper around the controller built by :func:`make_controller`.

    Subscribes ``lateral_position`` (geometry_msgs/PointStamped, y = sensed lateral displacement of
    the sensor point [m]) and ``lateral/reference`` (irs_msgs/LateralReference); publishes
    ``steering/command`` (irs_msgs/SteeringCommand, front axle) stamped with the measurement's
    stamp, every step, and ``lateral/status`` (irs_msgs/LateralControllerStatus) every
    ``status_decimation`` steps and whenever the state changes (telemetry, not part of the loop).

    One control step per measurement (the measurement stream sets the rate; ``dt`` must equal its
    period, 1 kHz by default). With ``reference_sync`` (lock-step runs) a measurement is answered
    only once the reference with the same stamp has arrived, so the run does not depend on DDS
    delivery order (one whose partner never comes is dropped after 1 s with a line naming what
    was missing); otherwise the latest reference is used. A NaN/inf measurement, or a measurement
    older than ``stale_timeout`` (checked on a timer), gives zero steer and a STALE/INVALID status;
    the controller restarts from rest when valid measurements return.

    Bad input (the rule at this node's edge; see irs_common.stamp_gate and the controllers'
    bad-input rule in :mod:`.discrete_rst`):

    - values: every step goes through ``controller.step_checked``: an invalid reference (NaN, inf,
      beyond 2 m) holds the last valid one (RUNNING, reason on ``lateral/status``); an invalid
      measurement gives zero steer, resets the controller and reports INVALID. The published steer
      is always finite and within ``steer_limit``;
    - stamps, against the node clock: a measurement or reference stamped more than
      ``future_tolerance`` s ahead is dropped (not answered, not stored); one older than the last
      step is dropped as out of order, unless it is more than 1 s older (a replay loop, a restarted
      publisher): then the controller, the stamp memory and the pairing restart and the message is
      taken; a measurement with the stamp of the last step is answered again with the same command
      (lock-step resend);
    - the node clock jumping back (``/clock`` of ``bag play --loop --clock``) resets the same time
      state; a STALE measurement resets the controller (it restarts from rest).

    Start-up design check: the controller built from the parameters is closed with the plant model
    ``check_plant`` (default ``identified``, the rig's Eq. 6 plant, with the actuator lag) --
    continuous and sampled closed-loop poles, gain and phase margins (:mod:`.design_check`). An
    unstable loop is refused with one line naming the poles and the plant (exit code 2) unless
    ``allow_unstable_design`` is true (then a warning); the result is logged either way.

    Writable parameters (``ros2 param set``): ``stale_timeout`` and ``default_reference`` (applied
    at once: it is the reference until the next ``lateral/reference`` message; without
    ``reference_sync``).
    """

    def __init__(self, **node_options):
        super().__init__('lateral_controller', **node_options)
        self.p = declare_table(self, PARAMS, on_change=self._on_parameter)
        cfg = controller_config(self.p)
        spec = make_controller(cfg)
        self.controller = spec.controller
        self.get_logger().info(spec.summary)
        # Refuse a design that is unstable on the configured plant (ValueError: one line, exit 2).
        _check, message, ok = require_stable(cfg, spec.controller, spec.design,
                                             f"{cfg['mode'].upper()} design")
        (self.get_logger().info if ok else self.get_logger().warning)(message)
        self.reference = self.p['default_reference']
        # reference stamps (without reference_sync); the steps' gate is self.edge's
        self.ref_gate = StampGate(int(round(self.p['future_tolerance'] * 1e9)))
        self.sync = StampSync(('y', 'ref')) if self.p['reference_sync'] else None
        self.answer = AnswerCache()   # what was published for the last stamp (re-sent on a repeat)
        self.last_meas_time = None
        self.state = LateralControllerStatus.STATE_STALE
        self.published_state = None
        self.steps = 0
        # rclpy's throttled logging inspects the caller's source on every call (~1 ms): at 1 kHz
        # that alone overloads the loop, so per-step warnings are throttled before rclpy.
        self.warner = ThrottledWarner(self.get_logger().warning, 1.0)
        self.edge = EdgeGate(self, self.p['future_tolerance'], 'measurement',
                             self._reset_time_state, self.warner)
        self.pub_cmd = self.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND_PUB)
        self.pub_status = self.create_publisher(
            LateralControllerStatus, 'lateral/status', qos.SENSOR_PUB
        )
        self.create_subscription(
            PointStamped, 'lateral_position', self._on_measurement, qos.SENSOR
        )
        self.create_subscription(LateralReference, 'lateral/reference', self._on_reference,
                                 qos.COMMAND)
        self.stale = StaleTimer(self, self.p['stale_timeout'], self._check_stale)

    # ------------------------------------------------------------------ parameters, time
    # rclpy fixes a logging call site's severity at its first call: info from this line
    def _log_info(self, text):
        self.get_logger().info(text)

    def _on_parameter(self, name, value):
        if name == 'stale_timeout':
            self.stale.set_timeout(value)
        elif name == 'default_reference':
            self.reference = value
        self.get_logger().info(f'parameter {name} = {value!r} applied')

    def _reset_time_state(self):
        """Time went back: forget the reference stamps and the controller state (restart from
        rest; the edge gate has forgotten the step stamps). Pending pairs stay: they may hold a
        part of a newer step already taken from the other input.
        """
        self.ref_gate.clear()
        self.controller.reset()
        self.answer.clear()
        self.last_meas_time = None
        self.state = LateralControllerStatus.STATE_STALE

    # ------------------------------------------------------------------ inputs
    def _on_reference(self, msg):
        stamp_ns = to_ns(msg.header.stamp)
        if self.sync is not None:
            if self.edge.admit('reference', stamp_ns, clock_now_ns(self.get_clock())):
                for _, vals in self.sync.add('ref', stamp_ns, msg.lateral_position):
                    self._control_step(vals['y'], vals['ref'])
            return
        now_ns = clock_now_ns(self.get_clock())
        verdict = self.ref_gate.check(stamp_ns, now_ns or None)   # 0: no /clock yet (EdgeGate)
        if verdict == OK or verdict == RESET or verdict == REPEAT:
            self.reference = msg.lateral_position    # screened by the controller at each step
        else:
            self.edge.drop('reference', verdict, stamp_ns, now_ns, self.ref_gate)

    def _on_measurement(self, msg):
        if self.sync is not None:
            stamp_ns = to_ns(msg.header.stamp)
            if self.edge.admit('measurement', stamp_ns, clock_now_ns(self.get_clock())):
                for _, vals in self.sync.add('y', stamp_ns, msg):
                    self._control_step(vals['y'], vals['ref'])
        else:
            self._control_step(msg, self.reference)

    def _control_step(self, msg, reference):
        stamp_ns = to_ns(msg.header.stamp)
        now = self.get_clock().now()
        if not self.edge.take_step(stamp_ns, now.nanoseconds, self.answer):
            return
        y = msg.point.y
        if self.state != LateralControllerStatus.STATE_RUNNING:
            self.controller.reset()  # restart from rest after a stale/invalid period
        out = self.controller.step_checked(reference, y)
        if out.state == STATE_RUNNING:
            self.state = LateralControllerStatus.STATE_RUNNING
            self.last_meas_time = now
            if self.warner.in_episode('invalid'):
                self.warner.end('invalid', self._log_info, 'valid measurements again',
                                time.monotonic())
            if self.warner.in_episode('stale'):   # logged once fresh for 1 s (flapping: one)
                self.warner.end_settled('stale', self._log_info, 'lateral measurement fresh '
                                        'again', time.monotonic())
            error = float(out.reference - y)
            if out.reason:
                self.warner.warn('reference', out.reason, time.monotonic())
        else:
            self.state = LateralControllerStatus.STATE_INVALID
            error = math.nan
            self.warner.once('invalid', out.reason, time.monotonic())   # once while it lasts
        self._publish(msg.header, out.u_sat, out.u_unsat, out.saturated,
                      (float(out.reference), float(y), error))

    def _publish(self, header, steer, unsat, saturated, tracking):
        """The steering command, and the status every ``status_decimation`` steps or on a
        change of state; ``tracking`` = (reference, measurement, error) [m].
        """
        self.answer.start()
        self.answer.publish(self.pub_cmd, _COMMAND(header=header, front_angle=float(steer),
                                                   rear_angle=0.0))
        every = self.p['status_decimation']
        self.steps += 1
        if self.state != self.published_state or (every and self.steps % every == 1 % every):
            self.published_state = self.state
            reference, measurement, error = tracking
            self.answer.publish(self.pub_status, _STATUS(
                header=header, mode=self.p['mode'], state=self.state, reference=reference,
                measurement=measurement, error=error, output_unsaturated=float(unsat),
                output=float(steer), saturated=bool(saturated)))

    def _check_stale(self):
        if self.sync is not None:
            self.edge.expire_unpaired(self.sync)
        if self.state != LateralControllerStatus.STATE_RUNNING or self.last_meas_time is None:
            return
        now = self.get_clock().now()
        age = (now - self.last_meas_time).nanoseconds * 1e-9
        if age > self.p['stale_timeout']:
            self.state = LateralControllerStatus.STATE_STALE    # logged once per transition
            self.controller.reset()                             # restart from rest
            self.warner.once('stale', f'lateral measurement stale ({age:.3f} s old): zero steer, '
                             'controller reset', time.monotonic())
            header = _HEADER(stamp=self.edge.own_command_stamp(now.to_msg()))
            self._publish(header, 0.0, 0.0, False, (float(self.reference), math.nan, math.nan))


def main(args=None):
    return run_node(LateralControllerNode, args)
