"""Unit tests of the treadmill belt model (paper Sec. 3.1)."""
import math

import numpy as np
import pytest

from irs_vehicle_sim.belt import (BeltParams, TreadmillBelt, coast_distance, coast_speed,
                                  coast_stop_time)


@pytest.mark.parametrize('volts', [1.0, 2.0, 3.0, 4.0])
def test_spin_up_steady_state_and_time_constant(volts):
    belt = TreadmillBelt(BeltParams(delay=0.0))
    dt = 0.001
    v_ss = 2.38 / 4.5 * volts
    n = 222  # 0.222 s, about one time constant 1/4.5 s
    for _ in range(n):
        belt.step(volts, dt)
    assert belt.speed == pytest.approx(v_ss * (1 - math.exp(-4.5 * n * dt)), rel=1e-9)
    for _ in range(3000):
        belt.step(volts, dt)
    assert belt.speed == pytest.approx(v_ss, rel=1e-5)


def test_step_size_independence_exact_discretisation():
    a, b = TreadmillBelt(), TreadmillBelt()

    def u(t):
        return 6.0 if t < 2.0 else (1.0 if t < 6.0 else 0.0)

    for k in range(8000):
        a.step(u(k * 0.001), 0.001)
    for k in range(80):
        b.step(u(k * 0.1), 0.1)
    assert a.speed == pytest.approx(b.speed, abs=1e-9)
    assert a.position == pytest.approx(b.position, abs=1e-9)


def test_transport_delay():
    belt = TreadmillBelt(BeltParams(delay=0.05))
    for _ in range(50):
        belt.step(5.0, 0.001)
    assert belt.speed == 0.0
    belt.step(5.0, 0.001)
    assert belt.speed > 0.0


def test_coast_down_matches_closed_form():
    belt = TreadmillBelt(BeltParams(delay=0.0))
    belt.reset(4.0)
    v0 = 4.0
    t_stop = coast_stop_time(v0)
    assert t_stop == pytest.approx(math.log(1 + 4.0 / 0.27) / 0.158)
    dt = 0.01
    t = 0.0
    while belt.speed > 0.0:
        belt.step(0.0, dt)
        t += dt
        if abs(t - 5.0) < dt / 2:
            assert belt.speed == pytest.approx(coast_speed(v0, 5.0), rel=1e-9)
    print(f'coast-down from {v0} m/s: simulated {t:.2f} s, closed form {t_stop:.3f} s')
    assert abs(t - t_stop) <= dt
    assert belt.position == pytest.approx(coast_distance(v0), abs=1e-9)


def test_drive_cannot_brake_lower_command_coasts():
    belt = TreadmillBelt(BeltParams(delay=0.0))
    belt.reset(4.0)
    # command 1 V (target 0.529 m/s): deceleration limited to friction
    belt.step(1.0, 1.0)
    assert belt.speed == pytest.approx(coast_speed(4.0, 1.0), rel=1e-12)
    for _ in range(40):
        belt.step(1.0, 1.0)
    assert belt.speed == pytest.approx(2.38 / 4.5, rel=1e-6)


def test_max_model_never_faster_than_friction_or_linear():
    p = BeltParams(delay=0.0)
    belt = TreadmillBelt(p)
    rng = np.random.default_rng(3)
    for _ in range(2000):
        u = rng.uniform(0, 10)
        v_prev = belt.speed
        belt.step(u, 0.01)
        dv = (belt.speed - v_prev) / 0.01
        if v_prev > 0:
            assert dv >= -p.b_over_j * (v_prev + p.f_over_b) - 1e-6


def test_voltage_and_top_speed_clamps():
    belt = TreadmillBelt(BeltParams(delay=0.0, u_max=10.0))    # a range that caps it below v_top
    belt.step(50.0, 10.0)
    assert belt.speed == pytest.approx(2.38 / 4.5 * 10.0, rel=1e-9)
    fast = TreadmillBelt(BeltParams(delay=0.0, u_max=20.0))
    fast.step(20.0, 10.0)
    assert fast.speed == pytest.approx(6.7056)
    belt.step(-3.0, 0.1)  # negative -> 0 V -> coasts, never negative
    assert 0.0 < belt.speed < 5.3
    with pytest.raises(ValueError):
        belt.step(float('nan'), 0.01)
    with pytest.raises(ValueError):
        belt.step(1.0, 0.0)


def test_encoder_quantisation_and_delay():
    p = BeltParams(delay=0.0, window_samples=10, delay_samples=2)
    belt = TreadmillBelt(p)
    belt.reset(3.0)
    dt = 0.001
    res = p.speed_resolution(dt)
    assert res == pytest.approx(2 * math.pi * 0.0508 / 4096 / 0.01)
    meas = []
    for _ in range(500):
        belt.step(3.0 / p.dc_gain, dt)
        meas.append(belt.measured_speed)
    m = np.array(meas[20:])
    assert np.all(np.abs(m - 3.0) <= res + 1e-9)
    # values are multiples of the resolution
    assert np.allclose(np.round(m / res) * res, m, atol=1e-9)
    assert abs(np.mean(m) - 3.0) < res / 5


def test_params_validation():
    with pytest.raises(ValueError):
        BeltParams(pole=0.1)
    with pytest.raises(ValueError):
        BeltParams(delay=-1.0)
    with pytest.raises(ValueError):
        BeltParams(window_samples=0)
    with pytest.raises(ValueError):
        TreadmillBelt().reset(-1.0)
