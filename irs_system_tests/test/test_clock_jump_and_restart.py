"""``/clock`` jumping back, for every node that keeps time state, and the restart services.

``test_bad_input_stamps.py`` covers the lateral controller and the arm pose estimator; here the
other four: the treadmill regulator and the chassis controller (stamped steps: a jump back by
0.4 s, less than the 1 s stamp rule, is answered only because the clock-jump callback reset
their time state), the reference generator and the excitation (tickers: after the jump they
answer the earlier time with the signal's value at it). Then ``reference/restart`` and
``excitation/restart`` (real time): the signal starts again from t = 0.
"""
from geometry_msgs.msg import PoseStamped, TwistStamped
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import (BeltSpeed, LateralReference, SteeringCommand, TreadmillDriveCommand,
                          WheelEncoders, WheelTorqueCommand)
from irs_bringup.processes import NodeSpec

T0 = 10_000_000_000          # [ns] 10 s
MS = 1_000_000


class Stepper:
    """Publish ``/clock`` and stamped inputs; collect the node's answers by stamp."""

    def __init__(self, ros, inputs, out_type, out_topic):
        node = ros.node
        self.ros = ros
        self.clock = node.create_publisher(Clock, '/clock', qos.CLOCK)
        self.inputs = [(node.create_publisher(t, topic, qos.SENSOR), make)
                       for t, topic, make in inputs]
        self.got = {}
        self.sub = node.create_subscription(
            out_type, out_topic, lambda m: self.got.setdefault(to_ns(m.header.stamp), m),
            qos.COMMAND)

    def ready(self, n_clock_subs=1):
        pubs = [p for p, _ in self.inputs]
        return (self.ros.wait_for_matched([*pubs, self.sub], timeout=30.0)
                and self.ros.wait_for_endpoints('/clock', subscribers=n_clock_subs))

    def tick(self, ns):
        self.clock.publish(Clock(clock=from_ns(ns)))

    def step(self, ns):
        """/clock = ns, then every input stamped ns; True once answered (a few resends: the
        node may take an input before the /clock sent ahead of it, then it is dropped).
        """
        for _ in range(10):
            self.tick(ns)
            for pub, make in self.inputs:
                msg = make()
                msg.header.stamp = from_ns(ns)
                pub.publish(msg)
            if self.ros.spin_until(lambda: ns in self.got, 0.5):
                return True
        return False


def _pose():
    p = PoseStamped()
    p.pose.position.x = 0.3
    p.pose.orientation.w = 1.0
    return p


def _belt():
    b = BeltSpeed()
    b.speed = 1.2
    return b


def _encoders():
    e = WheelEncoders()
    e.velocity = [1.2 / 0.033] * 4
    e.counts = [0, 0, 0, 0]
    return e


def _jump_back_is_answered(stepper, proc):
    for k in range(10):
        assert stepper.step(T0 + k * MS), f'step {k} not answered\n{proc.tail()}'
    back = T0 - 400 * MS           # 0.4 s back: without the clock jump, out of order
    for k in range(5):
        assert stepper.step(back + k * MS), f'not answered after /clock jumped back\n{proc.tail()}'
    assert 'clock jumped back' in proc.output()
    assert proc.poll() is None


def test_regulator_clock_jump_back(ros, launch):
    proc = launch(NodeSpec('irs_treadmill', 'treadmill_regulator',
                           params={'use_sim_time': True, 'safety.stale_timeout': 10.0}))
    stepper = Stepper(ros, [(TwistStamped, 'velocity', TwistStamped), (BeltSpeed, 'belt/speed',
                                                                          _belt),
                            (PoseStamped, 'pose', _pose)],
                      TreadmillDriveCommand, 'treadmill/drive')
    assert stepper.ready()
    _jump_back_is_answered(stepper, proc)


def test_chassis_controller_clock_jump_back(ros, launch):
    proc = launch(NodeSpec('irs_control', 'chassis_controller',
                           params={'use_sim_time': True, 'stale_timeout': 10.0}))
    stepper = Stepper(ros, [(PoseStamped, 'pose', _pose), (TwistStamped, 'velocity', TwistStamped),
                            (BeltSpeed, 'belt/speed', _belt),
                            (WheelEncoders, 'wheels/encoders', _encoders)],
                      WheelTorqueCommand, 'wheels/torque_command')
    assert stepper.ready()
    _jump_back_is_answered(stepper, proc)


def _ticker_jump(ros, launch, spec, out_type, out_topic, value_of):
    """A ticker node with a 0.1 step at t = 5 s: at 10 s it answers 0.1; after /clock jumps
    back to 2 s it answers that tick, with the signal's value there (0), and says so.
    """
    proc = launch(spec)
    stepper = Stepper(ros, [], out_type, out_topic)
    assert stepper.ready()
    assert stepper.step(T0), proc.tail()
    assert value_of(stepper.got[T0]) == 0.1
    assert stepper.step(2_000_000_000), proc.tail()
    assert value_of(stepper.got[2_000_000_000]) == 0.0
    assert 'time jumped back' in proc.output()
    assert proc.poll() is None


STEP = {'signal.type': 'step', 'signal.amplitude': 0.1, 'signal.start_time': 5.0}


def test_reference_generator_clock_jump_back(ros, launch):
    _ticker_jump(ros, launch, NodeSpec('irs_control', 'reference_generator',
                                       params={'use_sim_time': True, **STEP}),
                 LateralReference, 'lateral/reference', lambda m: m.lateral_position)


def test_excitation_clock_jump_back(ros, launch):
    _ticker_jump(ros, launch, NodeSpec('irs_sysid', 'excitation',
                                       params={'use_sim_time': True, 'target': 'steering',
                                               **STEP}),
                 SteeringCommand, 'steering/command', lambda m: m.front_angle)


def _restart(ros, launch, spec, service, out_type, out_topic, value_of):
    """Real time, a 0.1 step at t = 1 s: once it is 0.1, ``service`` -> 0.0 again, then 0.1."""
    proc = launch(spec)
    got = []
    sub = ros.node.create_subscription(out_type, out_topic, lambda m: got.append(value_of(m)),
                                       qos.COMMAND)
    assert ros.wait_for_matched([sub], timeout=30.0)
    assert ros.spin_until(lambda: got and got[-1] == 0.1, 10.0), proc.tail()
    client = ros.node.create_client(Trigger, service)
    assert ros.spin_until(client.service_is_ready, 20.0)
    future = client.call_async(Trigger.Request())
    assert ros.spin_until(future.done, 20.0) and future.result().success
    n = len(got)
    assert ros.spin_until(lambda: 0.0 in got[n:], 5.0), 'the signal did not start again'
    m = got.index(0.0, n)
    assert ros.spin_until(lambda: 0.1 in got[m:], 5.0), 'the restarted step did not come'
    assert proc.poll() is None


RT_STEP = {'signal.type': 'step', 'signal.amplitude': 0.1, 'signal.start_time': 1.0,
           'rate': 50.0}


def test_reference_restart(ros, launch):
    _restart(ros, launch, NodeSpec('irs_control', 'reference_generator', params=RT_STEP),
             'reference/restart', LateralReference, 'lateral/reference',
             lambda m: m.lateral_position)


def test_excitation_restart(ros, launch):
    _restart(ros, launch, NodeSpec('irs_sysid', 'excitation',
                                   params={'target': 'steering', **RT_STEP}),
             'excitation/restart', SteeringCommand, 'steering/command', lambda m: m.front_angle)
