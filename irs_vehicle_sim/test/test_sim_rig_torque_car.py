"""The rig with ``plant: two_track`` (the torque car): torques, brakes, locks, bad input, surfaces,
encoders, belt coupling; the other plants untouched.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_vehicle_sim.rig import RigConfig, RigInputs, RigSimulation, simulate
from irs_vehicle_sim.rig_torque_car import sanitize_wheel_inputs

V_HOLD = 1.2 / (2.38 / 4.5)   # [V] holds the belt at 1.2 m/s
G = 9.81
TORQUE_CAR = {'plant': 'two_track', 'arm.enable_noise': False}


def inputs(torque=(0.0,) * 4, locked=(False,) * 4, steer=0.0):
    return RigInputs(front_steer=steer, drive_voltage=V_HOLD, speed_cmd=1.2,
                     wheel_torque=tuple(torque), wheel_locked=tuple(locked))


def run(fn, duration, **params):
    return simulate({**TORQUE_CAR, **params}, lambda o: fn(o), duration)


def test_start_is_rolling_at_belt_speed_and_other_plants_have_no_torque_outputs():
    sim = RigSimulation(RigConfig.from_dict(TORQUE_CAR))
    o = sim.outputs
    r = sim.config.two_track['wheel_radius']
    assert o.u == 1.2 and o.x == 0.0 and o.y == 0.0 and o.psi == 0.0
    np.testing.assert_array_equal(o.wheel_speeds, [1.2 / r] * 4)
    # primed encoders: the start spin to the count resolution (not 0)
    res = 2 * math.pi / (2048 * 5 * 1e-3)
    assert np.all(np.abs(np.array(o.encoder_velocity) - 1.2 / r) <= res)
    assert o.encoder_counts == (0, 0, 0, 0) and o.tyre.x_belt == 0.0
    for plant in ('bicycle', 'identified'):
        b = RigSimulation(RigConfig.from_dict({'plant': plant}))
        ob = b.step(inputs(torque=(0.3,) * 4))
        assert ob.encoder_counts == () and ob.encoder_velocity == () and ob.tyre is None
        res = simulate({'plant': plant}, lambda o: inputs(), 0.01)
        assert 'encoder_counts' not in res and 'x_belt' not in res


def test_drive_torque_accelerates_forward_on_the_treadmill():
    r = run(lambda o: inputs(torque=(0.05,) * 4), 0.5)
    assert r['u'][-1] > 1.2 + 0.3           # 0.2 N m / 0.033 m = 6 N on 2.9 kg, less losses
    assert r['x'][-1] > 0.05                # faster than the belt: moves forward on it
    assert np.all(r['encoder_velocity'][-1] > r['encoder_velocity'][0] + 5.0)
    assert np.all(r['slip'][-1] > 0.0)      # driving slip
    np.testing.assert_array_equal(r['wheel_torque'], 0.05)


def test_braking_drifts_back_on_the_belt_and_slows_the_wheels():
    r = run(lambda o: inputs(torque=(-0.1,) * 4), 0.2)   # stops after ~0.3 s (then reverses)
    assert 0.0 < r['u'][-1] < 1.2 - 0.5
    assert r['x'][-1] < -0.04               # slower than the belt: falls back
    assert r['x_belt'][-1] < 1.2 * 0.2 - 0.04
    assert np.all(r['slip'][-1] < 0.0) and np.all(r['fx'][-1] < 0.0)
    assert np.all(np.diff(r['encoder_counts'], axis=0) >= 0)   # still rolling forward
    assert np.all(r['encoder_velocity'][-1] < r['encoder_velocity'][0] - 10.0)
    # load moves to the front while braking
    assert r['fz'][-1, 0] > r['fz'][0, 0] and r['fz'][-1, 2] < r['fz'][0, 2]


def test_locked_flags_lock_the_wheels_and_the_car_slides_near_mu_g():
    mu = 0.3
    r = run(lambda o: inputs(locked=(True,) * 4), 0.3, **{'surface.mu': mu})
    np.testing.assert_array_equal(r['wheel_speeds'][1:], 0.0)
    counts = r['encoder_counts']
    np.testing.assert_array_equal(counts[2:], np.broadcast_to(counts[1], counts[2:].shape))
    assert np.all(r['slip'][-1] < -0.9)      # sliding (relaxed slip towards -1)
    decel = (r['u'][100] - r['u'][-1]) / 0.2
    assert 0.6 * mu * G < decel < 1.02 * mu * G      # sliding friction: 0.65 of the peak
    assert r['wheel_locked'].all()


def test_torques_clip_to_the_motor_limit():
    r = run(lambda o: inputs(torque=(5.0, -5.0, 0.1, -0.2)), 0.002,
            **{'two_track.torque_limit': 0.25})
    np.testing.assert_array_equal(r['wheel_torque'][0], [0.25, -0.25, 0.1, -0.2])


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf, 'x', None])
def test_non_finite_torque_is_zero_with_a_reason(bad):
    sim_bad = RigSimulation(RigConfig.from_dict(TORQUE_CAR))
    sim_zero = RigSimulation(RigConfig.from_dict(TORQUE_CAR))
    o = sim_bad.step(inputs(torque=(0.1, 0.1, bad, 0.1)))
    z = sim_zero.step(inputs(torque=(0.1, 0.1, 0.0, 0.1)))
    assert o.applied_inputs.wheel_torque == (0.1, 0.1, 0.0, 0.1)
    assert len(o.input_warnings) == 1 and 'RL' in o.input_warnings[0]
    assert 'using 0 N m' in o.input_warnings[0] and o.input_warnings[0].startswith('wheel_torque')
    assert o.wheel_speeds == z.wheel_speeds and o.x == z.x and o.tyre == z.tyre
    # the next good command is taken again
    o2 = sim_bad.step(inputs(torque=(0.1,) * 4))
    assert o2.input_warnings == () and o2.applied_inputs.wheel_torque == (0.1,) * 4


def test_wrong_shapes_give_zero_torque_and_no_lock():
    tq, lk, reasons = sanitize_wheel_inputs((0.1, 0.2), (True,), 0.3)
    assert tq == (0.0,) * 4 and lk == (False,) * 4 and len(reasons) == 2
    tq, lk, reasons = sanitize_wheel_inputs(None, None, 0.3)
    assert tq == (0.0,) * 4 and lk == (False,) * 4 and len(reasons) == 2


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=4, max_size=4),
       st.lists(st.booleans(), min_size=4, max_size=4))
def test_any_torque_command_gives_finite_limited_torques_and_state(torque, locked):
    sim = RigSimulation(RigConfig.from_dict(TORQUE_CAR))
    for _ in range(20):
        o = sim.step(inputs(torque=torque, locked=locked))
    tq = o.applied_inputs.wheel_torque
    assert all(math.isfinite(t) and abs(t) <= 0.3 for t in tq)
    n_bad = sum(not math.isfinite(t) for t in torque)
    assert len(o.input_warnings) == n_bad
    assert all(math.isfinite(v) for v in (o.x, o.y, o.psi, o.u, o.v, o.yaw_rate))
    assert all(math.isfinite(v) for v in o.encoder_velocity + o.tyre.fx + o.tyre.fy)


@pytest.mark.parametrize('params, words', [
    ({'surface.mu': 0.0}, 'surface.mu must be a friction coefficient in [0.01, 2.0]'),
    ({'surface.kind': 'ice'}, 'surface kind must be one of'),
    ({'surface.kind': 'patch', 'surface.x_start': 0.5}, 'x_start < x_end'),
    ({'surface.mu_right': math.nan}, 'surface.mu_right must be finite'),
    ({'surface.t_step': 'soon'}, 'surface.t_step must be a number'),
    ({'surface.wet': True}, "unknown parameter(s) ['wet'] in section 'surface'"),
    ({'two_track.torque_limit': -0.1}, 'two_track.torque_limit must be a finite torque > 0'),
    ({'two_track.mass': 0.0}, 'two_track: TwoTrackParams.mass must be'),
    ({'two_track.peak_slip_x': 1.5}, 'peak_slip_x must be below sliding_slip_x'),
    ({'encoders.window': 0}, 'encoders: EncoderParams.window must be an integer >= 1'),
])
def test_bad_torque_car_parameters_are_refused_with_one_sentence(params, words):
    with pytest.raises(ValueError) as err:
        RigConfig.from_dict({**TORQUE_CAR, **params})
    msg = str(err.value)
    assert words in msg and '\n' not in msg


def test_encoder_counts_follow_the_true_wheel_angles():
    def fn(o):   # drive, then brake the left wheels and lock the right rear one
        if o.time < 0.2:
            return inputs(torque=(0.05,) * 4)
        return inputs(torque=(-0.12, 0.0, -0.12, 0.0), locked=(False, False, False, True))
    r = run(fn, 0.4)
    n, w, dt = 2048, 5, 1e-3
    omega = r['wheel_speeds']
    k_lock = int(np.argmax(r['wheel_locked'][:, 3]))      # first step with RR locked
    assert 195 < k_lock < 205
    # a friction brake holds the wheel from the start of its step: spin 0 over the step
    start = np.where(r['wheel_locked'], 0.0, omega[:-1])
    theta = np.vstack([np.zeros(4), np.cumsum(0.5 * (start + omega[1:]) * dt, axis=0)])
    true_counts = theta * n / (2 * math.pi)
    assert np.max(np.abs(r['encoder_counts'] - true_counts)) <= 1.0 + 1e-6
    assert np.all(r['encoder_counts'] <= true_counts + 1e-6)          # floor
    # velocity: the window's mean spin to one count per window
    res = 2 * math.pi / (n * w * dt)
    mean_w = (theta[w:] - theta[:-w]) / (w * dt)
    assert np.max(np.abs(r['encoder_velocity'][w:] - mean_w)) <= res + 1e-9
    assert r['encoder_counts'][-1, 3] == r['encoder_counts'][k_lock + 1, 3]   # locked: no count


def test_split_mu_under_the_wheels_and_braking_yaws_towards_the_grip():
    r = run(lambda o: inputs(torque=(-0.15,) * 4), 0.25,
            **{'surface.kind': 'split', 'surface.mu_left': 0.8, 'surface.mu_right': 0.3})
    np.testing.assert_array_equal(r['mu'][0], [0.8, 0.3, 0.8, 0.3])
    assert np.max(r['yaw_rate']) > 0.1       # more braking force on the left: yaws left
    assert r['psi'][-1] > 0.01


def test_step_surface_follows_rig_time_and_patch_the_position():
    r = run(lambda o: inputs(), 0.3, **{'surface.kind': 'step', 'surface.t_step': 0.1,
                                        'surface.mu': 0.8, 'surface.mu_after': 0.3})
    np.testing.assert_array_equal(r['mu'][100], 0.8)   # mu at the start of the step t_k
    np.testing.assert_array_equal(r['mu'][102], 0.3)
    r = run(lambda o: inputs(), 0.01, **{'surface.kind': 'patch', 'surface.x_start': 0.1,
                                         'surface.x_end': 0.2, 'surface.mu_patch': 0.3})
    np.testing.assert_array_equal(r['mu'][-1], [0.3, 0.3, 0.8, 0.8])   # front axle at +0.15 m


def test_car_moves_back_on_the_treadmill_by_the_belt_travel_exactly():
    sim = RigSimulation(RigConfig.from_dict({**TORQUE_CAR, 'belt_speed0': 1.0}))
    s0 = sim.belt.position
    for k in range(300):      # the belt accelerates towards 1.2 m/s under V_HOLD
        o = sim.step(inputs(torque=(0.01,) * 4))
    travel = sim.belt.position - s0
    assert travel > 0.3
    assert o.x == pytest.approx(o.tyre.x_belt - travel, abs=1e-12)
    assert o.belt_speed > 1.0 + 0.01


def test_steer_acts_through_the_actuator_and_reset_to_start_keeps_counting():
    sim = RigSimulation(RigConfig.from_dict(TORQUE_CAR))
    for _ in range(400):
        o = sim.step(inputs(torque=(0.014,) * 4, steer=0.1))
    assert o.actuator_front.achieved > 0.05 and o.yaw_rate > 0.1 and o.y > 0.0
    counts = o.encoder_counts
    back = sim.reset_to_start()
    assert back.x == 0.0 and back.y == 0.0 and back.psi == 0.0 and back.u == 1.2
    assert back.encoder_counts == counts and back.time == o.time
    o = sim.step(inputs())
    assert all(c > c0 for c, c0 in zip(o.encoder_counts, counts))
