"""The vehicle_sim node in lock-step: same numbers as the offline core, reproducible, faithful.

Each test plays the lateral controller: it answers every rig step with a steering command.
"""
import math

import numpy as np

from irs_vehicle_sim.rig import RigConfig, RigInputs, simulate

from irs_system_tests.lockstep_harness import offline_rig_params, rig_spec, run_lockstep

DT = 0.001


def step_steer(t):
    return 0.05 if t >= 0.1 else 0.0


def test_step_steer_matches_offline_core(ros, launch):
    launch(rig_spec())
    duration = 1.5
    rec = run_lockstep(ros, step_steer, duration)
    cfg = RigConfig.from_dict(offline_rig_params())
    off = simulate(cfg, lambda out: RigInputs(front_steer=step_steer(out.time),
                                              speed_cmd=cfg.u0), duration)
    stamps = sorted(rec['point'])[:len(off['time'])]
    y_node = np.array([rec['point'][s].point.y for s in stamps])
    y_core = off['y_s'][:len(stamps)]
    assert np.array_equal(
        np.array(stamps), np.round(off['time'][: len(stamps)] * 1e9).astype(np.int64)
    )
    assert np.max(np.abs(y_node - y_core)) < 1e-9
    assert abs(y_core[-1]) > 1e-3, 'the step must actually move the car'
    achieved = np.array([rec['actuator'][s].front_achieved for s in stamps])
    assert np.max(np.abs(achieved - off['steer_front'][:len(stamps)])) < 1e-12


def test_same_lockstep_run_twice_is_identical(ros, launch):
    def cmd(t):
        return 0.1 * math.sin(2 * math.pi * 1.5 * t)

    runs = []
    for _ in range(2):
        proc = launch(rig_spec(**{'arm.enable_noise': True, 'seed': 7}))
        rec = run_lockstep(ros, cmd, 0.6)
        proc.stop()
        runs.append(rec)
    a, b = runs
    for topic in ('point', 'actuator', 'arm'):
        assert sorted(a[topic]) == sorted(b[topic])
        for stamp in a[topic]:
            assert a[topic][stamp] == b[topic][stamp], (topic, stamp)
    noise = np.diff([a['arm'][s].position[0] for s in sorted(a['arm'])])
    assert np.std(noise) > 0, 'arm noise must be on for this test to mean anything'
