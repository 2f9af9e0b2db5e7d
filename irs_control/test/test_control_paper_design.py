"""Paper designs: closed loop equals the reference model; reconstruction facts."""
import numpy as np
import pytest

from irs_control.paper_design import (PAPER_PLANT_GAIN, PRINTED_R, PRINTED_T, identified_plant,
                                      paper_mrc_design, paper_observer, reconstruction_hypotheses,
                                      reference_model, relative_coefficient_errors)
from irs_control.polynomials import coeff_rel_error, degree, poly_div_exact


def test_gain_value():
    assert PAPER_PLANT_GAIN == pytest.approx(363.394, abs=1e-3)
    # S(0) route: b0 = Am(0) Ao(0) / 23779
    _, Am = reference_model()
    assert Am[-1] * paper_observer()[-1] / 23779 == pytest.approx(PAPER_PLANT_GAIN, rel=2e-4)


def test_identified_plant_structure():
    B, A = identified_plant(True)
    np.testing.assert_allclose(np.sort(np.roots(A).real), [-29, -20, -8, 0, 0], atol=1e-6)
    np.testing.assert_allclose(np.sort(np.roots(B)), [-4.8, -2.4])
    assert B[0] == pytest.approx(PAPER_PLANT_GAIN)
    B2, A2 = identified_plant(False)
    assert degree(A2) == 4
    # neglecting the unit-DC-gain lag 29/(s+29): same low-frequency gain lim s^2 G(s)
    assert B2[-1] / A2[-3] == pytest.approx(B[-1] / A[-3], rel=1e-12)
    assert B2[0] == pytest.approx(PAPER_PLANT_GAIN / 29.0)
    with pytest.raises(ValueError, match='positive'):
        identified_plant(True, actuator_pole=-1.0)


@pytest.mark.parametrize('act,obs', [(True, 'minimal'), (False, 'minimal'), (False, 'paper')])
def test_closed_loop_equals_model(act, obs):
    d = paper_mrc_design(act, observer=obs)
    assert d.closed_loop_freq_error(np.logspace(-2, 3, 500)) < 1e-9
    num, den = d.closed_loop()
    extra = np.polymul(d.Ao, d.B_plus)
    q_num, ok_n = poly_div_exact(num, extra)
    q_den, ok_d = poly_div_exact(den, extra)
    assert ok_n and ok_d
    assert coeff_rel_error(q_num, d.Bm) < 1e-9
    assert coeff_rel_error(q_den, d.Am) < 1e-9
    assert degree(d.S) <= degree(d.R) and degree(d.T) <= degree(d.R)


def test_with_actuator_reproduces_printed_t_and_s0():
    d = paper_mrc_design(True)
    assert np.max(relative_coefficient_errors(d.T, PRINTED_T)) < 1e-3
    assert d.S[-1] == pytest.approx(23779, rel=2e-4)
    np.testing.assert_allclose(d.R, [1, 28.2, 386.72, 1854.72, 2580.48], rtol=1e-6)
    np.testing.assert_allclose(np.sort_complex(d.closed_loop_poles),
                               np.sort_complex(np.r_[np.roots(d.Am), -12, -12, -2.4, -4.8]),
                               atol=1e-3)


def test_printed_r_inconsistent_with_zero_cancellation():
    # T proportional to Ao Bm => B- constant => (s+2.4)(s+4.8) must divide R. It does not.
    _, exact = poly_div_exact(PRINTED_R, [1, 7.2, 11.52], rtol=1e-3)
    assert not exact


def test_reconstruction_table():
    rows = reconstruction_hypotheses()
    errs = [r[3] for r in rows]
    assert errs == sorted(errs)
    chosen = [r for r in rows if '[chosen]' in r[0]][0]
    assert chosen[3] == pytest.approx(0.595, abs=2e-3)
    assert rows[0][3] == pytest.approx(0.318, abs=2e-3)  # vehicle-only, Ao = s + 12
    assert any(np.isinf(r[3]) and 'Non-causal' in r[0] for r in rows)
