"""Regulator unit tests (limits, anti-wind-up) and safety latching."""

import math

import pytest
from hypothesis import given, strategies as st

from irs_treadmill.regulator import BeltSpeedRegulator, RegulatorParams
from irs_treadmill.safety import FaultCode, SafetyMonitor, SafetyParams

DT = 0.001


def test_holds_belt_speed_when_on_set_point():
    p = RegulatorParams(slew_rate=1e6)
    reg = BeltSpeedRegulator(p)
    out = reg.update(p.x_ref, 2.0, DT, xdot=0.0)
    assert out.voltage == pytest.approx(2.0 / p.belt_gain)
    assert out.speed_setpoint == pytest.approx(2.0)
    assert out.car_speed_estimate == pytest.approx(2.0)


def test_voltage_clamped_and_slew_limited():
    p = RegulatorParams(slew_rate=40.0)
    reg = BeltSpeedRegulator(p)
    volts = [reg.update(p.x_ref + 3.0, 0.0, DT, xdot=0.0).voltage for _ in range(1000)]
    assert volts[0] == pytest.approx(40.0 * DT)
    assert all(0.0 <= v <= p.u_max for v in volts)
    assert max(volts) == pytest.approx(p.u_max)
    assert all(b - a <= 40.0 * DT + 1e-12 for a, b in zip(volts, volts[1:]))


def test_no_windup_while_coasting():
    p = RegulatorParams(k_i=1.0)
    reg = BeltSpeedRegulator(p)
    # car 0.4 m behind the set point, belt faster than the car: drive off, belt coasts
    for _ in range(2000):
        out = reg.update(p.x_ref - 0.4, 3.0, DT, xdot=-1.0)
        assert out.voltage == 0.0 or reg.voltage < 1.0  # slewing down to 0 first
    assert out.voltage == 0.0
    assert reg.integral == 0.0
    assert not out.integrating


def test_no_windup_while_saturated_high():
    p = RegulatorParams(k_i=1.0, slew_rate=1e6, u_max=10.0)   # 11.7 V wanted below
    reg = BeltSpeedRegulator(p)
    for _ in range(2000):
        out = reg.update(p.x_ref + 0.8, 1.0, DT, xdot=1.0)
    assert out.voltage == p.u_max
    assert reg.integral == 0.0


def test_integrates_when_unsaturated_and_is_clamped():
    p = RegulatorParams(k_i=1.0, integral_limit=0.2, slew_rate=1e6)
    reg = BeltSpeedRegulator(p)
    for _ in range(1000):
        out = reg.update(p.x_ref + 0.01, 2.0, DT, xdot=0.0)
    assert out.integrating
    assert reg.integral == pytest.approx(0.01 * 1.0, rel=1e-6)
    for _ in range(30000):
        reg.update(p.x_ref + 0.05, 2.0, DT, xdot=0.0)
    assert p.k_i * reg.integral == pytest.approx(0.2)


def test_disabled_outputs_zero_and_resets():
    p = RegulatorParams(k_i=1.0, slew_rate=1e6)
    reg = BeltSpeedRegulator(p)
    for _ in range(100):
        reg.update(p.x_ref + 0.01, 2.0, DT, xdot=0.0)
    assert reg.integral > 0
    out = reg.update(p.x_ref, 2.0, DT, enabled=False)
    assert out.voltage == 0.0 and reg.integral == 0.0 and reg.voltage == 0.0
    assert reg.update(float('nan'), 2.0, DT).voltage == 0.0


def test_regulator_param_validation():
    with pytest.raises(ValueError):
        RegulatorParams(k_x=0.0)
    with pytest.raises(ValueError):
        RegulatorParams(slew_rate=-1.0)
    with pytest.raises(ValueError):
        BeltSpeedRegulator().update(0.0, 0.0, 0.0)


# ---------------------------------------------------------------------------- safety
@pytest.mark.parametrize('x,y,code', [
    (1.10, 0.0, FaultCode.NEAR_FRONT_END),
    (-1.10, 0.0, FaultCode.NEAR_REAR_END),
    (0.0, 0.55, FaultCode.NEAR_LEFT_EDGE),
    (0.0, -0.55, FaultCode.NEAR_RIGHT_EDGE),
])
def test_fault_latches_until_reset(x, y, code):
    s = SafetyMonitor(SafetyParams(end_margin=0.15, edge_margin=0.10))
    assert not s.drive_permitted and s.gate(5.0) == 0.0   # no position yet
    assert s.update_position(0.0, 0.0, 0.0) == FaultCode.NONE
    assert s.gate(5.0) == 5.0
    assert s.update_position(x, y, 0.001) == code
    assert s.gate(5.0) == 0.0
    # car comes back to the centre: fault stays latched
    assert s.update_position(0.0, 0.0, 0.002) == code
    assert s.gate(5.0) == 0.0
    assert code.text in s.status_text()
    s.reset()
    assert s.fault == FaultCode.NONE and s.gate(5.0) == 0.0   # inhibited until new position
    s.update_position(0.0, 0.0, 0.003)
    assert s.gate(5.0) == 5.0


def test_persisting_condition_relatches_after_reset():
    s = SafetyMonitor()
    s.update_position(1.15, 0.0, 0.0)
    s.reset()
    assert s.update_position(1.15, 0.0, 0.001) == FaultCode.NEAR_FRONT_END


def test_within_margins_no_fault():
    s = SafetyMonitor(SafetyParams(end_margin=0.15, edge_margin=0.10))
    for x, y in ((1.06, 0.0), (-1.06, 0.0), (0.0, 0.50), (0.0, -0.50)):
        assert s.update_position(x, y, 0.0 if x == 1.06 else s._last_stamp + 0.001) \
            == FaultCode.NONE


def test_stale_position_latches():
    s = SafetyMonitor(SafetyParams(stale_timeout=0.1))
    s.update_position(0.0, 0.0, 1.0)
    assert s.check(1.09) == FaultCode.NONE
    assert s.check(1.11) == FaultCode.STALE_POSITION
    assert s.gate(3.0) == 0.0
    s.update_position(0.0, 0.0, 1.12)   # fresh data does not clear the latch
    assert s.fault == FaultCode.STALE_POSITION
    assert 'stale' in FaultCode.STALE_POSITION.text


def test_invalid_input_latches():
    s = SafetyMonitor()
    s.update_position(0.0, 0.0, 0.0)
    assert s.update_position(float('nan'), 0.0, 0.001) == FaultCode.INVALID_INPUT
    assert s.gate(float('nan')) == 0.0


def test_safety_param_validation():
    with pytest.raises(ValueError):
        SafetyParams(end_margin=2.0)
    with pytest.raises(ValueError):
        SafetyParams(stale_timeout=0.0)


def test_treadmill_yaml_units_and_params():
    import pathlib
    import re

    import yaml
    path = pathlib.Path(__file__).resolve().parents[1] / 'config' / 'treadmill.yaml'
    for line in path.read_text().splitlines():
        code = line.split('#')[0]
        if re.search(r':\s*\[?-?\d', code):
            assert re.search(r'#\s*\[', line), f'number without a unit comment: {line!r}'
    ros = yaml.safe_load(path.read_text())['treadmill_regulator']['ros__parameters']
    import dataclasses
    got = dataclasses.asdict(RegulatorParams.from_dict(ros['regulator']))
    for k, v in dataclasses.asdict(RegulatorParams()).items():
        assert got[k] == pytest.approx(v, rel=1e-6), k
    assert SafetyParams.from_dict(ros['safety']) == SafetyParams()
    with pytest.raises(ValueError):
        RegulatorParams.from_dict({'kx': 1.0})


def test_first_fault_is_kept():
    s = SafetyMonitor(SafetyParams(stale_timeout=0.1))
    s.update_position(1.15, 0.0, 0.0)
    s.check(1.0)                                  # would be stale as well
    s.update_position(0.0, -0.58, 1.001)          # and near the right edge
    assert s.fault == FaultCode.NEAR_FRONT_END


def test_a_car_moving_towards_an_end_trips_while_a_stop_still_has_room():
    """The end check of a moving car uses where a stop would bring it to rest:
    ``x - (|xdot| stop_delay + xdot^2 / (2 stop_decel))`` towards the rear, 0.7125 m behind a
    car at 1.5 m/s with the defaults. At -0.5 m moving rearward at 1.5 m/s (a car falling back
    from a belt running away) that is past the rear limit, -1.069 m: the fault. The same car
    at rest, or moving forward, is far from it; without a speed the check is the position's.
    """
    def fault(x, xdot):
        monitor = SafetyMonitor()
        return monitor.update_position(x, 0.0, 1.0, xdot=xdot), monitor.fault_detail

    code, detail = fault(-0.5, -1.5)
    assert code == FaultCode.NEAR_REAR_END and 'moving at -1.50 m/s' in detail, detail
    assert fault(0.5, 1.5)[0] == FaultCode.NEAR_FRONT_END
    for xdot in (None, 0.0, math.nan, 1.5):
        assert fault(-0.5, xdot)[0] == FaultCode.NONE, xdot
    assert fault(-1.0, None) == fault(-1.0, 0.0) == (FaultCode.NONE, '')
    assert fault(-1.1, None)[0] == FaultCode.NEAR_REAR_END        # the position alone


@given(x=st.floats(-1.0, 1.0), xdot=st.floats(-5.0, 5.0), more=st.floats(0.0, 5.0))
def test_a_faster_car_trips_no_later(x, xdot, more):
    """Moving faster towards the same end never clears a fault the slower car had."""
    slow, fast = SafetyMonitor(), SafetyMonitor()
    slow.update_position(x, 0.0, 1.0, xdot=xdot)
    fast.update_position(x, 0.0, 1.0, xdot=xdot + math.copysign(more, xdot))
    if slow.fault != FaultCode.NONE:
        assert fast.fault == slow.fault
