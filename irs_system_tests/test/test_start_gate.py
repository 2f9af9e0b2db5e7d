"""A lock-step node's first step reaches a consumer that matched late (``start_subscribers``,
:mod:`irs_common.start_gate`), and the gate's rules on a stand-in node.

A volatile DDS writer delivers nothing to a reader it matches after the write: without the gate,
a recorder whose reader the node matched after step 0 misses step 0 for good (seen as a
per-node lock-step bag that lacked the excitation's first ``steering/command``).
"""
import logging

from geometry_msgs.msg import PoseStamped
import pytest
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from irs_bringup.experiment import clock_overrides, expected_endpoints, load_experiment
from irs_bringup.processes import NodeSpec
from irs_common import qos
from irs_common.start_gate import StartGate, parse_start_subscribers
from irs_common.stamps import from_ns, to_ns
from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics
from irs_msgs.msg import SteeringCommand


def _arm_reading():
    msg = JointState()
    msg.header.stamp = from_ns(0)
    msg.name = ['arm_joint1', 'arm_joint2', 'arm_joint3']
    msg.position = [float(a) for a in inverse_kinematics(0.1, -0.05, 0.1, ArmGeometry())]
    return msg


def _tick():
    msg = Clock()
    msg.clock = from_ns(0)
    return msg


#: (node spec, its stepping input: topic, QoS, message at t = 0; its output: type, topic)
CASES = {
    'ticker': (NodeSpec('irs_sysid', 'excitation', params={
        'use_sim_time': True, 'target': 'steering', 'signal.type': 'step',
        'signal.amplitude': 0.1, 'signal.start_time': 0.0, 'signal.offset': 0.0,
        'start_subscribers': '/steering/command=2'}),
        ('/clock', qos.CLOCK_PUB, _tick), (SteeringCommand, 'steering/command')),
    'input-driven': (NodeSpec('irs_sensing', 'arm_pose_estimator', params={
        'use_sim_time': True, 'pose_decimation': 1, 'start_subscribers': '/pose=2'}),
        ('arm/joint_states', qos.SENSOR, _arm_reading), (PoseStamped, 'pose')),
}


@pytest.mark.parametrize('case', CASES)
def test_the_first_step_waits_for_the_subscriber_that_comes_last(ros, launch, case):
    """The node leaves step 0 unanswered while one of its two expected subscriptions is missing
    (through its Ticker, or its EdgeGate); step 0 published again (as the rig does) once both
    exist is answered to both, once.
    """
    spec, (in_topic, in_qos, make), (out_type, out_topic) = CASES[case]
    launch(spec)
    early, late = [], []
    witness = ros.node.create_subscription(
        out_type, out_topic, lambda m: early.append(to_ns(m.header.stamp)), qos.SENSOR)
    stimulus = ros.node.create_publisher(type(make()), in_topic, in_qos)
    assert ros.wait_for_matched([witness, stimulus], timeout=30.0), f'{case} did not match'
    step0 = make()
    stimulus.publish(step0)
    assert not ros.spin_until(lambda: early, 1.0), \
        f'the node answered step 0 before its second subscription existed: {early}'
    ros.node.create_subscription(out_type, out_topic,
                                 lambda m: late.append(to_ns(m.header.stamp)), qos.SENSOR)

    def answered():
        if not late:
            stimulus.publish(step0)          # the rig's resend, until the node answers
            ros.executor.spin_once(timeout_sec=0.05)
        return bool(late and early)
    assert ros.spin_until(answered, 30.0), f'no answer: early {early}, late {late}'
    assert late[0] == 0 and early[0] == 0
    assert set(late) == set(early) == {0}


def test_every_lock_step_node_waits_for_each_consumer_of_its_topics():
    """The runner's ``start_subscribers``: every published topic with subscribers in the run,
    with the run's count (recorder included), for each node of a lock-step experiment.
    """
    for name in ('figure10_mrc_with_actuator', 'sysid_actuator_steps', 'torque_braking_abs_low'):
        exp = load_experiment(name)
        expected = expected_endpoints(exp)
        published = set()
        for entry in exp.nodes:
            spec = clock_overrides(exp, entry, 0.001)['start_subscribers']
            waits = parse_start_subscribers(spec)
            assert all(expected[t][1] == n for t, n in waits.items()), (name, entry.name)
            published |= set(waits)
        assert published == set(expected), name   # each topic of the run, by its publisher


class _Publisher:
    def __init__(self, topic, counts):
        self.topic_name, self.counts = topic, iter(counts)

    def get_subscription_count(self):
        return next(self.counts)


class _Node:
    """Just what :class:`StartGate` reads of an rclpy node."""

    def __init__(self, spec, publishers):
        self.spec, self.publishers = spec, publishers

    def has_parameter(self, name):
        return name == 'start_subscribers'

    def get_parameter(self, _name):
        return type('P', (), {'value': self.spec})()

    def get_name(self):
        return 'stand_in'

    def get_logger(self):
        return logging.getLogger('stand_in')


def test_the_gate_opens_when_matched_or_after_its_timeout_and_then_stays_open(caplog):
    gate = StartGate(_Node('/a=2, b=1', [_Publisher('/a', [0, 1, 2]), _Publisher('/b', [1] * 3)]))
    assert [gate.ready() for _ in range(3)] == [False, False, True]
    assert gate.open and gate.ready()               # no more look-ups (the counts are spent)

    now = [0.0]
    held = StartGate(_Node('/a=3', [_Publisher('/a', [1] * 5)]), timeout=10.0,
                     clock=lambda: now[0])
    with caplog.at_level(logging.WARNING):
        for now[0] in (100.0, 105.0, 109.99):
            assert not held.ready()
        assert not caplog.text
        now[0] = 110.0
        assert held.ready() and held.open
    assert "going on although ['/a']" in caplog.text

    assert StartGate(_Node('', [])).open            # nothing to wait for
    caplog.clear()
    with caplog.at_level(logging.WARNING):          # a topic the node does not publish
        assert StartGate(_Node('/c=1, /a=1', [_Publisher('/a', [1])])).ready()
    assert "not waiting for ['/c']" in caplog.text
@pytest.mark.parametrize('bad', ['/a', '/a=x', '=1', '/a=-1', '/a=1.5'])
def test_a_malformed_start_subscribers_is_named(bad):
    with pytest.raises(ValueError, match="is not '<topic>=<count>'"):
        parse_start_subscribers(bad)


@pytest.mark.parametrize('package, executable', [('irs_sysid', 'excitation'),
                                                 ('irs_vehicle_sim', 'vehicle_sim')])
def test_a_node_given_a_malformed_start_subscribers_exits_with_one_line(ros, launch, package,
                                                                       executable):
    from irs_system_tests.output_lines import own_lines
    bad = launch(NodeSpec(package, executable, params={'start_subscribers': '/clock=x'}))
    assert ros.spin_until(lambda: bad.poll() is not None, 30.0)
    assert bad.poll() == 2
    lines = own_lines(bad.output())
    assert len(lines) == 1 and "'/clock=x' is not '<topic>=<count>'" in lines[0], lines
