"""Treadmill identification (irs_sysid.treadmill_fit) on data of the rig's belt model.

The data are the belt model's own encoder estimate (irs_vehicle_sim.belt: quantised to 77.9 um
of belt per count, differenced over 10 steps of 1 ms, one step late), the signal the rig
publishes on belt/speed. Tolerances (relative) as in the module: pole a 3 %, gain b 3 %,
delay 10 % (drive delay + encoder lag), B/J 5 %, F/B 10 %.
"""
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from irs_sysid.treadmill_cli import TOLERANCES, belt_params_of, installed_rig_params, \
    measured_delay
from irs_sysid.treadmill_fit import driver_profile, fit_coast, fit_drive, segments, \
    simulate_belt
from irs_control.reference import Schedule
from irs_vehicle_sim.belt import MPH, BeltParams, TreadmillBelt

DT = 1e-3
EXPERIMENTS = Path(__file__).resolve().parents[2] / 'irs_bringup' / 'config' / 'experiments'


def schedule(levels=(1.0, 2.0, 3.0, 4.0), hold=2.0, coasts=(5.8, 9.0, 11.5, 13.3), t0=0.5):
    """The sysid_treadmill plan: per level a step up, a 0.5 V step down, a coast-down."""
    times, values, t = [], [], t0
    for level, coast in zip(levels, coasts):
        times += [t, t + hold, t + 2 * hold]
        values += [level, level - 0.5, 0.0]
        t += 2 * hold + coast
    return times, values, t


def run(params, levels=(1.0, 2.0, 3.0, 4.0), coasts=(5.8, 9.0, 11.5, 13.3), noise=0.0, seed=1):
    times, values, end = schedule(levels, coasts=coasts)
    s = Schedule(times, values, 0.0)
    t = np.arange(int(round(end / DT))) * DT
    u = np.array([s(x) for x in t])
    v = simulate_belt(u, DT, params, measured=True)
    if noise:
        v = v + np.random.default_rng(seed).normal(0.0, noise, v.size)
    return t, v, u


def check(value, configured, key):
    assert value == pytest.approx(configured, rel=TOLERANCES[key]), key


@pytest.mark.parametrize('noise', [0.0, 0.01])
def test_drive_and_friction_recovered_from_the_encoder_speed(noise):
    """Eq. 2 and Eq. 1 at the rig's defaults; also with 1 cm/s white noise on the speed."""
    p = BeltParams()
    t, v, u = run(p, noise=noise)
    d, c = fit_drive(t, v, u), fit_coast(t, v, u)
    check(d.a, p.pole, 'pole')
    check(d.b, p.gain, 'gain')
    check(d.delay, measured_delay(p, DT), 'delay')
    check(c.b_over_j, p.b_over_j, 'b_over_j')
    check(c.f_over_b, p.f_over_b, 'f_over_b')
    assert len(d.steps) == 4 and len(c.coasts) == 4
    # the 95 % intervals are finite and no wider than the tolerances
    for value, ci, key in ((d.a, d.a_ci, 'pole'), (d.b, d.b_ci, 'gain'),
                           (c.b_over_j, c.b_over_j_ci, 'b_over_j'),
                           (c.f_over_b, c.f_over_b_ci, 'f_over_b')):
        assert 0.0 < ci < TOLERANCES[key] * value, key


@pytest.mark.parametrize('f_over_b', [0.270, 0.270 / 0.158, 0.270 * 0.0508])
def test_whichever_friction_reading_is_configured_is_recovered(f_over_b):
    """The three readings of the paper's F/B (docs/treadmill.md): 0.270 m/s (the default),
    F/J = 0.270 m/s^2 i.e. F/B = 1.709 m/s, and 0.270 rad/s of a 2 in roller (0.0137 m/s).
    """
    p = BeltParams(f_over_b=f_over_b)
    t, v, u = run(p)
    c = fit_coast(t, v, u)
    check(c.f_over_b, f_over_b, 'f_over_b')
    check(c.b_over_j, p.b_over_j, 'b_over_j')


def test_other_belt_parameters_are_recovered_too():
    """Not tuned to the defaults: another gain, pole, delay and friction."""
    p = BeltParams(gain=3.1, pole=6.0, delay=0.02, b_over_j=0.25, f_over_b=0.5)
    t, v, u = run(p, levels=(2.0, 4.0), coasts=(6.0, 8.0))
    d, c = fit_drive(t, v, u), fit_coast(t, v, u)
    check(d.a, p.pole, 'pole')
    check(d.b, p.gain, 'gain')
    check(d.delay, measured_delay(p, DT), 'delay')
    check(c.b_over_j, p.b_over_j, 'b_over_j')
    check(c.f_over_b, p.f_over_b, 'f_over_b')


def test_segments_are_classified():
    t = np.arange(8) * 1.0
    u = np.array([0, 0, 3, 3, 2.5, 0, 0, 1.0])
    assert [(s.start, s.kind) for s in segments(t, u)] == [
        (0.0, 'hold'), (2.0, 'up'), (4.0, 'down'), (5.0, 'coast'), (7.0, 'up')]


def test_no_step_or_no_coast_is_a_clear_error():
    t = np.arange(1000) * DT
    with pytest.raises(ValueError, match='no step up'):
        fit_drive(t, np.zeros_like(t), np.zeros_like(t))
    with pytest.raises(ValueError, match='no coast-down'):
        fit_coast(t, np.zeros_like(t), np.where(t > 0.5, 2.0, 0.0))


@pytest.mark.parametrize('name', ['sysid_treadmill', 'sysid_treadmill_short'])
def test_experiment_driver_profile_follows_the_predicted_belt_speed(name):
    """The driver keeps the car level with the belt: its profile is within 5 mm/s of the
    belt speed the model predicts for the file's schedule with the installed rig.yaml.
    """
    doc = yaml.safe_load((EXPERIMENTS / f'{name}.yaml').read_text())
    exc = doc['nodes']['excitation']['params']
    drv = doc['nodes']['driver']['params']
    s = Schedule(exc['signal.times'], exc['signal.values'], 0.0)
    t = np.arange(int(round(doc['duration'] / DT)) + 1) * DT
    v = simulate_belt([s(x) for x in t], DT, belt_params_of(installed_rig_params()))
    profile = np.interp(t, drv['profile.times'], drv['profile.speeds'])
    assert np.max(np.abs(profile - v)) < 0.005
    # the car drifts less than 10 cm at any time of the run (belt travel: tens of metres; the
    # car has about 1 m to either belt end)
    assert np.max(np.abs(np.cumsum(profile - v) * DT)) < 0.10


def test_driver_profile_is_within_its_tolerance():
    t = np.linspace(0.0, 10.0, 1001)
    v = 1.0 - np.exp(-t)
    tp, vp = driver_profile(t, v, tol=0.002)
    assert np.max(np.abs(np.interp(t, tp, vp) - v)) <= 0.002 + 1e-12
    assert len(tp) < 100


def test_15_mph_is_reached_at_the_drive_limit():
    """The paper's top speed, 15 mph, with Eq. 2 at the drive limit: rig default, rig.yaml and
    the treadmill regulator's configuration agree on the limit, and it reaches 6.7056 m/s.
    """
    root = Path(__file__).resolve().parents[2]
    rig = yaml.safe_load((root / 'irs_vehicle_sim/config/rig.yaml').read_text())
    reg = yaml.safe_load((root / 'irs_treadmill/config/treadmill.yaml').read_text())
    u_rig = rig['vehicle_sim']['ros__parameters']['belt']['u_max']
    u_reg = reg['treadmill_regulator']['ros__parameters']['regulator']['u_max']
    assert u_rig == u_reg == BeltParams().u_max
    p = BeltParams()
    assert p.v_top == pytest.approx(15 * MPH)
    assert p.u_max * p.dc_gain >= p.v_top          # Eq. 2 in steady state
    belt = TreadmillBelt(p)
    for _ in range(5000):                          # 5 s at the limit voltage
        belt.step(p.u_max, DT)
    assert belt.speed == pytest.approx(15 * MPH, abs=1e-9)
    assert math.isclose(belt.measured_speed, 15 * MPH, abs_tol=p.speed_resolution(DT))
