"""Unit tests of the sensing-arm kinematics (conventions.md, paper Eq. 3)."""
import math

import numpy as np
import pytest

from irs_models.arm_kinematics import (ArmGeometry, ArmPose, ArmReachError, forward_kinematics,
                                        inverse_kinematics, is_near_singular, sensor_point,
                                        singularity_margin, tip_jacobian_determinant, wrap_angle)


def test_fk_hand_computed_default_geometry():
    g = ArmGeometry()  # L1 = L2 = 1, base (0, 0.85), attach 0
    # theta1 = -90 deg, theta2 = +90 deg: link 1 straight down, link 2 along +x.
    p = forward_kinematics(-math.pi / 2, math.pi / 2, 0.0, g)
    assert p.x_tip == pytest.approx(1.0)
    assert p.y_tip == pytest.approx(0.85 - 1.0)
    assert p.psi == pytest.approx(0.0)
    assert (p.x_cg, p.y_cg) == pytest.approx((1.0, -0.15))


def test_fk_stretched_singular_arm():
    g = ArmGeometry()
    p = forward_kinematics(-math.pi / 2, 0.0, math.pi / 2, g)
    assert (p.x_tip, p.y_tip) == pytest.approx((0.0, 0.85 - 2.0), abs=1e-12)
    assert p.psi == pytest.approx(0.0, abs=1e-12)
    assert singularity_margin(0.0) == 0.0
    assert is_near_singular(0.0)
    assert tip_jacobian_determinant(0.0, g) == pytest.approx(0.0)


def test_fk_attach_offset_and_heading():
    g = ArmGeometry(l1=0.8, l2=0.6, base_x=0.1, base_y=0.9, attach_offset=0.12)
    t1, t2, t3 = -1.2, 0.9, 0.5
    x_tip = 0.1 + 0.8 * math.cos(t1) + 0.6 * math.cos(t1 + t2)
    y_tip = 0.9 + 0.8 * math.sin(t1) + 0.6 * math.sin(t1 + t2)
    psi = t1 + t2 + t3
    p = forward_kinematics(t1, t2, t3, g)
    assert p.psi == pytest.approx(psi)
    assert p.x_cg == pytest.approx(x_tip - 0.12 * math.cos(psi))
    assert p.y_cg == pytest.approx(y_tip - 0.12 * math.sin(psi))


def test_fk_psi_wrapped():
    p = forward_kinematics(3.0, 0.5, 0.5, ArmGeometry())
    assert -math.pi < p.psi <= math.pi
    assert p.psi == pytest.approx(4.0 - 2 * math.pi)


def test_wrap_angle_half_open():
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(3 * math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-4.0) == pytest.approx(-4.0 + 2 * math.pi)
    assert wrap_angle(0.1 + 4 * math.pi) == pytest.approx(0.1)


@pytest.mark.parametrize('elbow', [1, -1])
def test_fk_ik_round_trip(elbow):
    rng = np.random.default_rng(7)
    g = ArmGeometry(l1=1.0, l2=0.9, attach_offset=0.1, elbow=elbow)
    for _ in range(500):
        t1 = rng.uniform(-math.pi, math.pi)
        t2 = elbow * rng.uniform(0.05, math.pi - 0.05)
        t3 = rng.uniform(-math.pi, math.pi)
        p = forward_kinematics(t1, t2, t3, g)
        q = inverse_kinematics(p.x_cg, p.y_cg, p.psi, g)
        assert q[0] == pytest.approx(wrap_angle(t1), abs=1e-9)
        assert q[1] == pytest.approx(t2, abs=1e-9)
        assert wrap_angle(q[2] - t3) == pytest.approx(0.0, abs=1e-9)
        assert (elbow * q[1]) > 0


def test_ik_fk_round_trip_on_belt():
    g = ArmGeometry()
    for x in np.linspace(-1.1, 1.1, 9):
        for y in np.linspace(-0.55, 0.55, 5):
            for psi in (-0.3, 0.0, 0.4):
                q = inverse_kinematics(x, y, psi, g)
                p = forward_kinematics(*q, g)
                assert (p.x_cg, p.y_cg, p.psi) == pytest.approx((x, y, psi), abs=1e-9)


def test_ik_stretched_arm_at_boundary():
    g = ArmGeometry()
    q = inverse_kinematics(0.0, 0.85 - 2.0, 0.0, g)
    assert q[1] == pytest.approx(0.0, abs=1e-6)
    assert q[0] == pytest.approx(-math.pi / 2, abs=1e-6)


def test_ik_out_of_reach_raises_with_sentence():
    g = ArmGeometry()
    with pytest.raises(ArmReachError, match='maximum reach'):
        inverse_kinematics(0.0, 0.85 - 2.001, 0.0, g)
    g2 = ArmGeometry(l1=1.0, l2=0.5)
    with pytest.raises(ArmReachError, match='minimum reach'):
        inverse_kinematics(0.1, 0.85, 0.0, g2)
    assert issubclass(ArmReachError, ValueError)
    with pytest.raises(ArmReachError):
        inverse_kinematics(float('nan'), 0.0, 0.0, g)


def test_ik_uses_attach_offset():
    g = ArmGeometry(attach_offset=0.2)
    # c.g. reachable only because the tip is 0.2 m further toward the base? -> tip beyond reach.
    with pytest.raises(ArmReachError):
        inverse_kinematics(0.0, 0.85 - 1.9, -math.pi / 2, g)
    q = inverse_kinematics(0.0, 0.85 - 1.9, math.pi / 2, g)  # tip at 1.7 m
    p = forward_kinematics(*q, g)
    assert (p.x_tip, p.y_tip) == pytest.approx((0.0, 0.85 - 1.7))


def test_singularity_margin_values():
    assert singularity_margin(math.pi) == pytest.approx(0.0)
    assert singularity_margin(-math.pi + 0.01) == pytest.approx(0.01)
    assert singularity_margin(math.pi / 2) == pytest.approx(math.pi / 2)
    assert singularity_margin(-0.2) == pytest.approx(0.2)
    assert not is_near_singular(0.5)
    assert is_near_singular(0.05)


def test_sensor_point():
    p = ArmPose(x_cg=0.1, y_cg=0.2, psi=0.3, x_tip=0.0, y_tip=0.0)
    xs, ys = sensor_point(p, 0.25)
    assert ys == pytest.approx(0.2 + 0.25 * math.sin(0.3))
    assert xs == pytest.approx(0.1 + 0.25 * math.cos(0.3))


@pytest.mark.parametrize('kwargs', [dict(l1=0.0), dict(l2=-1.0), dict(elbow=0),
                                    dict(base_x=float('nan'))])
def test_geometry_validation(kwargs):
    with pytest.raises(ValueError):
        ArmGeometry(**kwargs)


def test_geometry_refuses_a_value_that_is_not_a_number():
    """Interpreted: a ValueError naming the field; compiled, the class's own type check raises
    a TypeError naming the type first (irs_common.native_cores).
    """
    with pytest.raises((ValueError, TypeError), match='attach_offset|float object expected'):
        ArmGeometry(attach_offset='a')
