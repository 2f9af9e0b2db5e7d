"""``treadmill_regulator`` node: keeps the car at its longitudinal set point with the belt speed.

Inputs: ``pose`` (PoseStamped, car c.g. in the treadmill frame), ``velocity`` (TwistStamped, car
velocity in the car frame relative to the treadmill), ``belt/speed`` (irs_msgs/BeltSpeed). Pose
and velocity of the same stamp are paired (they come from the same arm reading); the belt speed
too when ``sync_belt_speed`` is set. One regulator step per pose: ``treadmill/drive``
(TreadmillDriveCommand, stamped like the pose) every step and ``treadmill/state``
(TreadmillState) every ``state_decimation`` steps and whenever the mode changes.

Safety (irs_treadmill.safety): a car near a belt end or edge cuts the drive (0 V: the belt
coasts) and latches a fault, published in ``treadmill/state`` until reset through the
``treadmill/reset_fault`` service (std_srvs/Trigger) or a message on ``treadmill/reset``
(std_msgs/Empty). A NaN pose or no pose for ``safety.stale_timeout`` s cuts the drive too, until
the next valid pose (an input fault, not a dangerous car: it is not latched).
"""
import math

from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.node import Node
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.node_main import run_node
from irs_common.params import declare_table, unflatten
from irs_common.stamp_sync import StampSync
from irs_common.stamps import to_ns
from irs_msgs.msg import BeltSpeed, TreadmillDriveCommand, TreadmillState

from .regulator import BeltSpeedRegulator, RegulatorParams
from .regulator_params import regulator_parameter_table
from .safety import TRANSIENT, SafetyMonitor, SafetyParams


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class TreadmillRegulatorNode(Node):
    def __init__(self, **node_options):
        super().__init__('treadmill_regulator', **node_options)
        self.p = declare_table(self, regulator_parameter_table())
        nested = unflatten(self.p)
        self.regulator = BeltSpeedRegulator(RegulatorParams.from_dict(nested['regulator']))
        self.safety = SafetyMonitor(SafetyParams.from_dict(nested['safety']))
        self.dt = 1.0 / self.p['rate_hz']
        inputs = ['pose'] + (['velocity'] if self.p['use_velocity_input'] else []) \
            + (['belt'] if self.p['sync_belt_speed'] else [])
        self.sync = StampSync(tuple(inputs))
        self.belt_speed = math.nan
        self.last_stamp_ns = -1
        self.last_answer = None
        self.reported_fault = None
        self.published_mode = None
        self.steps = 0
        self.pub_drive = self.create_publisher(TreadmillDriveCommand, 'treadmill/drive', qos.COMMAND)
        self.pub_state = self.create_publisher(TreadmillState, 'treadmill/state', qos.SENSOR)
        self.create_subscription(PoseStamped, 'pose', lambda m: self._add('pose', m), qos.SENSOR)
        if self.p['use_velocity_input']:
            self.create_subscription(TwistStamped, 'velocity', lambda m: self._add('velocity', m),
                                     qos.SENSOR)
        self.create_subscription(BeltSpeed, 'belt/speed', self._on_belt, qos.SENSOR)
        self.create_subscription(Empty, 'treadmill/reset', lambda _m: self._reset(), qos.COMMAND)
        self.create_service(Trigger, 'treadmill/reset_fault', self._on_reset_service)
        self.create_timer(max(self.safety.params.stale_timeout / 4.0, 0.001), self._check_stale)

    def _on_belt(self, msg):
        if self.p['sync_belt_speed']:
            self._add('belt', msg)
        else:
            self.belt_speed = msg.speed

    def _add(self, name, msg):
        for stamp_ns, vals in self.sync.add(name, to_ns(msg.header.stamp), msg):
            self._step(stamp_ns, vals)

    def _step(self, stamp_ns, vals):
        if stamp_ns <= self.last_stamp_ns:
            if stamp_ns == self.last_stamp_ns and self.last_answer is not None:
                for pub, out in self.last_answer:   # a repeated step: repeat the answer
                    pub.publish(out)
            return  # older: out of order, ignored
        self.last_stamp_ns = stamp_ns
        pose = vals['pose']
        x, y = pose.pose.position.x, pose.pose.position.y
        belt = vals['belt'].speed if 'belt' in vals else self.belt_speed
        xdot = None
        if 'velocity' in vals:
            psi = _yaw(pose.pose.orientation)
            v = vals['velocity'].twist.linear
            xdot = v.x * math.cos(psi) - v.y * math.sin(psi)
        self.safety.update_position(x, y, stamp_ns * 1e-9)
        out = self.regulator.update(x, belt if math.isfinite(belt) else 0.0, self.dt, xdot=xdot,
                                    enabled=self.safety.drive_permitted and self.p['enabled'])
        voltage = self.safety.gate(out.voltage) if self.p['enabled'] else 0.0
        self._publish(pose.header.stamp, voltage, belt, x, out.voltage == 0.0 and out.speed_setpoint < belt)

    def _publish(self, stamp, voltage, belt, x, coasting):
        drive = TreadmillDriveCommand()
        drive.header.stamp = stamp
        drive.voltage = float(voltage)
        self.pub_drive.publish(drive)
        st = TreadmillState()
        st.header.stamp = stamp
        st.belt_speed = float(belt)
        st.drive_voltage = float(voltage)
        st.position_setpoint = float(self.regulator.params.x_ref)
        st.position = float(x)
        st.position_error = float(x - self.regulator.params.x_ref)
        if self.safety.faulted:
            st.mode = TreadmillState.MODE_FAULT
        elif not self.p['enabled']:
            st.mode = TreadmillState.MODE_OFF
        else:
            st.mode = TreadmillState.MODE_COAST if coasting else TreadmillState.MODE_DRIVE
        st.fault_code = int(self.safety.fault)
        st.fault_text = self.safety.status_text() if self.safety.faulted else ''
        self.last_answer = [(self.pub_drive, drive)]
        every = self.p['state_decimation']
        self.steps += 1
        if st.mode != self.published_mode or (every and self.steps % every == 1 % every):
            self.published_mode = st.mode
            self.pub_state.publish(st)
            self.last_answer.append((self.pub_state, st))
        if self.safety.faulted and self.reported_fault != self.safety.fault:
            self.reported_fault = self.safety.fault
            kind = 'until the input is valid again' if self.safety.fault in TRANSIENT else \
                'latched until reset'
            self.get_logger().error(f'treadmill fault, drive cut ({kind}): {st.fault_text}')
        elif not self.safety.faulted and self.reported_fault is not None:
            self.get_logger().info(f'treadmill input valid again: drive resumes (was: '
                                   f'{self.reported_fault.text})')
            self.reported_fault = None

    def _check_stale(self):
        if self.safety.faulted or self.last_stamp_ns < 0:
            return
        now = self.get_clock().now()
        if self.safety.check(now.nanoseconds * 1e-9):
            self.regulator.reset()
            self._publish(now.to_msg(), 0.0, self.belt_speed, math.nan, False)

    def _reset(self):
        self.safety.reset()
        self.regulator.reset()
        self.reported_fault = None
        self.last_stamp_ns = -1
        self.get_logger().info('treadmill fault reset')

    def _on_reset_service(self, _request, response):
        was = self.safety.status_text()
        self._reset()
        response.success = True
        response.message = f'reset (was: {was})'
        return response


def main(args=None):
    return run_node(TreadmillRegulatorNode, args)
