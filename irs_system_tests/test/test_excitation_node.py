"""The ``excitation`` node on its topics: the signal it publishes, per /clock tick, within its
bounds (a signal beyond them is refused at start-up: test_param_limits.py).
"""
import pytest
from rosgraph_msgs.msg import Clock

from irs_common import qos
from irs_common.stamps import from_ns, to_ns
from irs_msgs.msg import SteeringCommand, TreadmillDriveCommand
from irs_bringup.processes import NodeSpec

TIMES = [0.010, 0.020, 0.030]     # [s]
VALUES = [1.0, 12.0, 0.5]         # [V]; 12 V: the limit below


def test_excitation_publishes_its_signal_per_tick_on_either_target(ros, launch):
    """Two excitation nodes (drive: a schedule; steering: a step) answer the same /clock ticks."""
    launch(NodeSpec('irs_sysid', 'excitation', name='excitation_drive', params={
        'use_sim_time': True, 'target': 'drive', 'limit': 12.0, 'signal.type': 'schedule',
        'signal.times': TIMES, 'signal.values': VALUES, 'signal.offset': 0.25}))
    launch(NodeSpec('irs_sysid', 'excitation', name='excitation_steering', params={
        'use_sim_time': True, 'target': 'steering', 'signal.type': 'step',
        'signal.amplitude': 0.25, 'signal.start_time': 0.02, 'signal.offset': -0.2}))
    drive, steer = {}, {}
    subs = [ros.node.create_subscription(TreadmillDriveCommand, 'treadmill/drive',
                                         lambda m: drive.setdefault(to_ns(m.header.stamp), m),
                                         qos.COMMAND),
            ros.node.create_subscription(SteeringCommand, 'steering/command',
                                         lambda m: steer.setdefault(to_ns(m.header.stamp), m),
                                         qos.COMMAND)]
    clock = ros.node.create_publisher(Clock, '/clock', qos.CLOCK)
    assert ros.wait_for_matched([*subs, clock], timeout=30.0), 'excitation did not match'
    ticks = [k * 5_000_000 for k in range(9)]         # 0, 5, ..., 40 ms
    for ns in ticks:
        msg = Clock()
        msg.clock = from_ns(ns)

        def answered(ns=ns, msg=msg):
            if ns not in drive or ns not in steer:
                clock.publish(msg)      # again until answered (a subscription matched late)
                ros.executor.spin_once(timeout_sec=0.01)
            return ns in drive and ns in steer
        assert ros.spin_until(answered, 20.0), f'no answer to tick {ns} ns'
    # the schedule up to the 12 V limit, the offset before the first time
    assert {ns // 1_000_000: drive[ns].voltage for ns in ticks} == {
        0: 0.25, 5: 0.25, 10: 1.0, 15: 1.0, 20: 12.0, 25: 12.0, 30: 0.5, 35: 0.5, 40: 0.5}
    # the step: -0.2 rad before 20 ms, then 0.05 rad
    assert {ns // 1_000_000: steer[ns].front_angle for ns in ticks} == pytest.approx({
        0: -0.2, 5: -0.2, 10: -0.2, 15: -0.2, 20: 0.05, 25: 0.05, 30: 0.05,
        35: 0.05, 40: 0.05}, abs=1e-15)
    assert all(m.rear_angle == 0.0 for m in steer.values())
