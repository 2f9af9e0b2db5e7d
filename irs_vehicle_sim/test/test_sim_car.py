"""Car on the belt: longitudinal integration, off-belt detection, kinematic wheel speeds."""

import math

import numpy as np
import pytest

from irs_vehicle_sim.car_on_belt import CarOnBelt, CarParams, off_belt_edge, wheel_speeds

DT = 1e-3


@pytest.mark.parametrize('psi', [0.0, 0.2])
def test_position_integration_closed_form(psi):
    p = CarParams(tau_u=0.3)
    car = CarOnBelt(p, x0=0.1, u0=0.5)
    uc, vb, v = 1.5, 1.2, 0.05
    n = 1234
    for _ in range(n):
        car.step(uc, psi, v, vb, DT)
    t = n * DT
    e = math.exp(-t / p.tau_u)
    u_exp = uc + (0.5 - uc) * e
    x_exp = 0.1 + math.cos(psi) * (uc * t + (0.5 - uc) * p.tau_u * (1 - e)) \
        - (v * math.sin(psi) + vb) * t
    assert car.u == pytest.approx(u_exp, rel=1e-12)
    assert car.x == pytest.approx(x_exp, rel=1e-10, abs=1e-12)


def test_speed_63_percent_at_tau():
    car = CarOnBelt(CarParams(tau_u=0.3), u0=0.0)
    for _ in range(300):
        car.step(1.0, 0.0, 0.0, 0.0, DT)
    assert car.u == pytest.approx(1 - math.exp(-1), rel=1e-12)


def test_stationary_when_speed_equals_belt():
    car = CarOnBelt(CarParams(), x0=0.0, u0=1.2)
    for _ in range(1000):
        car.step(1.2, 0.0, 0.0, 1.2, DT)
    assert abs(car.x) < 1e-12


def test_off_belt_edges():
    p = CarParams(length=0.4, width=0.2)
    xm, ym = 1.2192 - 0.2, 0.6096 - 0.1
    assert off_belt_edge(0.0, 0.0, p) == ''
    assert off_belt_edge(xm - 1e-9, ym - 1e-9, p) == ''
    assert off_belt_edge(xm + 1e-6, 0.0, p) == 'front'
    assert off_belt_edge(-xm - 1e-6, 0.0, p) == 'rear'
    assert off_belt_edge(0.0, ym + 1e-6, p) == 'left'
    assert off_belt_edge(0.0, -ym - 1e-6, p) == 'right'
    assert off_belt_edge(math.nan, 0.0, p) == 'nonfinite'


def test_wheel_speeds_straight_turn_and_steer():
    p = CarParams(track=0.16, wheel_radius=0.033, lf=0.13, lr=0.12)
    np.testing.assert_allclose(wheel_speeds(1.2, 0, 0, 0, 0, p), [1.2 / 0.033] * 4)
    # pure yaw about the c.g.: left wheels roll backwards by r*track/2
    w = wheel_speeds(0.0, 0.0, 1.0, 0.0, 0.0, p)
    np.testing.assert_allclose(w, np.array([-0.08, 0.08, -0.08, 0.08]) / 0.033)
    # steered wheel aligned with its contact-point velocity rolls at |velocity| / R
    u, r = 1.0, 0.5
    vx, vy = u - r * 0.08, r * 0.13          # front-left contact velocity
    d = math.atan2(vy, vx)
    w = wheel_speeds(u, 0.0, r, d, 0.0, p)
    assert w[0] == pytest.approx(math.hypot(vx, vy) / 0.033)
    assert w[2] == pytest.approx((u - r * 0.08) / 0.033)


def test_bad_params():
    with pytest.raises(ValueError, match='tau_u'):
        CarOnBelt(CarParams(tau_u=0.0))
    with pytest.raises(ValueError, match='length'):
        CarOnBelt(CarParams(length=3.0))
