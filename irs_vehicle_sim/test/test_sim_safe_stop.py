"""The rig's safe actions (irs_vehicle_sim.safe_stop) composed with the rig core, offline.

A drive command that falls silent: the old rule (drive 0 V at once, the car keeps its speed)
loses the car off the front within 3 s; the controlled stop keeps it on the belt and brings car
and belt to rest together; recover brings the belt back to speed and releases the car.
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
                            u0=cfg.u0)
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
            drive, speed, sim.path_rate = safe.commands(out, plant_speed)
            inputs = RigInputs(0.0, 0.0, drive, speed)
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
    assert safe.state == STOPPED and 'drive command silent' in safe.cause
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
        drive, speed, sim.path_rate = safe.commands(out, cfg.bicycle['speed'])
        out = sim.step(RigInputs(0.0, 0.0, drive, speed))
    assert safe.state == STOPPED and not out.fault
    y_rest = out.y
    for _ in range(int(10 / DT)):
        drive, speed, sim.path_rate = safe.commands(out, cfg.bicycle['speed'])
        out = sim.step(RigInputs(0.0, 0.0, drive, speed))
    assert out.y == y_rest
    del received


def test_recover_spins_the_belt_up_before_releasing_the_car():
    cfg, sim, safe = _rig()
    safe.stop('test')
    for _ in range(int(15 / DT)):
        drive, speed, sim.path_rate = safe.commands(sim.outputs, 1.2)
        sim.step(RigInputs(0.0, 0.0, drive, speed))
    assert safe.state == STOPPED and sim.outputs.belt_speed < 0.01
    safe.recover()
    received = {'steering': 0.0, 'drive': 0.0}
    released = None
    t0 = sim.time
    for _ in range(int(5 / DT)):
        t = sim.time
        received.update(steering=t, drive=t)
        drive, speed, sim.path_rate = safe.commands(sim.outputs, 1.2)
        sim.step(RigInputs(0.0, 0.0, drive, speed))
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
