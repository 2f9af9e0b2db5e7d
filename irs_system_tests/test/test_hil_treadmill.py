"""``hil_treadmill_regulation`` in short form (the speed-up phase, 5 s) through the hardware node
and the emulated board and drive, lock-step: the graph is the hardware chain's offline twin to
the bit (every drive command: the regulator read the same pose and belt speed every step), and
the emulated car stays at the set point as on ``vehicle_sim`` (``test_experiments``: peak
position error under 0.15 m, settled to +-2 cm within 2.5 s of the speed change).
"""
import numpy as np

from irs_bag.run_series import series_by_stamp
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import ExperimentRunner
from irs_bringup.offline_twin.from_experiment import hardware_loop
from irs_studies.regulation_metrics import phase_metrics

DURATION = 5.0     # [s] the driver speeds up at 0.5 s (0 -> 1.2 m/s) and slows down at 4 s


def test_hil_treadmill_regulation_short(tmp_path):
    exp = load_experiment('hil_treadmill_regulation').composed()
    exp.duration = DURATION
    result = ExperimentRunner(exp, runs_dir=tmp_path, progress=False).run()
    assert result.completed, result.message
    assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes
    drive = series_by_stamp(result.bag_dir)['drive_voltage']
    twin = hardware_loop(load_experiment('hil_treadmill_regulation')).run(DURATION)
    n = len(twin['drive_voltage'])
    got = np.array([drive.get(k * 1_000_000, np.nan) for k in range(n)])
    assert np.array_equal(got, twin['drive_voltage']), \
        np.max(np.abs(got - twin['drive_voltage']))     # NaN too: a step missing
    assert np.max(twin['drive_voltage']) > 1.0, 'the belt was driven'
    up = phase_metrics(twin['time'], twin['x'], 0.3, [0.5, 4.0])[0]    # until the slow-down
    print(f"speed-up 0 -> 1.2 m/s on the hardware chain: peak position error "
          f"{up['peak_error']:.3f} m, settled to +-2 cm after {up['settling_time']:.2f} s")
    assert up['peak_error'] < 0.15 and up['settling_time'] < 2.5
    assert not twin['fault'].any()
