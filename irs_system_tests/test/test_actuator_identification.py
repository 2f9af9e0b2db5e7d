"""Identify the simulated steering actuator from its published state, as a user would.

The rig is driven with steps on ``steering/command``; from ``steering/state`` (commanded vs
achieved front steer) we identify the servo loop's time constant, the dead time, the rate limit
at the wheel (horn slew limit / gear ratio), the backlash width and the saturation, and compare
each with its parameter (5 % tolerance).  The friction dead zone, the minimum drive, the linkage
geometry and the radio frame are off here (the first offsets every settled angle, the second
speeds up small errors, the third changes the gain at large angles, the last makes the dead time
vary by a frame); the unit tests (irs_vehicle_sim/test/test_sim_actuator.py,
test_sim_radio_link.py) hold them to their closed forms and test_sysid_actuator.py here
identifies the whole servo from swept sines.
"""
import math

import numpy as np

from irs_system_tests.lockstep_harness import rig_spec, run_lockstep

LAG_HZ, DELAY, BACKLASH, LIMIT = 7.0, 0.017, math.radians(0.175), math.radians(15.0)
HORN_RATE, GEAR = math.radians(60.0) / 0.30, 3.0
RATE = HORN_RATE / GEAR   # [rad/s] at the wheel

SCHEDULE = [  # (from t [s], command [rad])
    (0.0, 0.0), (0.2, 0.02), (0.6, 0.035),  # take up the slack, then a step below the slew limit
    (1.0, 0.0), (1.4, -0.07), (1.8, 0.0),   # 0 approached from above, then from below: backlash
    (2.2, -0.4), (2.7, 0.4),                # saturated swing: rate limit, then saturation
]


def command(t):
    value = 0.0
    for start, v in SCHEDULE:
        if t >= start - 1e-12:
            value = v
    return value


def at(series, t):
    return series[int(round(t * 1000))]


def test_identified_actuator_matches_its_parameters(ros, launch):
    launch(rig_spec(**{'actuator_front.lag_hz': LAG_HZ, 'actuator_front.delay': DELAY,
                       'actuator_front.rate_limit': HORN_RATE, 'actuator_front.gear_ratio': GEAR,
                       'actuator_front.backlash': BACKLASH, 'actuator_front.limit': LIMIT,
                       'actuator_front.enable_friction': False,
                       'actuator_front.enable_linkage_geometry': False,
                       'actuator_front.min_drive': 0.0,
                       'actuator_front.enable_radio_frame': False}))
    rec = run_lockstep(ros, command, 3.6)
    stamps = sorted(rec['actuator'])
    t = np.array(stamps) * 1e-9
    ach = np.array([rec['actuator'][s].front_achieved for s in stamps])
    cmd = np.array([rec['actuator'][s].front_commanded for s in stamps])
    assert abs(at(cmd, 0.65) - 0.035) < 1e-12, 'the rig must report the command it received'

    # Lag and dead time: y = y0 + A (1 - exp(-(t - t0 - Td)/tau)) after the 0.02 -> 0.035 step.
    y0, y_end = at(ach, 0.599), at(ach, 0.999)
    win = (t > 0.6) & (t < 1.0)
    frac = (ach[win] - y0) / (y_end - y0)
    use = (frac > 0.05) & (frac < 0.95)
    slope, icpt = np.polyfit(t[win][use], np.log(1.0 - frac[use]), 1)
    tau = -1.0 / slope
    dead_time = icpt * tau - 0.6
    # Rate limit: steepest slope of the saturated swing.
    swing = (t > 2.7) & (t < 3.0)
    rate = np.max(np.abs(np.diff(ach[swing]))) / 0.001
    # Backlash: settled output at command 0, reached from above and from below.
    backlash = at(ach, 1.399) - at(ach, 2.199)
    # Saturation: the settled output at a command beyond the limit, plus half the play.
    saturation = at(ach, 3.599) + backlash / 2.0

    identified = {'time constant [s]': (tau, 1.0 / (2 * math.pi * LAG_HZ)),
                  'dead time [s]': (dead_time, DELAY), 'rate limit [rad/s]': (rate, RATE),
                  'backlash [rad]': (backlash, BACKLASH), 'saturation [rad]': (saturation, LIMIT)}
    for name, (got, want) in identified.items():
        print(
            f'{name:20s} identified {got:.6g}  configured {want:.6g}  error '
            f'{100 * (got / want - 1):+.2f} %'
        )
    for name, (got, want) in identified.items():
        assert abs(got / want - 1.0) < 0.05, f'{name}: identified {got:.6g}, configured {want:.6g}'
