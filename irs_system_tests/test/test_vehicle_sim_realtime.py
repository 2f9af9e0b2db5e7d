"""vehicle_sim in real time: invalid commands fall back to the safe value; a late one is held,
then the rig stops under control (docs/safety.md); both reported on rig/status. A command is as
old as the sample it answers: a controller that falls behind is stopped as a silent one is.
"""
import collections
import math
import time

from irs_common import qos
from sensor_msgs.msg import JointState

from irs_msgs.msg import RigStatus, SteeringActuatorState, SteeringCommand
from irs_bringup.processes import NodeSpec


def test_invalid_steering_gives_zero_steer_and_a_late_one_is_held_then_stopped(ros, launch):
    proc = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                           params={'clock_mode': 'realtime', 'dt': 0.005, 'command_timeout': 0.2,
                                   'stall_grace': 1.0, 'status_period': 0.01,
                                   'start_inputs': ['steering']}))
    node = ros.node
    states, status = [], []
    pub = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)
    subs = [
        node.create_subscription(
            SteeringActuatorState, 'steering/state', states.append, qos.SENSOR
        ),
        node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS),
    ]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)

    def send(angle):
        cmd = SteeringCommand()
        cmd.header.stamp = node.get_clock().now().to_msg()
        cmd.front_angle = angle
        pub.publish(cmd)

    def keep_sending(angle, predicate, timeout=10.0):
        def step():
            send(angle)
            ros.executor.spin_once(timeout_sec=0.01)
            return predicate()
        return ros.spin_until(step, timeout)

    # A fresh valid command is applied.
    assert keep_sending(0.1, lambda: states and states[-1].front_commanded == 0.1)
    # A NaN command is rejected: zero steer, counted on rig/status.
    assert keep_sending(math.nan, lambda: states[-1].front_commanded == 0.0)
    assert ros.spin_until(lambda: status and status[-1].rejected_steer_count > 0, 5.0)
    # Valid again, then silence: late after command_timeout, the last command held (the rig says
    # which input is late) ...
    assert keep_sending(0.1, lambda: states[-1].front_commanded == 0.1)
    n, m = len(states), len(status)
    assert ros.spin_until(lambda: any(s.safe_state == RigStatus.SAFE_HOLDING
                                      for s in status[m:]), 5.0)
    holding = next(s for s in status[m:] if s.safe_state == RigStatus.SAFE_HOLDING)
    assert holding.late_inputs == 'steering' and holding.stop_cause == ''
    assert states[-1].front_commanded == 0.1
    # ... and silent beyond stall_grace: the controlled stop, the cause on rig/status and in one
    # log line; the rig steers itself back to the centre line: the 0.1 rad held turned the car
    # left (y, psi > 0), so its lane hold steers right, within the steer limit
    assert ros.spin_until(lambda: status[-1].safe_state >= RigStatus.SAFE_STOPPING, 5.0)
    assert 'steering command late' in status[-1].stop_cause
    assert ros.spin_until(lambda: len(states) > n and -0.2618 <= states[-1].front_commanded < 0.0,
                          5.0)
    assert status[-1].car_on_belt
    assert proc.output().count('controlled stop:') == 1


def test_a_controller_falling_behind_is_held_then_stopped_though_its_commands_keep_coming(
        ros, launch):
    """A steering controller that answers every other arm sample, oldest first, so that its
    answers fall behind the rig by half a second per second while they keep arriving at 100 Hz
    (a process short of CPU working through a queue). The rig ages each command by the sample it
    answers: held once the newest answers a sample older than ``command_timeout``, then the
    controlled stop beyond ``stall_grace``, with that cause. Judged by arrival, the rig would run
    on with commands half a second and more out of date: no gap between two answers comes near
    ``stall_grace``.
    """
    proc = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                           params={'clock_mode': 'realtime', 'dt': 0.005, 'command_timeout': 0.1,
                                   'stall_grace': 0.5, 'status_period': 0.01,
                                   'start_inputs': ['steering']}))
    node = ros.node
    status, queue = [], collections.deque()
    answered, arrived, sent = [0], [0], []      # sent: time.monotonic() of each answer
    pub = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)

    def on_arm(msg):
        if answered[0] == 0:      # the first answer, at once: it starts the rig
            queue.clear()
        queue.append(msg.header.stamp)
        arrived[0] += 1
        if answered[0] == 0 or arrived[0] % 2 == 0:
            cmd = SteeringCommand()
            cmd.header.stamp = queue.popleft()
            pub.publish(cmd)
            sent.append(time.monotonic())
            answered[0] += 1

    subs = [node.create_subscription(JointState, 'arm/joint_states', on_arm, qos.SENSOR),
            node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS)]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)
    assert ros.spin_until(lambda: any(s.safe_state == RigStatus.SAFE_HOLDING for s in status),
                          10.0), [s.safe_state for s in status[-5:]]
    holding = next(s for s in status if s.safe_state == RigStatus.SAFE_HOLDING)
    assert holding.late_inputs == 'steering'
    assert ros.spin_until(lambda: status[-1].safe_state >= RigStatus.SAFE_STOPPING, 10.0)
    cause = status[-1].stop_cause
    assert 'steering command late: the newest answers a sample' in cause, cause
    # the answers kept coming (100 Hz when the machine keeps up): never silent for anything near
    # the grace, so arrival alone would have stopped nothing
    gaps = [b - a for a, b in zip(sent, sent[1:])]
    assert answered[0] >= 50 and max(gaps) < 0.5 / 2, (answered, max(gaps))   # stall_grace / 2
    assert status[-1].car_on_belt
    assert proc.output().count('controlled stop:') == 1


def test_the_hold_and_the_run_stamp_their_samples_on_one_1ms_grid(ros, launch):
    """The rig holding the car before its start publishes the start pose stamped ``t_0 + n dt``
    (steps a late timer tick missed published back to back), and the run goes on from the last
    hold step: every arm sample before and after the start lies on one 1 ms grid, stamps
    strictly increasing. A gap off ``dt`` would restart the estimator's differentiators, and
    the treadmill regulator would get a NaN velocity at the start.
    """
    rig = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim',
                          params={'clock_mode': 'realtime', 'start_inputs': ['steering']}))
    node = ros.node
    stamps, status = [], []
    pub = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)
    subs = [node.create_subscription(
        JointState, 'arm/joint_states',
        lambda m: stamps.append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec),
        qos.SENSOR),
        node.create_subscription(RigStatus, 'rig/status', status.append, qos.STATUS)]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)
    assert ros.spin_until(lambda: len(stamps) >= 500, 10.0), len(stamps)   # 0.5 s of hold
    held = len(stamps)
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and len(stamps) < held + 500:     # started: 0.5 s more
        cmd = SteeringCommand()
        cmd.header.stamp = node.get_clock().now().to_msg()
        pub.publish(cmd)
        ros.executor.spin_once(timeout_sec=0.005)
    assert len(stamps) >= held + 500, (held, len(stamps))
    assert "inputs ['steering'] present: starting" in rig.output(), rig.tail()
    assert status and not status[-1].stop_cause, status[-1:]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    off_grid = [(i, g) for i, g in enumerate(gaps) if g <= 0 or g % 1_000_000]
    assert not off_grid, (held, off_grid[:10])
    assert collections.Counter(gaps).most_common(1)[0][0] == 1_000_000
