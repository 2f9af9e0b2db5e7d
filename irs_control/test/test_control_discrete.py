"""Discrete RST and PI controllers: linear-range accuracy and anti-windup."""
import control
import numpy as np
import pytest

from irs_control.discrete_pi import DiscretePiController
from irs_control.discrete_rst import DiscreteRstController, anti_windup_polynomial
from irs_control.loop_sim import simulate_loop
from irs_control.metrics import overshoot_percent, settling_time
from irs_control.paper_design import identified_plant, paper_mrc_design
from irs_control.rst_design import design_rst


def _model_step(d, t):
    _, ym = control.step_response(control.tf(d.Bm, d.Am), t)
    return ym


@pytest.mark.parametrize('act', [True, False])
def test_linear_range_matches_reference_model(act):
    d = paper_mrc_design(act)
    B, A = identified_plant(act)
    amp = 0.02  # m: small enough that |steer| < 0.2618 rad throughout
    res = simulate_loop(DiscreteRstController(d, dt=1e-3), B, A, lambda t: amp, 3.0)
    assert not res.saturated.any()
    err = np.max(np.abs(res.y - amp * _model_step(d, res.t))) / amp
    assert err < 5e-3


def test_discretisation_error_converges_with_dt():
    d = paper_mrc_design(True)
    B, A = identified_plant(True)
    errs = []
    for dt in (2e-3, 5e-4):
        res = simulate_loop(DiscreteRstController(d, dt=dt), B, A, lambda t: 0.02, 2.0)
        errs.append(np.max(np.abs(res.y - 0.02 * _model_step(d, res.t))))
    assert errs[1] < 0.3 * errs[0]  # first order in dt: ratio ~ 0.25


def test_anti_windup_large_step():
    d = paper_mrc_design(True)
    B, A = identified_plant(True)
    amp = 0.3
    out = {}
    for aw in (True, False):
        res = simulate_loop(DiscreteRstController(d, anti_windup=aw), B, A, lambda t: amp, 8.0)
        assert res.saturated.any()
        assert np.all(np.abs(res.u) <= 0.2618 + 1e-12)
        out[aw] = (overshoot_percent(res.y, amp), settling_time(res.t, res.y, amp))
    assert out[True][0] < 3.0            # ~1.2 %
    assert out[False][0] > 20.0          # ~30 % when the states wind up
    assert out[True][1] < 0.6 * out[False][1]


def test_linear_behaviour_independent_of_aw_polynomial():
    d = paper_mrc_design(True)
    B, A = identified_plant(True)
    F2 = np.poly([-20.0] * 4)
    r1 = simulate_loop(DiscreteRstController(d), B, A, lambda t: 0.02, 1.0)
    r2 = simulate_loop(DiscreteRstController(d, aw_poly=F2), B, A, lambda t: 0.02, 1.0)
    np.testing.assert_allclose(r1.y, r2.y, atol=1e-12)


def test_default_aw_polynomial_and_validation():
    d = paper_mrc_design(True)
    F = anti_windup_polynomial(d)
    np.testing.assert_allclose(np.sort(np.roots(F).real), [-30, -30, -12, -12], atol=1e-4)
    with pytest.raises(ValueError, match='degree'):
        DiscreteRstController(d, aw_poly=[1, 1])
    with pytest.raises(ValueError, match='positive sample time'):
        DiscreteRstController(d, dt=0.0)
    with pytest.raises(ValueError, match='u_min < u_max'):
        DiscreteRstController(d, u_min=0.1, u_max=-0.1)


def test_step_output_and_reset():
    d = design_rst([1.0], [1, 0, 0], [4.0], [1, 2.8, 4.0], [1, 4.0])
    c = DiscreteRstController(d, dt=1e-3, u_min=-1.0, u_max=1.0, reference_limit=20.0)
    o = c.step(10.0, 0.0)  # direct term t0/r0 * 10 = 40 -> clipped
    assert o.saturated and o.u_sat == 1.0 and o.u_unsat == pytest.approx(40.0)
    c.step(10.0, 0.0)
    assert np.any(c.state != 0)
    c.reset()
    assert np.all(c.state == 0)
    o = c.step(0.0, 0.0)
    assert o.u_unsat == 0.0 and not o.saturated


def test_pi_steady_state_and_back_calculation():
    B, A = identified_plant(True)
    pi = DiscretePiController(kp=5.0, ki=3.0, dt=1e-3)
    res = simulate_loop(pi, B, A, lambda t: 0.05, 15.0)
    assert res.y[-1] == pytest.approx(0.05, rel=1e-2)
    # Back-calculation bounds the integrator during a long saturation.
    pi = DiscretePiController(kp=5.0, ki=3.0, dt=1e-3, limits=(-0.1, 0.1))
    pi_no = DiscretePiController(kp=5.0, ki=3.0, dt=1e-3, limits=(-0.1, 0.1), anti_windup=False)
    for _ in range(5000):
        pi.step(1.0, 0.0)
        pi_no.step(1.0, 0.0)
    assert pi_no.integral == pytest.approx(15.0, rel=1e-3)   # 3 * 1 m * 5 s
    # back-calculation equilibrium: ki e = (u - v)/Tt -> I = v - kp e + ki e Tt = 0.1
    assert pi.integral == pytest.approx(0.1, abs=1e-2)
    pi.reset()
    assert pi.integral == 0.0


def test_pi_validation():
    with pytest.raises(ValueError, match='u_min < u_max'):
        DiscretePiController(limits=(0.2, -0.2))
    with pytest.raises(ValueError, match='non-negative'):
        DiscretePiController(kp=-1.0)
