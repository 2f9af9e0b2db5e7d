"""Bad inputs cannot make the treadmill regulator emit a non-finite or out-of-limit voltage, its
state recovers, and a future-stamped position cannot blind the safety monitor.
"""
import math

import pytest
from hypothesis import given, settings, strategies as st

from irs_treadmill.regulator import BeltSpeedRegulator, RegulatorParams
from irs_treadmill.safety import FaultCode, SafetyMonitor

DT = 1e-3
NASTY = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, 6.0, -7.5, 25.0]
ANY = st.one_of(st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
                st.sampled_from(NASTY), st.floats(-1.2, 1.2))
GOOD_X = st.floats(-1.0, 1.0, allow_subnormal=True)
GOOD_V = st.floats(0.0, 3.0, allow_subnormal=True)
XDOT = st.one_of(st.none(), ANY)


def state_finite(r):
    return all(math.isfinite(v) for v in (r.integral, r.voltage, r._xdot_f)) and \
        (r._x_prev is None or math.isfinite(r._x_prev))


def check(reg, out):
    assert math.isfinite(out.voltage) and 0.0 <= out.voltage <= reg.params.u_max
    assert math.isfinite(out.speed_setpoint)
    assert state_finite(reg)


@settings(max_examples=80, deadline=None)
@given(seq=st.lists(st.tuples(ANY, ANY, XDOT), min_size=1, max_size=60))
def test_voltage_always_finite_and_within_limits(seq):
    reg = BeltSpeedRegulator()
    for x, belt, xdot in seq:
        out = reg.update(x, belt, DT, xdot=xdot)
        check(reg, out)
        bad = not (
            math.isfinite(x) and abs(x) <= 5.0 and math.isfinite(belt) and abs(belt) <= 20.0
        )
        if bad:
            assert out.voltage == 0.0 and 'regulator reset' in out.reason
            assert reg.integral == 0.0 and reg.voltage == 0.0


@settings(max_examples=60, deadline=None)
@given(prefix=st.lists(st.tuples(ANY, ANY, XDOT), max_size=30),
       bad_x=st.sampled_from([math.nan, math.inf, 1e308, -1e308, 6.0]),
       tail=st.lists(st.tuples(GOOD_X, GOOD_V, st.one_of(st.none(), st.floats(-2.0, 2.0))),
                     min_size=1, max_size=40))
def test_after_a_bad_position_the_regulator_equals_a_fresh_one(prefix, bad_x, tail):
    reg = BeltSpeedRegulator()
    for x, belt, xdot in prefix:
        reg.update(x, belt, DT, xdot=xdot)
    out = reg.update(bad_x, 1.0, DT)
    assert out.voltage == 0.0 and out.reason
    fresh = BeltSpeedRegulator()
    for x, belt, xdot in tail:
        assert reg.update(x, belt, DT, xdot=xdot) == fresh.update(x, belt, DT, xdot=xdot)
    assert (reg.integral, reg.voltage, reg._xdot_f) == (fresh.integral, fresh.voltage,
                                                        fresh._xdot_f)


@settings(max_examples=60, deadline=None)
@given(seq=st.lists(st.tuples(GOOD_X, GOOD_V, st.one_of(st.sampled_from(NASTY),
                                                         st.floats(-2.0, 2.0))),
                    min_size=1, max_size=40))
def test_bad_xdot_falls_back_to_the_internal_estimate(seq):
    a, b = BeltSpeedRegulator(), BeltSpeedRegulator()
    for x, belt, xdot in seq:
        oa = a.update(x, belt, DT, xdot=xdot)
        usable = math.isfinite(xdot) and abs(xdot) <= 20.0
        ob = b.update(x, belt, DT, xdot=xdot if usable else None)
        assert oa.voltage == ob.voltage and oa.speed_setpoint == ob.speed_setpoint
        assert (oa.reason == '') == usable
        if not usable:
            assert 'internal velocity estimate used' in oa.reason


def test_one_huge_position_no_longer_poisons_the_velocity_filter():
    """The fuzzer's case: x = 1e308 once made the internal xdot filter inf/NaN for good."""
    reg, fresh = BeltSpeedRegulator(), BeltSpeedRegulator()
    for k in range(50):
        reg.update(0.3, 1.2, DT)
    assert reg.update(1e308, 1.2, DT).voltage == 0.0
    for k in range(200):
        x = 0.3 + 1e-4 * k
        assert reg.update(x, 1.2, DT) == fresh.update(x, 1.2, DT)
    assert reg.update(0.35, 1.2, DT).voltage > 0.0


def test_subnormal_dt_cannot_store_a_non_finite_state():
    reg = BeltSpeedRegulator()
    reg.update(0.3, 1.2, DT)
    out = reg.update(0.31, 1.2, 5e-324)
    assert out.voltage == 0.0 and 'non-finite' in out.reason and state_finite(reg)
    with pytest.raises(ValueError, match='dt'):
        reg.update(0.3, 1.2, math.nan)


def test_limits_configurable_and_validated():
    reg = BeltSpeedRegulator(RegulatorParams(), position_limit=1.0, speed_limit=2.0)
    assert reg.update(1.5, 1.0, DT).reason.startswith('x = 1.5 m is outside')
    assert 'belt_speed' in reg.update(0.3, 2.5, DT).reason
    with pytest.raises(ValueError, match='position_limit'):
        BeltSpeedRegulator(position_limit=math.nan)


# ---------------------------------------------------------------- safety: stamps
DAY = 86400.0
FUTURES = [DAY, 2.0 ** 31, 1e308, 0.6, 1e9]


def test_future_stamped_position_is_rejected_and_never_stored():
    s = SafetyMonitor()
    now = 10.0
    s.update_position(0.3, 0.0, now, now=now)
    assert s.drive_permitted
    s.update_position(0.3, 0.0, now + DAY, now=now)
    assert (
        s.rejected_stamps == 1
        and 'future' in s.last_rejection
        and 'ahead of the clock' in s.last_rejection
    )
    for k in range(1, 100):          # later genuine data is used: no stale fault, permitted
        t = now + k * DT
        s.update_position(0.3, 0.0, t, now=t)
        assert s.check(t) == FaultCode.NONE and s.drive_permitted
    assert s.rejected_stamps == 1


def test_only_future_stamps_do_not_hide_a_stale_input():
    s = SafetyMonitor()
    s.update_position(0.3, 0.0, 1.0, now=1.0)
    for k in range(1, int(1.5 * s.params.stale_timeout / DT)):
        t = 1.0 + k * DT
        s.update_position(0.3, 0.0, 2.0 ** 31, now=t)
        s.check(t)
    assert s.fault == FaultCode.STALE_POSITION


def test_future_stamp_still_checked_against_the_belt_edges():
    s = SafetyMonitor()
    s.update_position(0.3, 0.59, DAY, now=0.0)
    assert s.fault == FaultCode.NEAR_LEFT_EDGE


def test_old_and_repeated_stamps_are_not_stored():
    s = SafetyMonitor()
    s.update_position(0.3, 0.0, 5.0)
    s.update_position(0.3, 0.0, 5.0)
    assert 'repeat' in s.last_rejection
    s.update_position(0.3, 0.0, 1.0)
    assert 'old' in s.last_rejection and s.rejected_stamps == 2
    timeout = s.params.stale_timeout
    assert s.check(5.0 + 0.5 * timeout) == FaultCode.NONE    # last stored stamp is still 5.0
    assert s.check(5.0 + 1.5 * timeout) == FaultCode.STALE_POSITION


@settings(max_examples=80, deadline=None)
@given(seq=st.lists(st.tuples(ANY, ANY, st.one_of(st.sampled_from(FUTURES), st.just(None), ANY),
                              ANY, XDOT), min_size=1, max_size=40))
def test_safety_and_regulator_never_emit_a_bad_voltage(seq):
    """The node's composition (closed_loop.py) under arbitrary inputs: the gated voltage is
    finite and within [0, u_max]; no exception escapes.
    """
    s, reg = SafetyMonitor(), BeltSpeedRegulator()
    now = 0.0
    for x, y, stamp_off, belt, xdot in seq:
        now += DT
        stamp = now if stamp_off is None else now + stamp_off
        s.update_position(x, y, stamp, now=now)
        s.check(now)
        out = reg.update(x, belt, DT, xdot=xdot, enabled=s.drive_permitted)
        v = s.gate(out.voltage)
        assert math.isfinite(v) and 0.0 <= v <= reg.params.u_max
        assert s._last_stamp is None or s._last_stamp <= now + s.future_tolerance
