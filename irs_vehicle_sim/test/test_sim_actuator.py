"""Steering actuator vs closed forms: delay, loop, slew limit, gearing, linkage, friction, play,
minimum drive, the wheel limit through the linkage.
"""

import math
from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_vehicle_sim.actuator import (ActuatorParams, SteeringActuator, DEFAULT_RATE_LIMIT_RAD_S,
                                      LEGACY, LEGACY_RATE_LIMIT_RAD_S, PRESETS)

DT = 1e-3


def only(**enable):
    """Every element off but the ones given; gearing 1 (horn = wheel)."""
    flags = dict(enable_lag=False, enable_rate_limit=False, enable_delay=False,
                 enable_backlash=False, enable_saturation=False, enable_friction=False,
                 enable_linkage_geometry=False, gear_ratio=1.0, min_drive=0.0,
                 enable_radio_frame=False, enable_linkage_compensation=False)
    flags.update(enable)
    return flags


def legacy(**enable):
    """The old linear model's numbers with the given elements."""
    return {**LEGACY, **only(**enable)}


def run(act, cmds, dt=DT):
    return np.array([act.step(c, dt) for c in cmds])


def test_defaults_are_documented_values():
    p = ActuatorParams()
    assert p.lag_hz == 4.4 and p.gear_ratio == 3.0 and p.min_drive == 0.5
    assert p.delay == 0.017 and p.radio_frame == 0.020 and p.enable_radio_frame
    assert p.enable_linkage_compensation
    assert p.backlash == pytest.approx(math.radians(0.175))
    assert p.limit == pytest.approx(0.2618, abs=1e-4)
    assert DEFAULT_RATE_LIMIT_RAD_S == pytest.approx(math.radians(60) / 0.11)
    assert LEGACY_RATE_LIMIT_RAD_S == pytest.approx(6.981, abs=1e-3)
    assert p.friction_deadband == pytest.approx(math.radians(0.05))
    assert p.wheel_rate_limit == pytest.approx(DEFAULT_RATE_LIMIT_RAD_S / 3.0)
    assert p.tau == pytest.approx(1 / (2 * math.pi * 4.4))


def test_lag_step_exact_and_63_percent_at_tau():
    p = ActuatorParams(**legacy(enable_lag=True))
    act = SteeringActuator(p)
    A = 0.05
    y = run(act, [A] * 200)
    k = np.arange(1, 201)
    np.testing.assert_allclose(y, A * (1 - np.exp(-k * DT / p.tau)), rtol=0, atol=1e-15)
    n_tau = int(round(p.tau / DT))  # 35 samples = 0.035 s vs tau = 0.0346 s
    assert y[n_tau - 1] / A == pytest.approx(1 - math.exp(-n_tau * DT / p.tau), abs=1e-12)
    assert y[n_tau - 1] / A == pytest.approx(1 - math.exp(-1), abs=0.01)


def test_gear_ratio_alone_is_unity_dc_with_same_pole():
    # horn = N * wheel: without geometry and friction the wheel response does not depend on N
    A = 0.05
    y1 = run(SteeringActuator(ActuatorParams(**only(enable_lag=True))), [A] * 100)
    y3 = run(SteeringActuator(ActuatorParams(**only(enable_lag=True, gear_ratio=3.0))), [A] * 100)
    np.testing.assert_allclose(y3, y1, rtol=1e-12)


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


def test_rate_limit_acts_in_horn_coordinates():
    # horn limit R, gear N: the wheel moves at R / N while the loop is saturated
    N, R = 3.0, DEFAULT_RATE_LIMIT_RAD_S
    p = ActuatorParams(**only(enable_lag=True, enable_rate_limit=True, gear_ratio=N),
                       rate_limit=R)
    act = SteeringActuator(p)
    y = run(act, [0.3] * 30)
    k = np.arange(1, 11)
    np.testing.assert_allclose(y[:10], k * R / N * DT, rtol=1e-12)
    assert act.state.rate_limited
    np.testing.assert_allclose(act.state.horn, N * y[-1], rtol=1e-12)
    # the loop saturates for steer errors above R tau / N: a step below that is a pure lag
    small = 0.9 * R * p.tau / N * (1 - math.exp(-DT / p.tau)) / (DT / p.tau)
    act2 = SteeringActuator(p)
    y2 = run(act2, [small] * 5)
    np.testing.assert_allclose(y2, small * (1 - np.exp(-np.arange(1, 6) * DT / p.tau)))
    assert not act2.state.rate_limited


def test_large_steps_are_rate_limited_small_ones_not():
    # default chain: over the 20-80 % part of a -15 -> +15 deg swing the horn slews at exactly
    # its limit (the wheel at R cos(theta) / (N cos(delta)), the linkage's local gain); 0.5 deg
    # is the loop: minimum drive and proportional part, no ramp
    p = ActuatorParams(enable_radio_frame=False)
    lim = p.limit
    for start, size, limited in ((0.0, math.radians(0.5), False), (-lim, 2 * lim, True)):
        act = SteeringActuator(p, initial_angle=start)
        h0 = act.state.horn
        horn = []
        for _ in range(1500):
            act.step(start + size, DT)
            horn.append(act.state.horn)
        horn = np.array(horn)
        frac = (horn - h0) / (horn[-1] - h0)
        mid = (frac > 0.2) & (frac < 0.8)
        slopes = np.diff(horn)[mid[1:]] / DT
        if limited:
            np.testing.assert_allclose(slopes, p.rate_limit, rtol=1e-9)
        else:
            assert np.max(slopes) < 0.5 * p.rate_limit
            assert np.ptp(slopes) > 0.3 * np.max(slopes)  # exponential, not a ramp


def test_minimum_drive_closed_form_and_stops_at_the_dead_zone_edge():
    # outside the dead zone: theta' = m + K (e - e_f), i.e. an exact first-order approach to
    # ref - e_f + m / K, ended at the dead zone's edge ref - e_f
    e_f, m = math.radians(0.05), 0.5
    p = ActuatorParams(**{**only(enable_lag=True, enable_friction=True),
                          'friction_deadband': e_f, 'min_drive': m})
    act = SteeringActuator(p)
    ref = 0.02
    y = run(act, [ref] * 400)
    k = np.arange(1, 401)
    target = ref - e_f + m * p.tau
    free = target * (1 - np.exp(-k * DT / p.tau))
    np.testing.assert_allclose(y, np.minimum(free, ref - e_f), rtol=1e-12, atol=1e-15)
    assert y[-1] == pytest.approx(ref - e_f, abs=1e-15) and np.all(y <= ref - e_f)
    # faster than the loop alone, which never reaches the edge
    slow = run(SteeringActuator(ActuatorParams(**only(enable_lag=True, enable_friction=True),
                                               friction_deadband=e_f)), [ref] * 400)
    assert np.all(y[:100] > slow[:100]) and slow[-1] < ref - e_f


def test_presets_apply_and_the_yaml_preset_matches():
    import yaml
    from pathlib import Path
    for name, over in PRESETS.items():
        ActuatorParams(**over).validate()
    cfg = Path(__file__).parents[1] / 'config' / 'servo_7hz.yaml'
    doc = yaml.safe_load(cfg.read_text())['vehicle_sim']['ros__parameters']
    for side in ('actuator_front', 'actuator_rear'):
        assert doc[side] == pytest.approx(PRESETS['servo_7hz'])


def test_linkage_geometry_closed_form():
    p = ActuatorParams(**only(enable_linkage_geometry=True, gear_ratio=3.0))
    act = SteeringActuator(p)
    u = math.radians(15.0)
    y = act.step(u, DT)
    assert act.state.horn == pytest.approx(3.0 * u)
    assert y == pytest.approx(math.asin(math.sin(3.0 * u) / 3.0), rel=1e-12)
    assert math.degrees(y) == pytest.approx(13.63, abs=0.01)
    # small angles: gain 1 to first order
    assert act.step(1e-4, DT) == pytest.approx(1e-4, rel=1e-6)


def test_friction_dead_zone_holds_small_errors_and_leaves_offset():
    e_f = math.radians(0.5)
    p = ActuatorParams(**only(enable_lag=True, enable_friction=True), friction_deadband=e_f)
    act = SteeringActuator(p)
    y = run(act, [0.9 * e_f] * 200)  # inside the dead zone: no motion at all
    np.testing.assert_array_equal(y, 0.0)
    y = run(act, [0.05] * 2000)  # outside: settles e_f short of the reference
    assert y[-1] == pytest.approx(0.05 - e_f, abs=1e-9)
    y = run(act, [0.0] * 2000)  # back from above: stops e_f above the reference
    assert y[-1] == pytest.approx(e_f, abs=1e-9)


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
    for _ in range(1500):
        act.step(-1.0, DT)
    s = act.state
    assert s.commanded == -1.0 and s.delayed == pytest.approx(-math.radians(15))
    # approached from above: wheel lags the servo by half the play
    assert s.achieved == pytest.approx(s.servo + 0.5 * math.radians(0.175), abs=1e-12)
    p = act.params
    assert s.horn == pytest.approx(-p.horn_of(p.limit) + p.friction_deadband, abs=1e-9)


class _OldActuator:
    """The pre-servo-model update (commit f35f610), transcribed: the legacy reference."""

    def __init__(self, p):
        self.p, self.servo, self.achieved, self.fifo, self.a = p, 0.0, 0.0, None, 0.0

    def step(self, u, dt):
        p = self.p
        if self.fifo is None:
            self.a = math.exp(-dt / p.tau) if p.enable_lag else 0.0
            self.fifo = deque([0.0] * (int(round(p.delay / dt)) if p.enable_delay else 0))
        if self.fifo:
            self.fifo.append(u)
            u = self.fifo.popleft()
        if p.enable_saturation and abs(u) > p.limit:
            u = math.copysign(p.limit, u)
        inc = (1.0 - self.a) * (u - self.servo)
        limited = False
        if p.enable_rate_limit and abs(inc) > p.rate_limit * dt:
            inc, limited = math.copysign(p.rate_limit * dt, inc), True
        self.servo = self.servo + inc if (p.enable_lag or limited) else u
        half = 0.5 * p.backlash
        if p.enable_backlash and p.backlash > 0.0:
            gap = self.servo - self.achieved
            if gap > half:
                self.achieved = self.servo - half
            elif gap < -half:
                self.achieved = self.servo + half
        else:
            self.achieved = self.servo
        return self.achieved


@pytest.mark.parametrize('lag', [True, False])
def test_legacy_parameters_reproduce_the_old_model_to_the_bit(lag):
    p = ActuatorParams(**LEGACY, enable_lag=lag)
    new, old = SteeringActuator(p), _OldActuator(p)
    rng = np.random.default_rng(3)
    cmds = np.concatenate([rng.normal(0.0, 0.2, 800), np.full(300, 0.4), np.full(300, -0.05)])
    assert [new.step(c, DT) for c in cmds] == [old.step(c, DT) for c in cmds]


_finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(cmds=st.lists(_finite, min_size=1, max_size=300), geometry=st.booleans(),
       friction=st.booleans(), compensation=st.booleans(), ratio=st.floats(1.0, 3.8))
def test_output_finite_and_within_limits_for_any_finite_input(cmds, geometry, friction,
                                                              compensation, ratio):
    p = ActuatorParams(gear_ratio=ratio, enable_linkage_geometry=geometry,
                       enable_friction=friction, enable_linkage_compensation=compensation)
    act = SteeringActuator(p)
    for c in cmds:
        y = act.step(c, DT)
        assert math.isfinite(y) and abs(y) <= p.limit
        assert abs(act.state.horn) <= p.horn_of(p.limit)


def test_bad_params_and_dt_change():
    with pytest.raises(ValueError, match='lag_hz'):
        SteeringActuator(ActuatorParams(lag_hz=0.0))
    with pytest.raises(ValueError, match='delay'):
        SteeringActuator(ActuatorParams(delay=-1.0))
    with pytest.raises(ValueError, match='rate_limit'):
        SteeringActuator(ActuatorParams(rate_limit=math.nan))
    with pytest.raises(ValueError, match='gear_ratio'):
        SteeringActuator(ActuatorParams(gear_ratio=0.5))
    with pytest.raises(ValueError, match='friction_deadband'):
        SteeringActuator(ActuatorParams(friction_deadband=-1e-3))
    with pytest.raises(ValueError, match='min_drive'):
        SteeringActuator(ActuatorParams(min_drive=-1.0))
    with pytest.raises(ValueError, match='radio_frame'):
        SteeringActuator(ActuatorParams(radio_frame=0.0))
    with pytest.raises(ValueError, match='half the radio frame'):
        SteeringActuator(ActuatorParams(delay=0.005))
    with pytest.raises(ValueError, match='cannot reach the wheel limit'):
        SteeringActuator(ActuatorParams(gear_ratio=4.0))
    act = SteeringActuator()
    act.step(0.0, DT)
    with pytest.raises(ValueError, match='constant'):
        act.step(0.0, 2 * DT)
