"""ABS core: slip held near its target on low mu, shorter stops than locked wheels (ROS-free).

The closed loop is the cores alone: the two-track car (irs_vehicle_sim, a test fixture), its
wheel encoders, the arm-pose speed estimate plus the belt speed, the ABS and, for the chassis
tests, the chassis controller.  The controllers see only the encoders, the pose and the belt
speed, never the model's velocities or slips.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_control.abs_control import AbsController, AbsParams, ArmSpeedEstimator, wheel_slips
from irs_vehicle_sim.surface import SurfaceSpec
from irs_vehicle_sim.two_track import TwoTrack
from irs_vehicle_sim.wheel_encoder import WheelEncoders

DT = 1e-3
VB = 1.2
BRAKE = 0.3     # N m per wheel, enough to lock a wheel on mu = 0.8


def brake_run(surface, mode, chassis=None, t_max=2.0):
    """Brake from belt speed until the car stands on the belt.

    ``mode``: ``'locked'`` (friction brakes hold all wheels) or ``'abs'``.  Returns a dict with
    the stopping distance over the belt [m], the time [s], the ground-truth slips while
    ``u > 0.3 m/s`` (for the test's judgement only), the yaw rates, and the car.
    """
    car = TwoTrack(surface=surface, u0=VB)
    enc, est, abs_ = WheelEncoders(), ArmSpeedEstimator(), AbsController()
    psi_prev = car.psi
    slips, yaw, rear = [], [], 0.0
    for k in range(int(t_max / DT)):
        _, w_meas = enc.step(car.omega, DT)
        v_hat = est.step(car.x, car.psi, VB, DT)          # arm pose + belt speed
        r_meas = (car.psi - psi_prev) / DT                # arm heading differentiated
        psi_prev = car.psi
        if mode == 'locked':
            car.step([0.0] * 4, 0.0, 0.0, DT, belt_speed=VB, locked=[True] * 4)
        else:
            req = np.full(4, -BRAKE)
            if chassis is not None:
                co = chassis.step(VB, v_hat, r_meas, 0.0, DT, brake=BRAKE)
                req, rear = co.torques, co.rear_steer
            car.step(abs_.step(req, w_meas, v_hat, DT).torques, 0.0, rear, DT, belt_speed=VB)
        if car.u > 0.3:
            slips.append(car.kappa)
        yaw.append(car.r)
        if car.u < 0.01:
            break
    return {'distance': car.x_belt, 'time': (k + 1) * DT, 'slips': np.array(slips),
            'yaw': np.array(yaw), 'car': car}


def test_abs_stops_shorter_than_locked_wheels_on_low_mu_with_slip_near_target():
    low = SurfaceSpec(mu=0.3)
    locked = brake_run(low, 'locked')
    abs_run = brake_run(low, 'abs')
    assert abs_run['car'].u < 0.01 and locked['car'].u < 0.01
    assert abs_run['distance'] < 0.95 * locked['distance'], (abs_run['distance'],
                                                           locked['distance'])
    target = AbsParams().slip_target
    held = abs_run['slips'][50:]                     # after the first 50 ms
    assert np.all(np.abs(held.mean(axis=0) - target) < 0.02), held.mean(axis=0)
    assert np.all(held.min(axis=0) > -0.5)           # no wheel locked on the way
    assert np.all(locked['slips'][50:] < -0.9)


def test_low_speed_and_drive_pass_through():
    a = AbsController()
    out = a.step([-0.2, -0.2, 0.1, 0.0], [0.0] * 4, 0.05, DT)
    assert out.reason == 'low_speed' and np.allclose(out.torques, [-0.2, -0.2, 0.1, 0.0])
    out = a.step([0.1] * 4, [0.0] * 4, 1.0, DT)      # driving: no slip control
    assert out.reason == 'ok' and np.allclose(out.torques, 0.1) and not out.active.any()
    out = a.step([-0.3] * 4, [0.0] * 4, 1.0, DT)     # locked wheels: braking released
    assert np.all(out.torques > -0.3) and out.active.all()
    assert np.allclose(out.slips, wheel_slips([0.0] * 4, 1.0, 0.033, 0.1))


@pytest.mark.parametrize('bad', [
    ([float('nan')] + [-0.1] * 3, [30.0] * 4, 1.0),
    ([-0.1] * 4, [30.0, float('inf'), 30.0, 30.0], 1.0),
    ([-0.1] * 4, [30.0] * 4, float('nan')),
    ([-0.1] * 3, [30.0] * 4, 1.0),
])
def test_nonfinite_input_gives_zero_torque_and_a_reason(bad):
    out = AbsController().step(*bad, DT)
    assert out.reason == 'nonfinite_input' and np.all(out.torques == 0.0)


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(st.lists(finite, min_size=4, max_size=4), st.lists(finite, min_size=4, max_size=4),
       finite, st.integers(1, 5))
def test_outputs_finite_within_limits_and_never_more_braking(treq, omega, v_hat, steps):
    a = AbsController()
    for _ in range(steps):
        out = a.step(treq, omega, v_hat, DT)
    lim = a.params.torque_limit
    t = np.clip(treq, -lim, lim)
    assert np.all(np.isfinite(out.torques)) and np.all(np.abs(out.torques) <= lim)
    brake = t < 0
    assert np.all(out.torques[brake] >= t[brake]) and np.all(out.torques[brake] <= 0.0)


def test_arm_speed_estimator():
    est = ArmSpeedEstimator(window=5)
    u, psi = 0.9, 0.1
    for k in range(20):     # car at u over the belt, belt at VB: x moves at u cos(psi) - VB
        got = est.step(0.2 + k * DT * (u * math.cos(psi) - VB), psi, VB, DT)
    assert got == pytest.approx(u, rel=1e-9)
    assert est.step(float('nan'), psi, VB, DT) == got
    with pytest.raises(ValueError, match='window'):
        ArmSpeedEstimator(window=0)
    with pytest.raises(ValueError, match='slip_target'):
        AbsParams(slip_target=0.1)
