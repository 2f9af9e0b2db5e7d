"""Steering actuator vs closed forms (lag, delay, rate limit, backlash, saturation)."""

import math

import numpy as np
import pytest

from irs_vehicle_sim.actuator import ActuatorParams, SteeringActuator, DEFAULT_RATE_LIMIT_RAD_S

DT = 1e-3


def only(**enable):
    flags = dict(enable_lag=False, enable_rate_limit=False, enable_delay=False,
                 enable_backlash=False, enable_saturation=False)
    flags.update(enable)
    return flags


def run(act, cmds, dt=DT):
    return np.array([act.step(c, dt) for c in cmds])


def test_defaults_are_documented_values():
    p = ActuatorParams()
    assert p.lag_hz == 4.6
    assert p.delay == 0.017
    assert p.backlash == pytest.approx(math.radians(0.175))
    assert p.limit == pytest.approx(0.2618, abs=1e-4)
    assert DEFAULT_RATE_LIMIT_RAD_S == pytest.approx(6.981, abs=1e-3)
    assert p.tau == pytest.approx(1 / (2 * math.pi * 4.6))


def test_lag_step_exact_and_63_percent_at_tau():
    p = ActuatorParams(**only(enable_lag=True))
    act = SteeringActuator(p)
    A = 0.05
    y = run(act, [A] * 200)
    k = np.arange(1, 201)
    np.testing.assert_allclose(y, A * (1 - np.exp(-k * DT / p.tau)), rtol=0, atol=1e-15)
    n_tau = int(round(p.tau / DT))  # 35 samples = 0.035 s vs tau = 0.0346 s
    assert y[n_tau - 1] / A == pytest.approx(1 - math.exp(-n_tau * DT / p.tau), abs=1e-12)
    assert y[n_tau - 1] / A == pytest.approx(1 - math.exp(-1), abs=0.01)


def test_delay_is_exact_fifo_quantised_to_dt():
    p = ActuatorParams(**only(enable_delay=True), delay=0.0174)  # -> 17 samples
    act = SteeringActuator(p)
    cmds = np.sin(np.arange(100) * 0.1) * 0.1
    y = run(act, cmds)
    assert act.delay_samples == 17
    np.testing.assert_array_equal(y[:17], 0.0)
    np.testing.assert_array_equal(y[17:], cmds[:-17])


def test_default_delay_17_samples_then_lag_starts():
    act = SteeringActuator(ActuatorParams(**only(enable_delay=True, enable_lag=True)))
    y = run(act, [0.1] * 40)
    np.testing.assert_array_equal(y[:17], 0.0)
    assert y[17] > 0.0


def test_rate_limited_slope():
    p = ActuatorParams(**only(enable_lag=True, enable_rate_limit=True))
    act = SteeringActuator(p)
    y = run(act, [1.0] * 30)  # saturation disabled; limit active while 1 - s > R dt / (1 - a)
    # while (1-a)(u - s) > R dt the servo moves exactly R dt per step
    k = np.arange(1, 11)
    np.testing.assert_allclose(y[:10], k * p.rate_limit * DT, rtol=1e-12)
    assert act.state.rate_limited
    # small steps are not rate limited (pure lag)
    act2 = SteeringActuator(p)
    y2 = run(act2, [0.05] * 5)
    np.testing.assert_allclose(y2, 0.05 * (1 - np.exp(-np.arange(1, 6) * DT / p.tau)))


def test_backlash_dead_zone_and_reversal():
    b = math.radians(0.175)
    act = SteeringActuator(ActuatorParams(**only(enable_backlash=True)))
    # inside the play: no motion
    y = run(act, [0.4 * b, -0.4 * b, 0.49 * b])
    np.testing.assert_array_equal(y, 0.0)
    # pushing forward: output = input - b/2
    assert act.step(2 * b, DT) == pytest.approx(1.5 * b)
    # reversing by less than b: output holds
    assert act.step(1.2 * b, DT) == pytest.approx(1.5 * b)
    # reversing by more than b: output = input + b/2
    assert act.step(0.5 * b, DT) == pytest.approx(1.0 * b)


def test_saturation():
    act = SteeringActuator(ActuatorParams(**only(enable_saturation=True, enable_lag=True)))
    y = run(act, [1.0] * 2000)
    assert act.state.saturated
    assert act.state.delayed == pytest.approx(math.radians(15))
    assert y[-1] == pytest.approx(math.radians(15), abs=1e-12)
    assert np.all(np.abs(y) <= math.radians(15) + 1e-15)


def test_full_chain_state_and_order():
    act = SteeringActuator()
    for _ in range(500):
        act.step(-1.0, DT)
    s = act.state
    assert s.commanded == -1.0 and s.delayed == pytest.approx(-math.radians(15))
    # approached from above: wheel lags the servo by half the play
    assert s.achieved == pytest.approx(s.servo + 0.5 * math.radians(0.175), abs=1e-12)


def test_bad_params_and_dt_change():
    with pytest.raises(ValueError, match='lag_hz'):
        SteeringActuator(ActuatorParams(lag_hz=0.0))
    with pytest.raises(ValueError, match='delay'):
        SteeringActuator(ActuatorParams(delay=-1.0))
    with pytest.raises(ValueError, match='rate_limit'):
        SteeringActuator(ActuatorParams(rate_limit=math.nan))
    act = SteeringActuator()
    act.step(0.0, DT)
    with pytest.raises(ValueError, match='constant'):
        act.step(0.0, 2 * DT)
