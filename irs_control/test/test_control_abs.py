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

from scipy.optimize import minimize_scalar

from irs_control.abs_control import AbsController, AbsParams, ArmSpeedEstimator, wheel_slips
from irs_control.abs_peak import PeakSeeker, PeakSeekParams
from irs_control.abs_reference import WheelSpeedObserver
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


def test_per_wheel_slip_targets():
    """Every wheel at slip -0.15: the wheel with target -0.10 is released, the one with -0.20
    keeps the full brake (it slips less than asked).
    """
    a = AbsController()
    omega = [0.85 * 1.0 / 0.033] * 4
    out = a.step([-0.2] * 4, omega, 1.0, DT, slip_target=[-0.10, -0.20, -0.10, -0.20])
    assert np.allclose(out.slips, -0.15)
    assert out.torques[0] > -0.2 and out.torques[1] == pytest.approx(-0.2)
    assert out.active[0] and not out.active[1]


def test_wheel_speed_observer_follows_the_car_over_a_slowing_belt():
    """Rolling, then braking below the locking torque, while the belt slows at 0.5 m/s^2: the
    reference from the encoders, the applied torques and the measured belt speed stays within
    5 mm/s of the car's true speed over the belt, but at the brake onset (the arm is not used);
    with the wheels held it is their speed.
    """
    car = TwoTrack(u0=VB)
    enc = WheelEncoders()
    enc.reset(car.omega, DT)
    obs = WheelSpeedObserver()
    torques, belt, err = np.zeros(4), VB, []
    for k in range(250):
        _, w = enc.step(car.omega, DT)
        v = obs.step(w, torques, k >= 100, False, belt, DT)
        err.append(v - car.u)
        torques = np.full(4, -0.1) if k >= 100 else np.zeros(4)    # 4 m/s^2 from 0.1 s on
        car.step(torques, 0.0, 0.0, DT, belt_speed=belt, belt_accel=-0.5)
        belt -= 0.5 * DT
    assert car.u < 0.7 * VB                     # it did brake
    err = np.array(err[50:])                    # the first 50 ms average the encoders' steps
    # measured: 2.5 mm/s rolling, 7.0 mm/s at the brake onset (the encoders' 2.5 ms lag on the
    # wheels' deceleration; the inertia term's integral is exact after it), 3.9 mm/s from 20 ms
    # after the onset on
    assert np.max(np.abs(err)) < 0.008 and np.max(np.abs(err[70:])) < 0.005
    assert obs.step([0.0] * 4, [0.0] * 4, True, True, belt, DT) == 0.0


def _burckhardt(c1, c2, c3):
    return lambda s: c1 * (1.0 - np.exp(-c2 * s)) - c3 * s


def _feed(seeker, mu, n=300, i=0):
    """Settled samples of ``mu(s)`` over s in [0.02, 0.30] into wheel ``i``'s fit, with the
    target decisions as the seeker makes them after a probe.
    """
    seeker.probed[i] = True
    for k in range(n):
        s = 0.02 + 0.28 * ((k * 0.618) % 1.0)
        seeker._learn(i, s, float(mu(s)))
        seeker._retarget(i)


@pytest.mark.parametrize('name, coeffs, moves', [
    ('dry asphalt', (1.2801, 23.99, 0.52), True),    # peak 1.170 at 0.170; 5 % over 0.10
    ('wet asphalt', (0.857, 33.822, 0.347), False),  # peak 0.801 at 0.131; 1 % over 0.10
    ('snow', (0.1946, 94.129, 0.0646), False),       # peak 0.190 at 0.060; 1 % under 0.10
])
def test_peak_seeker_moves_only_for_a_gain_and_to_the_fitted_peak(name, coeffs, moves):
    mu = _burckhardt(*coeffs)
    seeker = PeakSeeker()
    _feed(seeker, mu)
    s_pk = minimize_scalar(lambda s: -mu(s), bounds=(0.0, 1.0), method='bounded').x
    fit = seeker.curve(0, seeker.slips)
    assert seeker.slips[np.argmax(fit)] == pytest.approx(min(s_pk, 0.25), abs=0.01), name
    if moves:
        assert seeker.target[0] > 0.12 and mu(seeker.target[0]) > 0.99 * mu(s_pk), name
    else:
        assert seeker.target[0] == 0.10, name
    assert np.all(seeker.target[1:] == 0.10)      # the other wheels saw nothing


def test_peak_seeker_restarts_at_the_baseline_when_the_surface_changes():
    seeker = PeakSeeker()
    _feed(seeker, _burckhardt(1.2801, 23.99, 0.52))
    assert seeker.target[0] > 0.12
    _feed(seeker, _burckhardt(0.1946, 94.129, 0.0646), n=40)     # snow from now on
    assert seeker.restarts >= 1 and seeker.target[0] == 0.10
    with pytest.raises(ValueError, match='slip_min <= baseline'):
        PeakSeekParams(baseline=0.3)
