"""The torque car's controller step (``torque_car_control``), ROS-free: the driver's schedule,
the brake modes, the friction-brake hold at standstill, yaw control off/on, bad input.

The car is not simulated here (the closed loops are in test_control_abs/chassis and, through the
graph, irs_system_tests/test/test_torque_car_graph.py): the inputs are chosen so the answer is
known.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_control.chassis_params import LIVE, PARAMS
from irs_control.torque_car_control import TorqueCarConfig, TorqueCarController

R = 0.033
V = 1.2
MS = 1_000_000


def controller(**kw):
    return TorqueCarController(TorqueCarConfig(**kw))


def drive(ctl, n, omega=None, x=lambda k: 0.3, psi=0.0, belt=V, r=0.0, k0=0):
    """``n`` steps of a car standing on the treadmill at belt speed; the last output."""
    omega = [V / R] * 4 if omega is None else omega
    out = None
    for k in range(k0, k0 + n):
        ctl.update_pose(k * MS, x(k), psi, belt)
        out = ctl.step(k * MS, omega, r)
    return out


def test_driving_at_belt_speed_needs_no_torque_and_the_step_steer_starts_on_time():
    ctl = controller(steer_amplitude=0.04, steer_start_time=0.05)
    out = drive(ctl, 50)                                   # t = 0 .. 0.049 s
    assert out.front_steer == 0.0 and out.t == pytest.approx(0.049)
    out = drive(ctl, 1, k0=50)
    assert out.front_steer == 0.04 and out.rear_steer == 0.0     # yaw control off
    assert out.reason == 'ok' and not out.braking
    assert out.v_hat == pytest.approx(V) and np.allclose(out.torques, 0.0, atol=1e-12)
    assert out.r_ref > 0.0                                 # left steer, left turn (REP 103)


def test_a_car_slower_than_the_belt_is_driven_and_a_speed_target_overrides_the_belt():
    ctl = controller()
    out = drive(ctl, 30, x=lambda k: 0.3 - 0.2 * k * 1e-3)     # falls back at 0.2 m/s: 1.0 m/s
    assert out.v_hat == pytest.approx(1.0, abs=1e-9)
    assert np.all(out.torques > 0.0)
    ctl = controller(speed_target=0.5)
    out = drive(ctl, 30)                                   # at 1.2 m/s, asked for 0.5 m/s
    assert np.all(out.torques < 0.0)


def test_target_zero_holds_the_starting_belt_speed_and_relatches_when_set_to_zero_again():
    ctl = controller()
    drive(ctl, 30)                                         # starts at the 1.2 m/s belt
    # the belt speeds up and the car keeps pace (x constant): 1.5 m/s, above the held 1.2
    out = drive(ctl, 30, belt=1.5, k0=30)
    assert out.v_hat == pytest.approx(1.5) and np.all(out.torques < 0.0)
    ctl.config.speed_target = 1.0                          # a target of its own ...
    drive(ctl, 1, belt=1.5, k0=60)
    ctl.config.speed_target = 0.0                          # ... and back: the belt speed now
    first = drive(ctl, 20, belt=1.5, k0=61)
    out = drive(ctl, 10, belt=1.5, k0=81)
    # no speed error: the speed integral stands still (held 1.2 would keep it falling)
    assert np.array_equal(out.torques, first.torques)


@pytest.mark.parametrize('mode', ['abs', 'abs_peak', 'open', 'locked'])
def test_brake_modes_on_a_wheel_slipping_at_minus_half(mode):
    """The arm's speed as the ABS's reference, so the slip is known (-0.5 on FL)."""
    ctl = controller(brake_start_time=0.01, brake_mode=mode, brake_torque=0.2,
                     abs_reference='arm')
    omega = [0.5 * V / R, V / R, V / R, V / R]
    before = drive(ctl, 10, omega=omega)
    assert not before.braking
    first = drive(ctl, 1, omega=omega, k0=10)
    out = drive(ctl, 29, omega=omega, k0=11)
    assert out.braking
    if mode == 'locked':
        assert out.locked == (True,) * 4 and np.all(out.torques == 0.0)
    elif mode == 'open':
        assert out.locked == (False,) * 4 and np.allclose(out.torques, -0.2)
    else:
        assert out.locked == (False,) * 4
        assert np.allclose(out.torques[1:], -0.2) and out.torques[0] > -0.05
        assert out.slips[0] == pytest.approx(-0.5)
        assert np.allclose(first.slip_target, -0.10)   # the peak seeker starts at the baseline
        # ... and 20 ms into the stop raises it by its probe, 0.03
        assert np.allclose(out.slip_target, -0.13 if mode == 'abs_peak' else -0.10)


def test_the_abs_takes_the_wheels_speed_not_the_arms():
    """Wheels rolling at 1.0 m/s while the arm says 1.2 m/s: before the brake the reference is
    the wheels' mean, and at the brake start the ABS sees no slip (full brake), where the arm
    would have seen -0.17 on every wheel and released it.
    """
    ctl = controller(brake_start_time=0.01, brake_mode='abs', brake_torque=0.2)
    omega = [1.0 / R] * 4
    before = drive(ctl, 10, omega=omega)
    # (the wheels correct the torque-integrated speed over 20 ms; the torques here drive)
    assert before.v_ref == pytest.approx(1.0, abs=0.005) and before.v_hat == pytest.approx(V)
    out = drive(ctl, 1, omega=omega, k0=10)
    assert out.braking and np.allclose(out.torques, -0.2)
    assert np.allclose(out.slips, 0.0, atol=0.005)
    arm = controller(brake_start_time=0.01, brake_mode='abs', brake_torque=0.2,
                     abs_reference='arm')
    drive(arm, 10, omega=omega)
    out = drive(arm, 1, omega=omega, k0=10)
    assert np.allclose(out.slips, 1.0 / V - 1.0) and np.all(out.torques > -0.2)


def test_stopped_car_is_held_by_the_friction_brakes_until_the_brake_is_released():
    ctl = controller(brake_start_time=0.0, brake_duration=0.2, brake_mode='abs')
    # the car stands on the belt surface: it moves back with the belt (x falls at V)
    out = drive(ctl, 20, omega=[0.0] * 4, x=lambda k: 0.3 - V * k * 1e-3)
    assert out.v_hat == pytest.approx(0.0, abs=1e-9)
    assert out.locked == (True,) * 4 and np.all(out.torques == 0.0), 'no motor torque backwards'
    assert out.reason == 'low_speed'
    # the estimate rising above v_min again does not release the hold during the event
    out = drive(ctl, 20, x=lambda k: 0.3, k0=20)
    assert out.locked == (True,) * 4
    out = drive(ctl, 1, k0=200)                            # t = 0.2 s: released
    assert not out.braking and out.locked == (False,) * 4


def test_yaw_control_answers_a_yaw_rate_error_and_off_does_not():
    for yaw_control, rear, diff in (('off', False, False), ('rear_steer', True, False),
                                    ('differential', False, True), ('both', True, True)):
        ctl = controller(yaw_control=yaw_control)
        out = drive(ctl, 30, r=0.2)                        # turning left, straight wanted
        assert (out.rear_steer != 0.0) == rear, yaw_control
        right_minus_left = out.torques[1] - out.torques[0]
        assert (abs(right_minus_left) > 1e-9) == diff, yaw_control
        if rear:
            assert out.rear_steer > 0.0       # rear steer left turns the car right
        if diff:
            assert right_minus_left < 0.0     # more drive on the left turns it right


@pytest.mark.parametrize('bad', ['omega', 'pose', 'belt', 'yaw'])
def test_bad_input_gives_zero_commands_and_a_reason_and_the_next_step_recovers(bad):
    ctl = controller(yaw_control='both', steer_amplitude=0.05, brake_start_time=0.02)
    drive(ctl, 10)
    omega = [V / R, math.nan, V / R, V / R] if bad == 'omega' else [V / R] * 4
    ctl.update_pose(10 * MS, math.nan if bad == 'pose' else 0.3, 0.0,
                    math.inf if bad == 'belt' else V)
    out = ctl.step(10 * MS, omega, math.nan if bad == 'yaw' else 0.0)
    assert not out.ok and out.reason != 'ok'
    assert np.all(out.torques == 0.0) and out.locked == (False,) * 4
    assert (out.front_steer, out.rear_steer) == (0.0, 0.0)
    out = drive(ctl, 1, k0=11)
    assert out.ok and out.front_steer == 0.05


def test_a_pose_that_stops_coming_stops_the_drive_after_pose_timeout_and_a_fresh_one_resumes():
    """The speed estimate differentiates the poses: when they stop, it freezes. A car falling
    back at 0.2 m/s is driven while poses come; with the last pose 100 ms old the encoder
    samples still get an answer, beyond it zero torque and steer (``stale_pose``).
    """
    ctl = controller(steer_amplitude=0.05, pose_timeout=0.1)
    fall = lambda k: 0.3 - 0.2 * k * 1e-3                  # noqa: E731
    out = drive(ctl, 30, x=fall)
    assert out.ok and np.all(out.torques > 0.0)
    for k in range(30, 130):                               # encoders only: pose of k = 29
        out = ctl.step(k * MS, [V / R] * 4, 0.0)
        assert out.ok, k
    out = ctl.step(130 * MS, [V / R] * 4, 0.0)             # 101 ms after the last pose
    assert out.reason == 'stale_pose' and np.all(out.torques == 0.0)
    assert (out.front_steer, out.rear_steer) == (0.0, 0.0)
    out = drive(ctl, 1, x=fall, k0=131)                    # a fresh pose: driving again
    assert out.ok and out.front_steer == 0.05
    with pytest.raises(ValueError, match='pose_timeout'):
        TorqueCarConfig(pose_timeout=0.0)


def test_nan_yaw_rate_does_not_matter_without_yaw_control():
    ctl = controller(yaw_control='off')
    out = drive(ctl, 5, r=math.nan)
    assert out.ok


finite = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(omega=st.lists(finite, min_size=4, max_size=4), x=finite, psi=finite, belt=finite,
       r=finite, mode=st.sampled_from(['abs', 'abs_peak', 'open', 'locked']),
       yaw=st.sampled_from(['off', 'rear_steer', 'differential', 'both']))
def test_commands_are_finite_and_within_limits_for_any_input(omega, x, psi, belt, r, mode, yaw):
    ctl = controller(brake_start_time=0.001, brake_mode=mode, yaw_control=yaw,
                     steer_amplitude=0.1)
    for k in range(3):
        ctl.update_pose(k * MS, x, psi, belt)
        out = ctl.step(k * MS, omega, r)
        assert np.all(np.isfinite(out.torques)) and np.all(np.abs(out.torques) <= 0.3)
        assert math.isfinite(out.front_steer) and abs(out.rear_steer) <= 0.2618
        assert len(out.locked) == 4
        assert np.all(np.isfinite(out.slip_target)) and np.all(out.slip_target <= 0.0)


def test_bad_configuration_is_refused_with_a_sentence_and_live_names_exist():
    with pytest.raises(ValueError, match='brake.mode'):
        TorqueCarConfig(brake_mode='skid')
    with pytest.raises(ValueError, match='yaw_control'):
        TorqueCarConfig(yaw_control='torque_vectoring')
    with pytest.raises(ValueError, match='abs.reference'):
        TorqueCarConfig(abs_reference='gps')
    with pytest.raises(ValueError, match='finite'):
        TorqueCarConfig(brake_start_time=math.nan)
    names = {p.name for p in PARAMS}
    defaults = {p.name: p.default for p in PARAMS}
    cfg = TorqueCarConfig.from_params(defaults)
    for name, attr in LIVE.items():
        assert name in names and hasattr(cfg, attr)
