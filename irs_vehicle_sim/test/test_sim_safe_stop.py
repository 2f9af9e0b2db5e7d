"""The rig's safe actions (irs_vehicle_sim.safe_stop) composed with the rig core, offline.

A drive command that falls silent: drive 0 V at once with the car keeping its speed loses the
car off the front within 3 s; the controlled stop keeps it on the belt and brings car and belt
to rest together; recover brings the belt back to speed and releases the car. A stop that begins
with a heading error: steer 0 lets the car drift off the side while the belt coasts down; the
stop's lane hold brings it back to the centre line.
"""
import pytest

from irs_vehicle_sim.rig import RigConfig, RigInputs, RigSimulation
from irs_vehicle_sim.safe_stop import (HOLDING, RECOVERING, RUNNING, STOPPED, STOPPING,
                                       SafeStop, SafeStopParams)

DT = 1e-3


def _rig(plant='bicycle'):
    cfg = RigConfig.from_dict({'plant': plant, 'seed': 1})
    sim = RigSimulation(cfg)
    params = SafeStopParams(belt_gain=cfg.belt.gain / cfg.belt.pole, u_max=cfg.belt.u_max,
                            u0=cfg.u0, curvature_gain=sim.curvature_gain)
    return cfg, sim, SafeStop(params)


def _run(sim, safe, cfg, seconds, silent_from, plant_speed=1.2, safe_stop=True):
    """Steer 0, drive at the belt's equilibrium voltage for u0 until ``silent_from`` [s]; from
    then on no drive command arrives. Returns the states seen and the last outputs.
    """
    hold_voltage = cfg.u0 / (cfg.belt.gain / cfg.belt.pole)
    received = {'steering': 0.0, 'drive': 0.0}
    states = set()
    out = sim.outputs
    for _ in range(int(round(seconds / DT))):
        t = sim.time
        received['steering'] = t
        if t < silent_from:
            received['drive'] = t
        if safe_stop:
            safe.watch(t, received)
            states.add(safe.state)
        if safe_stop and safe.overriding:
            steer, drive, speed, sim.path_rate = safe.commands(out, plant_speed)
            inputs = RigInputs(steer, 0.0, drive, speed)
        elif safe_stop or t < silent_from:
            inputs = RigInputs(0.0, 0.0, hold_voltage, cfg.u0)    # late: the last one held
        else:
            inputs = RigInputs(0.0, 0.0, 0.0, cfg.u0)             # the old safe value: 0 V
        out = sim.step(inputs)
        if out.fault:
            break
    return states, out


def test_silent_drive_with_zero_volts_loses_the_car_off_the_front():
    cfg, sim, safe = _rig()
    _states, out = _run(sim, safe, cfg, 6.0, silent_from=1.0, safe_stop=False)
    assert out.fault_reason == 'off_belt:front'
    assert out.time < 4.5


def test_silent_drive_holds_then_stops_car_and_belt_together():
    cfg, sim, safe = _rig()
    states, out = _run(sim, safe, cfg, 20.0, silent_from=1.0)
    assert states == {RUNNING, HOLDING, STOPPING, STOPPED}
    assert not out.fault, out.fault_reason
    assert safe.state == STOPPED and 'drive command late' in safe.cause
    assert out.belt_speed < 0.01 and abs(out.u) < 0.01
    assert abs(out.x - cfg.x0) < 0.15      # the car moved with the belt, not over it


def test_short_stall_is_held_without_a_stop():
    cfg, sim, safe = _rig()
    received = {'steering': 0.0, 'drive': 0.0}
    seen = []
    for k in range(1000):
        t = k * DT
        received['steering'] = t
        if not 0.2 <= t < 0.6:          # a 0.4 s stall of the drive, shorter than the grace
            received['drive'] = t
        safe.watch(t, received)
        seen.append(safe.state)
    assert HOLDING in seen and STOPPING not in seen and seen[-1] == RUNNING


def test_stopped_car_does_not_drift_sideways():
    """At rest the lateral plant stands still (it advances on the car's path, at u / U)."""
    cfg, sim, safe = _rig()
    received = {'steering': 0.0, 'drive': 0.0}
    out = sim.step(RigInputs(0.05, 0.0, 2.27, cfg.u0))     # a little heading
    for _ in range(300):
        out = sim.step(RigInputs(0.05, 0.0, 2.27, cfg.u0))
    safe.stop('test')
    for _ in range(int(30 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(out, cfg.bicycle['speed'])
        out = sim.step(RigInputs(steer, 0.0, drive, speed))
    assert safe.state == STOPPED and not out.fault
    y_rest = out.y
    for _ in range(int(10 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(out, cfg.bicycle['speed'])
        out = sim.step(RigInputs(steer, 0.0, drive, speed))
    assert out.y == y_rest
    del received


def test_recover_spins_the_belt_up_before_releasing_the_car():
    cfg, sim, safe = _rig()
    safe.stop('test')
    for _ in range(int(15 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(sim.outputs, 1.2)
        sim.step(RigInputs(steer, 0.0, drive, speed))
    assert safe.state == STOPPED and sim.outputs.belt_speed < 0.01
    safe.recover()
    received = {'steering': 0.0, 'drive': 0.0}
    released = None
    t0 = sim.time
    for _ in range(int(5 / DT)):
        t = sim.time
        received.update(steering=t, drive=t)
        steer, drive, speed, sim.path_rate = safe.commands(sim.outputs, 1.2)
        assert steer == 0.0                              # recovering: the car is held straight
        sim.step(RigInputs(steer, 0.0, drive, speed))
        out = sim.reset_to_start()                       # the car is held at its start pose
        if safe.ready(out.belt_speed_measured, t, received):
            released = t - t0
            break
    assert released is not None and released < 3.0
    assert safe.state == RUNNING and abs(sim.outputs.belt_speed - cfg.u0) <= 0.06
    assert sim.outputs.x == cfg.x0


def test_recover_waits_for_fresh_commands():
    _cfg, _sim, safe = _rig()
    safe.recover()
    assert safe.state == RECOVERING
    assert not safe.ready(1.2, 10.0, {'steering': 10.0})          # no drive command yet
    assert not safe.ready(1.2, 10.0, {'steering': 10.0, 'drive': 9.0})   # a stale one
    assert safe.ready(1.2, 10.0, {'steering': 10.0, 'drive': 9.95})


@pytest.mark.parametrize('bad', [{'stall_grace': 0.05}, {'command_timeout': -1.0},
                                 {'u_max': float('nan')}])
def test_params_refused(bad):
    with pytest.raises(ValueError):
        SafeStopParams(**bad)


def test_a_rig_behind_real_time_stops():
    """A rig more than stall_grace behind real time (starved itself) stops, whatever the ages
    of its inputs (they look fresh: the graph answers what little the rig publishes).
    """
    _cfg, _sim, safe = _rig()
    fresh = {'steering': 10.0, 'drive': 10.0}
    assert safe.watch(10.0, fresh, lag=0.4) == '' and safe.state == RUNNING
    cause = safe.watch(10.0, fresh, lag=0.6)
    assert safe.state == STOPPING and 'behind real time' in cause


def _stop_with_heading(plant: str, steer_before: float, lane_hold: bool):
    """Run 0.4 s on a constant steer (a heading error builds up), then the controlled stop for
    25 s; the rig's steer is its lane hold, or 0 rad. Returns the largest |y| [m] and the last
    outputs.
    """
    cfg, sim, safe = _rig(plant)
    hold_voltage = cfg.u0 / (cfg.belt.gain / cfg.belt.pole)
    out = sim.outputs
    for _ in range(400):
        out = sim.step(RigInputs(steer_before, 0.0, hold_voltage, cfg.u0))
    assert abs(out.psi) > 0.02            # the stop begins with a heading error
    safe.stop('test')
    y_max = 0.0
    for _ in range(int(25 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(out, sim.plant_speed)
        assert abs(steer) <= safe.params.steer_limit
        out = sim.step(RigInputs(steer if lane_hold else 0.0, 0.0, drive, speed))
        y_max = max(y_max, abs(out.y))
        if out.fault:
            break
    return y_max, out, safe


@pytest.mark.parametrize('steer_before', [0.05, -0.05])
def test_a_stop_with_steer_zero_lets_a_heading_error_carry_the_car_off_the_side(steer_before):
    y_max, out, _safe = _stop_with_heading('bicycle', steer_before, lane_hold=False)
    assert y_max > 0.4
    assert out.fault_reason in ('off_belt:left', 'off_belt:right') or abs(out.y) > 0.4


@pytest.mark.parametrize('plant', ['bicycle', 'identified'])
@pytest.mark.parametrize('steer_before', [0.05, -0.05])
def test_the_stops_lane_hold_brings_the_car_back_to_the_centre_line(plant, steer_before):
    y_max, out, safe = _stop_with_heading(plant, steer_before, lane_hold=True)
    assert not out.fault, out.fault_reason
    assert safe.state == STOPPED
    assert y_max < 0.05                   # 0.4-0.5 m with steer 0 (test above)
    assert abs(out.y_s) < 0.005 and abs(out.psi) < 0.005


def test_lane_steer_sign_limit_and_bad_pose():
    safe = SafeStop(SafeStopParams(curvature_gain=4.0))
    assert safe.lane_steer(0.01, 0.0) < 0.0 < safe.lane_steer(-0.01, 0.0)   # REP 103: y left
    assert safe.lane_steer(0.0, 0.01) < 0.0 < safe.lane_steer(0.0, -0.01)
    assert safe.lane_steer(5.0, 0.0) == -safe.params.steer_limit
    w, z = safe.params.lane_omega, safe.params.lane_damping
    expected = -(w * w * 0.001 + 2 * z * w * 0.002) / 4.0
    assert safe.lane_steer(0.001, 0.002) == pytest.approx(expected)
    assert safe.lane_steer(float('nan'), 0.0) == 0.0 == safe.lane_steer(0.0, float('inf'))


@pytest.mark.parametrize('plant, length', [('bicycle', 0.26), ('identified', 1.60),
                                           ('two_track', 0.30)])
def test_curvature_gain_of_each_plant(plant, length):
    """1 / kappa: about the wheelbase for a physical car (with its understeer), 1.6 m for the
    paper's Eq. 6 (``K n0 / (d0 U^2)`` = 12.53 * 11.52 / (160 * 1.44) = 0.627 1/m).
    """
    sim = RigSimulation(RigConfig.from_dict({'plant': plant}))
    assert 1.0 / sim.curvature_gain == pytest.approx(length, rel=0.01)


@pytest.mark.parametrize('torque_loop', [False, True])
def test_the_torque_cars_stop_holds_it_with_its_wheel_torques(torque_loop):
    """The torque car's speed comes from its wheel torques, not a speed command: with 0 N m in
    the stop the free-rolling car is dragged off the rear; the stop's speed loop on the wheel
    torques holds it where the stop began while the belt coasts down.
    """
    cfg = RigConfig.from_dict({'plant': 'two_track', 'seed': 1})
    sim = RigSimulation(cfg)
    safe = SafeStop(SafeStopParams(belt_gain=cfg.belt.gain / cfg.belt.pole, u_max=cfg.belt.u_max,
                                   u0=cfg.u0, curvature_gain=sim.curvature_gain,
                                   **sim.stop_torque_params()))
    safe.stop('test')
    out = sim.outputs
    drift = 0.0                      # [m] the largest distance from where the stop began
    stopped_at = None                # [s] when the belt had coasted down (about 10.7 s)
    for _ in range(int(25 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(out, sim.plant_speed)
        torque = safe.stop_torque(speed, out.u) if torque_loop else (0.0,) * 4
        assert all(abs(t) <= sim.torque_car.torque_limit for t in torque)
        out = sim.step(RigInputs(steer, 0.0, drive, speed, torque))
        drift = max(drift, abs(out.x - cfg.x0))
        if out.fault:
            break
        if safe.state == STOPPED and stopped_at is None:
            stopped_at = out.time
        if stopped_at is not None and out.time >= stopped_at + 2.0:
            break                    # held for 2 s at rest
    if not torque_loop:
        assert out.fault_reason == 'off_belt:rear' and out.time < 5.0
        return
    assert not out.fault, out.fault_reason
    assert stopped_at is not None and safe.state == STOPPED
    assert drift < 0.05 and abs(out.x - cfg.x0) < 0.05, (drift, out.x - cfg.x0)


def _stop_from(u0, belt_speed, x0, mu, torque_limit=None):
    """The torque car's controlled stop from a car ``u0`` [m/s] over a belt at ``belt_speed``
    [m/s], at ``x0`` [m] on a surface of friction ``mu``; the stop's own torque limit unless
    ``torque_limit`` [N m] is given. Returns the last outputs, the state machine, the extremes
    of x [m] and the largest drive slip of any wheel [-].
    """
    cfg = RigConfig.from_dict({'plant': 'two_track', 'seed': 1, 'u0': u0,
                               'belt_speed0': belt_speed, 'x0': x0, 'speed_cmd_max': 8.0,
                               'surface': {'kind': 'uniform', 'mu': mu}})
    sim = RigSimulation(cfg)
    params = sim.stop_torque_params()
    if torque_limit is not None:
        params['torque_limit'] = torque_limit
    safe = SafeStop(SafeStopParams(belt_gain=cfg.belt.gain / cfg.belt.pole, u_max=cfg.belt.u_max,
                                   u0=1.2, curvature_gain=sim.curvature_gain, **params))
    safe.stop('test')
    out = sim.outputs
    xs, slip = [out.x], 0.0
    for _ in range(int(30 / DT)):
        steer, drive, speed, sim.path_rate = safe.commands(out, sim.plant_speed)
        out = sim.step(RigInputs(steer, 0.0, drive, speed, safe.stop_torque(speed, out.u)))
        xs.append(out.x)
        slip = max(slip, max(out.tyre.slip))
        if out.fault or safe.state == STOPPED:
            break
    return out, safe, min(xs), max(xs), slip


def test_the_torque_cars_stop_does_not_spin_its_wheels_and_holds_a_car_behind_a_fast_belt():
    """A stop that finds the car 1.16 m/s slower than a belt at 6.52 m/s, on mu 0.3 (the state of
    a real-time process-per-node run whose belt had run away, 2026-12-03): the stop must speed
    the car up to the belt. Its torque is limited to 0.7 of what a tyre transmits
    (``RigSimulation.stop_torque_params``): the wheels do not spin, and the car comes to rest
    with the belt, on it. With the motors' 0.3 N m, 4.3 times a tyre's grip on mu 0.3, the wheels
    spin and the car is lost.
    """
    out, safe, x_min, x_max, slip = _stop_from(5.36, 6.52, 0.455, 0.3)
    assert safe.params.torque_limit < 0.3 * 9.81 * 2.86 / 4 * 0.033
    assert not out.fault and safe.state == STOPPED, out.fault_reason
    assert -0.5 < x_min and x_max < 0.6, (x_min, x_max)
    assert slip < 0.2, slip
    lost, _, _, _, spun = _stop_from(5.36, 6.52, 0.455, 0.3, torque_limit=0.3)
    assert lost.fault and spun > 1.0, (lost.fault_reason, spun)
