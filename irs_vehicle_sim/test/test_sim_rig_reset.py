"""RigSimulation.reset_to_start: the car back at its start pose, the off-belt fault cleared, the
clock running on (for a rig/reset service).
"""
import math

import pytest
from hypothesis import given, settings, strategies as st

from irs_vehicle_sim.rig import RigConfig, RigInputs, RigSimulation

V_HOLD = 1.2 / (2.38 / 4.5)  # [V] holds the belt at 1.2 m/s
ANY = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                st.sampled_from([math.nan, math.inf, 1e308, -1e308, 0.0, 0.26]))


def drive_off_the_left_edge(rig):
    """Full left steer until the car is off the belt; returns the step count."""
    for k in range(20000):
        out = rig.step(RigInputs(front_steer=0.26, drive_voltage=V_HOLD, speed_cmd=1.2))
        if out.fault:
            return k
    raise AssertionError('the car never left the belt')


def assert_at_start(rig, out):
    c = rig.config
    assert not out.fault and out.fault_reason == '' and not out.off_belt
    assert (out.x, out.y, out.psi, out.u, out.v, out.yaw_rate) == (c.x0, c.y0, 0.0, c.u0, 0.0, 0.0)
    assert out.actuator_front.achieved == 0.0 and out.actuator_rear.achieved == 0.0
    assert all(math.isfinite(a) for a in out.arm_angles)


def test_reset_to_start_clears_the_off_belt_fault_and_keeps_the_clock():
    rig = RigSimulation(RigConfig.from_dict({'arm': {'enable_noise': False}}))
    drive_off_the_left_edge(rig)
    assert rig.outputs.fault and rig.outputs.fault_reason.startswith('off_belt')
    t, k = rig.time, rig.k
    belt = rig.belt.speed
    out = rig.reset_to_start()
    assert rig.outputs is out and (rig.time, rig.k) == (t, k) and out.time == t
    assert_at_start(rig, out)
    assert rig.belt.speed == belt            # the belt is not teleported
    nxt = rig.step(RigInputs(0.0, 0.0, V_HOLD, 1.2))
    assert nxt.time == pytest.approx(t + rig.config.dt) and not nxt.fault


def test_after_reset_to_start_the_car_moves_like_a_fresh_rig():
    """With the belt reset too, the car/belt dynamics after the reset equal a fresh rig's for
    the same inputs (the clock and the arm-noise stream aside).
    """
    cfg = RigConfig.from_dict({'x0': 0.3, 'y0': 0.02})
    rig, fresh = RigSimulation(cfg), RigSimulation(RigConfig.from_dict({'x0': 0.3, 'y0': 0.02}))
    drive_off_the_left_edge(rig)
    rig.reset_to_start(belt_speed=cfg.belt_speed0)
    for k in range(300):
        u = RigInputs(front_steer=0.05 * math.sin(0.01 * k), drive_voltage=V_HOLD, speed_cmd=1.2)
        a, b = rig.step(u), fresh.step(u)
        assert (a.x, a.y, a.psi, a.y_s, a.belt_speed, a.belt_speed_measured) == \
            (b.x, b.y, b.psi, b.y_s, b.belt_speed, b.belt_speed_measured)
        assert a.actuator_front == b.actuator_front and a.fault == b.fault


def test_reset_to_start_refuses_a_bad_belt_speed_without_changing_anything():
    rig = RigSimulation()
    rig.step(RigInputs(0.1, 0.0, V_HOLD, 1.2))
    before = (rig.outputs.x, rig.outputs.y, rig.belt.speed)
    for bad in (math.nan, -1.0, 100.0):
        with pytest.raises(ValueError, match='reset speed'):
            rig.reset_to_start(belt_speed=bad)
    assert (rig.outputs.x, rig.outputs.y, rig.belt.speed) == before


def test_fault_re_latches_when_the_start_pose_is_off_the_belt():
    rig = RigSimulation(RigConfig.from_dict({'y0': 0.7}))
    assert rig.outputs.fault
    assert rig.reset_to_start().fault_reason == 'off_belt:left'


@settings(max_examples=25, deadline=None)
@given(seq=st.lists(st.tuples(ANY, ANY, ANY), min_size=1, max_size=40))
def test_reset_to_start_after_any_inputs(seq):
    rig = RigSimulation()
    for steer, volt, speed in seq:
        rig.step(RigInputs(steer, 0.0, volt, speed))
    k = rig.k
    out = rig.reset_to_start()
    assert rig.k == k
    assert_at_start(rig, out)
