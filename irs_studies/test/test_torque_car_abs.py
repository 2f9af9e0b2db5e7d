"""The three brakes of the torque car through the offline chassis loop (no ROS): locked wheels,
the fixed-target ABS and the peak-seeking ABS, on high, low and split mu and a mid-stop step.

``irs_bringup/offline_twin/chassis_loop.py`` steps the graph's cores in the graph's order (the
graph equals it to the bit: irs_system_tests/test/test_torque_car_graph.py, which also runs the
high-mu case of the peak-seeking ABS through the graph). Per surface the experiment files
``torque_braking_{locked,abs,abspeak}_<surface>`` differ only in ``brake.mode``. Stopping distance:
over the belt surface (the rig's ``x_belt``), from the brake start at 0.05 s to the first ``u <
0.02 m/s``.
"""
import numpy as np
import pytest

from irs_bringup.offline_twin.from_experiment import offline_run

SURFACES = ('high', 'low', 'split', 'step')
MODES = ('locked', 'abs', 'abspeak')
T_BRAKE = 0.05          # [s]
STOPPED = 0.02          # [m/s]


@pytest.fixture(scope='module')
def runs():
    """``{(mode, surface): offline run}`` of the twelve braking experiments."""
    return {(m, s): offline_run(f'torque_braking_{m}_{s}')
            for s in SURFACES for m in MODES}


def stop(r):
    """``(stopping distance over the belt [m], index of the stop)``."""
    i0 = int(np.flatnonzero(np.round(r['time'] * 1000) == round(T_BRAKE * 1000))[0])
    i1 = i0 + int(np.argmax(r['u'][i0:] < STOPPED))
    assert r['u'][i1] < STOPPED, 'the car must stop within the run'
    return float(r['x_belt'][i1] - r['x_belt'][i0]), i1


@pytest.mark.parametrize('surface', SURFACES)
def test_peak_seeking_abs_stops_at_least_as_short_as_the_better_of_the_other_two(runs, surface):
    d = {m: stop(runs[m, surface])[0] for m in MODES}
    print(f'{surface}: stopping distance ' + ', '.join(f'{m} {v:.4f} m' for m, v in d.items()))
    # On low mu the friction peak (slip 0.09) is at the fixed target (0.10): the seeker keeps the
    # target there after one probe, and the two ABS stop within a millimetre of each other:
    # which one is shorter depends on the car's state at the brake start.
    slack = 1e-3 if surface == 'low' else 0.0
    assert d['abspeak'] <= min(d['abs'], d['locked']) + slack
    # the tyre's sliding friction is 0.65 of its peak on every surface: any ABS beats locking
    assert d['abs'] < 0.8 * d['locked']


def test_the_peak_seeker_moves_the_target_up_on_dry_and_stays_near_the_baseline_on_wet(runs):
    means = {}
    for surface in ('high', 'low'):
        r = runs['abspeak', surface]
        _d, i1 = stop(r)
        braking = (r['time'][:i1] >= T_BRAKE) & (r['u'][:i1] > 0.2)
        means[surface] = float(np.mean(r['slip_target'][:i1][braking]))
    print(f'mean slip target: {means}')
    assert means['high'] < -0.105                  # measured -0.107: the peak is at 0.16
    assert -0.105 < means['low'] <= -0.10          # measured -0.103 (one probe): it is at 0.09
    assert np.all(runs['abs', 'high']['slip_target'] == -0.10)


def test_the_wheels_reference_speed_beats_the_arms_while_braking(runs):
    for (mode, surface), r in runs.items():
        if mode == 'locked':
            continue
        n = len(r['v_ref'])
        m = (r['time'][:n] >= T_BRAKE) & (r['u'][:n] > 0.2)
        err_ref = np.abs(r['v_ref'][m] - r['u'][:n][m])
        err_arm = np.abs(r['v_hat'][m] - r['u'][:n][m])
        # measured: at most 0.021-0.025 m/s (rms 0.005-0.006) against the arm's 0.084-0.097
        assert err_ref.max() < 0.03 and err_ref.max() < 0.5 * err_arm.max(), (mode, surface)
