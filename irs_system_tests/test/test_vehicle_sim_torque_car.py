"""The vehicle_sim node with ``plant: two_track`` (the torque car) on its topics, in lock-step.

The test plays the chassis controller: it answers every ``wheels/encoders`` sample t_k with a
``WheelTorqueCommand`` and a ``SteeringCommand`` stamped t_k, and compares what the rig
publishes with the offline core (:func:`irs_vehicle_sim.rig.simulate`) fed the same commands.
"""
import math
import subprocess

from builtin_interfaces.msg import Time
from hypothesis import HealthCheck, Phase, given, settings, strategies as st
import numpy as np
import pytest

from irs_common import qos
from irs_common.stamps import to_ns
from irs_msgs.msg import SteeringCommand, TyreState, WheelEncoders, WheelTorqueCommand
from irs_vehicle_sim.rig import RigConfig, RigInputs, simulate
from irs_bringup.graph import call_rig_start
from irs_bringup.processes import NodeSpec
from std_srvs.srv import Trigger

from irs_system_tests.lockstep_harness import offline_rig_params, rig_spec

V_HOLD = 1.2 / (2.38 / 4.5)      # [V] holds the belt at 1.2 m/s (Eq. 2 DC gain)
T_BRAKE = 0.2                    # [s]
BRAKE = -0.08                    # [N m] per wheel: below locking on mu 0.8 (0.19 N m)
NAN_SPAN = (0.1, 0.15)           # [s] FL torque NaN in this window


def torque_car_params(**extra):
    return dict(plant='two_track', lockstep_inputs=['steering', 'wheels'],
                default_drive_voltage=V_HOLD, **extra)


def command(t):
    """(torques [N m], locked): hold speed against rolling resistance, NaN on FL for a while,
    then brake every wheel.
    """
    tq = [0.014] * 4 if t < T_BRAKE else [BRAKE] * 4
    if NAN_SPAN[0] <= t < NAN_SPAN[1]:
        tq[0] = math.nan
    return tq, [False] * 4


def run_torque_lockstep(ros, command_fn, duration, timeout=300.0):
    """Answer every encoder sample until ``duration`` s; ``{'enc': {stamp: msg}, 'tyre': ...}``."""
    node = ros.node
    rec = {'enc': {}, 'tyre': {}}
    pub_t = node.create_publisher(WheelTorqueCommand, 'wheels/torque_command', qos.COMMAND)
    pub_s = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND)
    end_ns = int(round(duration * 1e9))

    def on_encoders(msg):
        stamp = to_ns(msg.header.stamp)
        if stamp in rec['enc']:
            return                      # a resend of a step already answered
        rec['enc'][stamp] = msg
        if stamp < end_ns:
            tq, locked = command_fn(stamp * 1e-9)
            cmd = WheelTorqueCommand()
            cmd.header.stamp = msg.header.stamp
            cmd.torque = [float(v) for v in tq]
            cmd.locked = [bool(b) for b in locked]
            cmd.torque_limit = 0.3
            pub_t.publish(cmd)
            steer = SteeringCommand()
            steer.header.stamp = msg.header.stamp
            pub_s.publish(steer)

    subs = [node.create_subscription(WheelEncoders, 'wheels/encoders', on_encoders, qos.SENSOR),
            node.create_subscription(TyreState, 'rig/tyre_truth',
                                     lambda m: rec['tyre'].setdefault(to_ns(m.header.stamp), m),
                                     qos.SENSOR)]
    assert ros.wait_for_matched([pub_t, pub_s, *subs], timeout=30.0), 'rig topics did not match'
    client = node.create_client(Trigger, 'rig/start')
    assert ros.spin_until(client.service_is_ready, 30.0), 'rig/start not available'
    ok, message = call_rig_start(ros, client)
    assert ok, message
    n = int(round(duration * 1000)) + 1
    done = ros.spin_until(lambda: all(len(v) >= n for v in rec.values()), timeout)
    assert done, f'lock-step run incomplete: {[len(v) for v in rec.values()]} of {n} samples'
    return rec


def test_torque_car_topics_match_the_offline_core_brake_and_refuse_nan(ros, launch):
    params = torque_car_params()
    proc = launch(rig_spec(start_subscribers='wheels/encoders=1,rig/tyre_truth=1', **params))
    duration = 0.4
    rec = run_torque_lockstep(ros, command, duration)

    # the offline core with the same commands, NaN replaced by the 0 N m the rig must use
    def offline(out):
        tq, locked = command(out.time)
        return RigInputs(drive_voltage=V_HOLD, speed_cmd=1.2, wheel_locked=tuple(locked),
                         wheel_torque=tuple(0.0 if math.isnan(v) else v for v in tq))
    cfg = RigConfig.from_dict(offline_rig_params(**params))
    off = simulate(cfg, offline, duration)
    stamps = sorted(rec['enc'])[:len(off['time'])]
    assert stamps == [int(round(t * 1e9)) for t in off['time']]
    counts = np.array([rec['enc'][s].counts for s in stamps])
    vel = np.array([rec['enc'][s].velocity for s in stamps])
    np.testing.assert_array_equal(counts, off['encoder_counts'])
    np.testing.assert_array_equal(vel, off['encoder_velocity'])
    tyre = [rec['tyre'][s] for s in stamps]
    np.testing.assert_array_equal([m.x_belt for m in tyre], off['x_belt'])
    np.testing.assert_array_equal(np.array([m.omega for m in tyre]), off['wheel_speeds'])
    assert rec['enc'][stamps[0]].counts_per_rev == 2048 and rec['enc'][stamps[0]].window == 5

    # NaN on FL: that wheel had no torque (it slows against rolling resistance, the others do
    # not), and the rig said so in its log
    k0, k1 = (int(round(t * 1000)) for t in NAN_SPAN)
    omega = np.array([m.omega for m in tyre])
    assert omega[k1, 0] < omega[k0, 0] and omega[k1, 0] < omega[k1, 1] - 0.1
    assert 'wheel torque FL nan is not finite; using 0 N m' in proc.output()

    # braking: the wheels and the encoders slow down, the distance over the belt grows slower
    kb = int(round(T_BRAKE * 1000))
    assert np.all(vel[-1] < vel[kb] - 3.0), (vel[kb], vel[-1])
    x_belt = np.array([m.x_belt for m in tyre])
    rate_before = (x_belt[kb] - x_belt[kb - 100]) / 0.1
    rate_after = (x_belt[-1] - x_belt[-101]) / 0.1
    assert rate_after < rate_before - 0.05, (rate_before, rate_after)
    assert all(math.isfinite(v) for m in tyre for v in m.fx)


def test_realtime_missing_nan_and_stale_torque_commands_coast(ros, launch):
    """Real time: before any command, a NaN wheel and after ``command_timeout`` without
    commands the wheels get 0 N m (the tyres carry only rolling resistance), each reported.
    """
    # stall_grace: the torque car's physics runs slower than real time on a loaded 2-core
    # machine, and a rig more than stall_grace behind real time makes its controlled stop (its
    # own wheel torques: irs_vehicle_sim/test/test_sim_safe_stop.py); this test is about the
    # torque commands
    proc = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim', params=torque_car_params(
        clock_mode='realtime', command_timeout=0.2, start_inputs=[''],
        ground_truth_decimation=5, stall_grace=3600.0)))
    node = ros.node
    truth = []
    pub = node.create_publisher(WheelTorqueCommand, 'wheels/torque_command', qos.COMMAND)
    sub = node.create_subscription(TyreState, 'rig/tyre_truth', truth.append, qos.SENSOR)
    assert ros.wait_for_matched([pub, sub], timeout=30.0)
    assert ros.spin_until(lambda: 'no wheel torque command yet' in proc.output(), 10.0)

    def send(torque):
        cmd = WheelTorqueCommand()
        cmd.header.stamp = node.get_clock().now().to_msg()
        cmd.torque = torque
        pub.publish(cmd)

    def braking(fx):         # -0.1 N m / 0.033 m = -3 N; coasting: rolling resistance only
        return [f < -1.5 for f in fx]

    def keep_sending(torque, predicate, timeout=10.0):
        def step():
            send(torque)
            ros.executor.spin_once(timeout_sec=0.005)
            return bool(truth) and predicate(truth[-1])
        return ros.spin_until(step, timeout)

    # the log line comes from the rig's first tick; its tyre truth may still be on its way
    assert ros.spin_until(lambda: bool(truth), 5.0), 'no rig/tyre_truth after the first tick'
    assert not any(braking(truth[-1].fx))
    assert keep_sending([math.nan, -0.1, -0.1, -0.1],
                        lambda m: braking(m.fx) == [False, True, True, True]), truth[-1].fx
    assert 'wheel torque FL nan is not finite; using 0 N m' in proc.output()
    n = len(truth)
    assert ros.spin_until(lambda: len(truth) > n and not any(braking(truth[-1].fx)), 5.0)
    assert ros.spin_until(lambda: 'wheels command stale' in proc.output(), 5.0)


FUZZ = settings(max_examples=10, deadline=None, database=None, derandomize=True,
                phases=[Phase.explicit, Phase.generate], suppress_health_check=list(HealthCheck))
SPECIAL = [math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0, -0.0, 5e-324, 0.3, -0.3]
FLOATS = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True))


def test_fuzz_torque_commands_keep_the_rig_alive_and_its_outputs_finite(ros, launch):
    """Any torque values, locked flags and stamps (a day ahead, zero, negative): the rig keeps
    publishing, and its encoders and tyre truth stay finite.
    """
    proc = launch(NodeSpec('irs_vehicle_sim', 'vehicle_sim', params=torque_car_params(
        clock_mode='realtime', dt=0.005, start_inputs=[''], command_timeout=1.0)))
    node = ros.node
    enc, truth = [], []
    pub = node.create_publisher(WheelTorqueCommand, 'wheels/torque_command', qos.COMMAND)
    subs = [node.create_subscription(WheelEncoders, 'wheels/encoders', enc.append, qos.SENSOR),
            node.create_subscription(TyreState, 'rig/tyre_truth', truth.append, qos.SENSOR)]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0)
    day = 86_400 * 10**9

    @FUZZ
    @given(torque=st.lists(FLOATS, min_size=4, max_size=4),
           locked=st.lists(st.booleans(), min_size=4, max_size=4),
           stamp=st.sampled_from([0, 1, day, -day]))
    def example(torque, locked, stamp):
        now = node.get_clock().now().nanoseconds
        ns = now + stamp if stamp != 1 else now
        cmd = WheelTorqueCommand()
        cmd.header.stamp = Time(sec=ns // 10**9, nanosec=ns % 10**9)
        cmd.torque, cmd.locked = torque, locked
        pub.publish(cmd)
        n = len(enc)
        assert ros.spin_until(lambda: len(enc) > n + 2, 10.0), proc.tail(20)
        assert proc.poll() is None, proc.tail(30)

    example()
    for m in enc:
        assert all(math.isfinite(v) for v in m.velocity), m
    for m in truth:
        assert all(math.isfinite(v) for f in ('fx', 'fy', 'fz', 'omega', 'slip')
                   for v in getattr(m, f)) and math.isfinite(m.x_belt), m


@pytest.mark.parametrize('args, line', [
    (['plant:=two_track', 'surface.mu:=0.0'],
     "parameter 'surface.mu': got 0.0 (out of range), expected a finite double in [0.01, 2.0]"),
    (['plant:=two_track', 'two_track.torque_limit:=0.0'],
     'two_track.torque_limit must be a finite torque > 0 N m, got 0.0.'),
    (['clock_mode:=lockstep', 'lockstep_inputs:=[wheels]'],
     "('wheels' needs plant: two_track)"),
])
def test_bad_torque_car_parameters_stop_the_node_with_one_line(args, line):
    from irs_bringup.executables import resolve_executable
    cmd = [resolve_executable('irs_vehicle_sim', 'vehicle_sim'), '--ros-args']
    for a in args:
        cmd += ['-p', a]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert res.returncode == 2, res.stdout + res.stderr
    errors = [x for x in res.stderr.splitlines() if 'FATAL' in x]
    assert len(errors) == 1 and line in errors[0], res.stderr
    assert 'Traceback' not in res.stderr
