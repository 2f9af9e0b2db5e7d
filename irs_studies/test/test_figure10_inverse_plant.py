"""The Figure 10 experiment files on the design plant behind the printed R, S, T (offline cores).

One offline run (about 10 s): the file's rig plant and controller design plant are the
``irs_control.paper_inverse.INVERSE_PLANT`` and the MRC designed with the actuator follows the
reference model on it (docs/control_design.md: 13 % overshoot, max deviation 13 % of the step).
"""
import numpy as np

from irs_studies.figure10.report import run_metrics
from irs_bringup.experiment import load_experiment
from irs_bringup.offline_twin.from_experiment import offline_run
from irs_control.paper_inverse import INVERSE_PLANT, vehicle_part

NAMES = ('figure10_mrc_with_actuator_inverse_plant', 'figure10_mrc_without_actuator_inverse_plant',
         'figure10_pi_inverse_plant')


def _params(exp, node):
    return next(n for n in exp.nodes if n.name == node).params


def test_files_carry_the_inverse_plant():
    B, A = vehicle_part(INVERSE_PLANT)
    for name in NAMES:
        exp = load_experiment(name)
        rig, ctl = _params(exp, 'vehicle_sim'), _params(exp, 'lateral_controller')
        np.testing.assert_allclose(rig['identified.numerator'], B[1:] / B[0], rtol=1e-5)
        np.testing.assert_allclose(rig['identified.denominator'], A[1:3], rtol=1e-5)
        assert rig['identified.gain'] == round(float(B[0]), 5)
        np.testing.assert_allclose(ctl['plant_num'], B, rtol=1e-5)
        np.testing.assert_allclose(ctl['plant_den'], A, rtol=1e-5, atol=1e-9)


def test_mrc_with_actuator_follows_the_model_on_the_inverse_plant():
    m = run_metrics(offline_run(NAMES[0]))
    assert 0.0 < m['overshoot_percent'] < 20.0       # model's own: 9.3 %
    assert m['max_dev_rel'] < 0.2
