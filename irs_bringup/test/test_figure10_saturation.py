"""The README's Figure 10 saturation claim, on the offline cores (no ROS; the graph equals them).

"Steps above about 0.036 m saturate every MRC and the difference disappears": at 0.03 m neither
MRC design reaches the 15 deg steer limit and neglecting the actuator overshoots far more; at
0.05 m both hit the limit and both overshoot less than 2 % (with this project's anti-windup).
"""
import numpy as np
import pytest

from irs_bringup.paper.closed_loop import ClosedLoop
from irs_bringup.run.experiment import load_experiment
from irs_bringup.run.offline import loop_config_from_experiment
from irs_control.metrics import overshoot_percent

STEER_LIMIT = 0.2618   # [rad] 15 deg


def step_response(name: str, amplitude: float) -> dict:
    exp = load_experiment(name)
    exp.node('irs_control', 'reference_generator').params['signal.amplitude'] = amplitude
    return ClosedLoop(loop_config_from_experiment(exp)).run(exp.duration)


@pytest.mark.parametrize('amplitude, saturates', [(0.03, False), (0.05, True)])
def test_mrc_designs_saturate_above_about_0036_m(amplitude, saturates):
    runs = {key: step_response(f'figure10_mrc_{key}_actuator', amplitude)
            for key in ('with', 'without')}
    peak = {k: float(np.max(np.abs(r['steer_cmd']))) for k, r in runs.items()}
    over = {k: overshoot_percent(r['y_s'], amplitude) for k, r in runs.items()}
    if saturates:
        assert all(p >= STEER_LIMIT - 1e-9 for p in peak.values()), peak
        assert all(o < 2.0 for o in over.values()), over
    else:
        assert all(p < STEER_LIMIT - 1e-3 for p in peak.values()), peak
        assert over['without'] > 1.5 * over['with'], over
