"""Pose estimator: validation, rejection, staleness, velocities."""
import math

import numpy as np
import pytest

from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics
from irs_sensing.pose_estimator import PoseEstimator, PoseEstimatorParams

DT = 0.001


def feed(est, traj, t0=0.0, belt_speed=0.0):
    """traj: list of (x, y, psi); returns list of (estimate, reason)."""
    g = est.params.geometry
    out = []
    for k, (x, y, psi) in enumerate(traj):
        q = inverse_kinematics(x, y, psi, g)
        out.append(est.update(*q, stamp=t0 + k * DT, belt_speed=belt_speed))
    return out


def test_pose_and_sensor_point():
    est = PoseEstimator(PoseEstimatorParams(ds=0.2))
    (e, reason), = feed(est, [(0.3, -0.1, 0.25)])
    assert reason == ''
    assert (e.x_cg, e.y_cg, e.psi) == pytest.approx((0.3, -0.1, 0.25), abs=1e-9)
    assert e.y_s == pytest.approx(-0.1 + 0.2 * math.sin(0.25))
    assert e.x_s == pytest.approx(0.3 + 0.2 * math.cos(0.25))
    assert not e.velocity_valid and math.isnan(e.xdot)


def test_an_estimate_is_a_whole_record():
    import dataclasses
    from irs_sensing.pose_estimator import PoseEstimate
    est = PoseEstimator(PoseEstimatorParams(ds=0.2))
    e = [e for e, _ in feed(est, [(0.3, -0.1 + 1e-4 * k, 0.25) for k in range(40)])][-1]
    assert e.velocity_valid
    # every field present and equal to a record built through the constructor
    assert e == PoseEstimate(**dataclasses.asdict(e))


@pytest.mark.parametrize('kind', ['lowpass', 'savgol'])
def test_constant_velocity_car_frame(kind):
    est = PoseEstimator(PoseEstimatorParams(differentiator=kind, window=15))
    psi = 0.3
    vx, vy = 0.4, -0.1   # treadmill-frame velocity [m/s]
    vb = 1.5
    traj = [(-0.2 + vx * k * DT, 0.1 + vy * k * DT, psi) for k in range(600)]
    res = feed(est, traj, belt_speed=vb)
    e, _ = res[-1]
    assert e.velocity_valid
    assert e.xdot == pytest.approx(vx, abs=1e-6)
    assert e.ydot == pytest.approx(vy, abs=1e-6)
    assert e.yaw_rate == pytest.approx(0.0, abs=1e-6)
    # over-the-belt velocity rotated into the car frame
    ub = vx + vb
    assert e.u == pytest.approx(ub * math.cos(psi) + vy * math.sin(psi), abs=1e-6)
    assert e.v == pytest.approx(-ub * math.sin(psi) + vy * math.cos(psi), abs=1e-6)
    # consistency with conventions.md: dx/dt = u cos psi - v sin psi - V_b
    assert e.u * math.cos(psi) - e.v * math.sin(psi) - vb == pytest.approx(vx, abs=1e-6)


def test_yaw_rate_across_pi_wrap():
    est = PoseEstimator(PoseEstimatorParams())
    r = 2.0
    traj = [(0.0, 0.0, math.pi - 0.5 + r * k * DT) for k in range(600)]  # crosses +pi at 0.25 s
    res = feed(est, traj)
    assert all(e is not None for e, _ in res)
    psis = np.array([e.psi for e, _ in res])
    assert np.any(psis > 3.1) and np.any(psis < -3.1)   # the wrapped heading did jump
    # after the filter has settled (~0.2 s) the rate stays exact across the wrap at 0.25 s
    rates = np.array([e.yaw_rate for e, _ in res[200:]])
    assert np.all(np.abs(rates - r) < 1e-4)   # a wrap glitch would be ~2 pi (1 - alpha)/dt


def test_rejections_return_none_and_keep_state():
    est = PoseEstimator(PoseEstimatorParams())
    g = est.params.geometry
    q = inverse_kinematics(0.0, 0.0, 0.0, g)
    e, reason = est.update(*q, stamp=0.0)
    assert e is not None and reason == ''
    e, reason = est.update(float('nan'), q[1], q[2], stamp=0.001)
    assert e is None and 'finite' in reason
    e, reason = est.update(*q, stamp=0.0)
    assert e is None and 'does not increase' in reason
    # implausible jump: 0.5 m in 1 ms
    q2 = inverse_kinematics(0.5, 0.0, 0.0, g)
    e, reason = est.update(*q2, stamp=0.002)
    assert e is None and 'jump' in reason
    # heading jump
    q3 = inverse_kinematics(0.0, 0.0, 1.0, g)
    e, reason = est.update(*q3, stamp=0.002)
    assert e is None and 'heading' in reason
    # off the belt: c.g. at x = 1.5 m (belt half-length 1.2192 + margin 0.1)
    est2 = PoseEstimator(PoseEstimatorParams())
    q4 = inverse_kinematics(1.5, 0.0, 0.0, g)
    e, reason = est2.update(*q4, stamp=0.0)
    assert e is None and 'off the belt' in reason
    assert est.last_valid_stamp == 0.0


def test_joint_range_rejection_modulo_two_pi():
    p = PoseEstimatorParams(joint_min=(-4.1364, -2.5656, -2.5656),
                            joint_max=(0.9948, 2.5656, 2.5656))
    est = PoseEstimator(p)
    g = p.geometry
    # rear-left corner: IK gives theta1 ~ +2.5 rad (== -3.78 rad, inside the range modulo 2 pi)
    q = inverse_kinematics(-1.1, 0.5, 0.0, g)
    assert q[0] > 0.9948
    e, reason = est.update(*q, stamp=0.0)
    assert e is not None, reason
    # theta3 = 2.8 rad is outside +-2.5656 in every 2 pi shift
    e, reason = PoseEstimator(p).update(q[0], q[1], 2.8, stamp=0.0)
    assert e is None and 'joint 3' in reason and 'mechanical range' in reason


def test_jump_allowed_after_long_gap():
    est = PoseEstimator(PoseEstimatorParams(max_speed=2.0))
    g = est.params.geometry
    est.update(*inverse_kinematics(0.0, 0.0, 0.0, g), stamp=0.0)
    assert est.update(*inverse_kinematics(0.3, 0.0, 0.0, g), stamp=0.01)[0] is None
    e, _ = est.update(*inverse_kinematics(0.3, 0.0, 0.0, g), stamp=0.2)
    assert e is not None
    assert not e.velocity_valid   # differentiators restarted after the gap


def test_stale_detection():
    est = PoseEstimator(PoseEstimatorParams(stale_timeout=0.05))
    assert est.stale(0.0) and 'no valid' in est.stale_reason(0.0)
    g = est.params.geometry
    q = inverse_kinematics(0.0, 0.0, 0.0, g)
    est.update(*q, stamp=1.0)
    assert not est.stale(1.04) and est.stale_reason(1.04) == ''
    for k in range(1, 60):  # only bad readings afterwards
        est.update(float('nan'), 0.0, 0.0, stamp=1.0 + k * DT)
    assert est.stale(1.06)
    assert 'stale' in est.stale_reason(1.06)


def test_near_singular_flag():
    # shorter arm so that the stretched arm ends on the belt: tip at y = 0.85 - 1.4 = -0.55 m
    p = PoseEstimatorParams(geometry=ArmGeometry(l1=0.9, l2=0.5))
    e, reason = PoseEstimator(p).update(-math.pi / 2, 0.02, math.pi / 2, stamp=0.0)
    assert e is not None and e.near_singular, reason
    e, reason = PoseEstimator(p).update(-math.pi / 2 - 0.7, 1.4, 0.0, stamp=0.0)
    assert e is not None and not e.near_singular, reason


def test_params_validation():
    with pytest.raises(ValueError):
        PoseEstimatorParams(dt=0.0)
    with pytest.raises(ValueError):
        PoseEstimatorParams(joint_min=(0.0, 0.0, 0.0), joint_max=(0.0, 1.0, 1.0))
    with pytest.raises(ValueError):
        PoseEstimatorParams(differentiator='kalman')
