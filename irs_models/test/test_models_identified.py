"""Identified plant (Eq. 6 without actuator) and the bicycle wrapper vs continuous models."""

from fractions import Fraction
import math

import control
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from irs_models import bicycle as bic, presets
from irs_models.constants import PAPER_PLANT_GAIN
from irs_models.identified import (IdentifiedParams, IdentifiedPlant, fma, identified_matrices,
                                   identified_plant, numpy_dot_form)
from irs_models.lateral_plant import BicyclePlant, LateralPlant

DT = 1e-3


def g_tf(K):
    s = control.tf('s')
    return K * (s + 2.4) * (s + 4.8) / (s**2 * (s + 8) * (s + 20))


def test_gain_is_full_plant_b0_over_actuator_pole():
    b0 = PAPER_PLANT_GAIN
    assert b0 == pytest.approx(363.394, abs=1e-3)
    assert IdentifiedParams().resolved_gain() == pytest.approx(b0 / 29.0, rel=1e-12)


def test_actuator_times_G_equals_the_transfer_function():
    num, den = identified_plant(include_actuator=True)
    A, B, C, D, _, _ = identified_matrices()
    G = control.ss2tf(control.ss(A, B, C, D))
    full = control.minreal(G * control.tf([29.0], [1.0, 29.0]), verbose=False)
    ref = control.tf(np.asarray(num, float), np.asarray(den, float))
    w = np.logspace(-1, 2, 30)
    np.testing.assert_allclose(np.abs(full(1j * w)), np.abs(ref(1j * w)), rtol=1e-9)


def test_poles_zeros_and_high_frequency_gain_of_realization():
    A, B, C, D, Ca, Da = identified_matrices()
    K = IdentifiedParams().resolved_gain()
    eig = np.sort(np.linalg.eigvals(A).real)
    np.testing.assert_allclose(eig, [-20.0, -8.0, 0.0, 0.0], atol=1e-6)
    z = np.sort(control.zeros(control.ss(A, B, C, D)).real)
    np.testing.assert_allclose(z, [-4.8, -2.4], rtol=1e-9)
    assert (C @ B)[0, 0] == 0.0
    assert (C @ A @ B)[0, 0] == pytest.approx(K)  # relative degree 2, gain K
    # acceleration row consistent with A
    np.testing.assert_array_equal(Ca[0], A[1])
    assert Da[0, 0] == B[1, 0]


def test_discrete_step_matches_continuous_tf():
    plant = IdentifiedPlant()
    plant.reset()
    K = plant.params.resolved_gain()
    delta = 0.01
    n = 2000
    ys = np.empty(n + 1)
    ys[0] = plant.y_s
    for k in range(n):
        plant.step(delta, 0.0, DT)
        ys[k + 1] = plant.y_s
    t = np.arange(n + 1) * DT
    # independent realisation through python-control
    _, yref = control.step_response(g_tf(K), T=t)
    np.testing.assert_allclose(ys, delta * yref, rtol=1e-6, atol=1e-12)
    # analytic: partial fractions of K N(s) / (s^3 (s+8)(s+20))
    from scipy.signal import residue
    r, p, kk = residue(K * np.polymul([1, 2.4], [1, 4.8]),
                       np.polymul([1, 0, 0, 0], np.polymul([1, 8], [1, 20])))
    # residue groups repeated roots: r_j/(s-p)^m for successive m
    yan = np.zeros_like(t)
    seen = {}
    for rj, pj in zip(r, p):
        key = round(pj.real, 6)
        m = seen.get(key, 0) + 1
        seen[key] = m
        yan += (rj * t**(m - 1) / math.factorial(m - 1) * np.exp(pj * t)).real
    np.testing.assert_allclose(ys, delta * yan, rtol=1e-6, atol=1e-10)


def test_dc_acceleration_and_kinematic_pose():
    plant = IdentifiedPlant()
    plant.reset()
    K = plant.params.resolved_gain()
    U, ds = plant.params.speed, plant.params.ds
    delta = 0.01
    for _ in range(3000):
        plant.step(delta, 0.0, DT)
    a_dc = K * 2.4 * 4.8 / (8 * 20)
    assert plant.yaw_rate * U == pytest.approx(a_dc * delta, rel=1e-8)
    assert plant.psi == pytest.approx(plant.x[1] / U)
    assert plant.y_cg == pytest.approx(plant.y_s - ds * math.sin(plant.psi))
    assert plant.lateral_velocity == 0.0
    # rear steer is ignored by Eq. 6
    p2 = IdentifiedPlant()
    p2.reset()
    p2.step(0.0, 0.2, DT)
    assert p2.y_s == 0.0 and p2.psi == 0.0


def test_identified_bad_params():
    with pytest.raises(ValueError, match='speed'):
        IdentifiedPlant(IdentifiedParams(speed=0.0))
    with pytest.raises(ValueError, match='gain'):
        IdentifiedPlant(IdentifiedParams(gain=-1.0))


def test_bicycle_plant_matches_continuous_state_space():
    pre = presets.get_preset('irs_2wd')
    plant = BicyclePlant(pre.params, 1.2, 0.33)
    assert isinstance(plant, LateralPlant)
    assert isinstance(IdentifiedPlant(), LateralPlant)
    plant.reset()
    A, B, C, D = bic.bicycle_state_space(pre.params, 1.2, 0.33)
    n = 1500
    t = np.arange(n + 1) * DT
    out = np.empty((n + 1, 4))
    out[0] = plant.x
    for k in range(n):
        plant.step(0.01, -0.005, DT)
        out[k + 1] = [plant.lateral_velocity, plant.yaw_rate, plant.y_cg, plant.psi]
    sys_c = control.ss(A, B, np.eye(4), np.zeros((4, 2)))
    U = np.vstack([np.full(n + 1, 0.01), np.full(n + 1, -0.005)])
    res = control.forced_response(sys_c, T=t, U=U)
    np.testing.assert_allclose(out, res.outputs.T, rtol=1e-7, atol=1e-12)
    assert plant.y_s == pytest.approx(plant.y_cg + 0.33 * math.sin(plant.psi))


def test_discretisation_is_the_exact_zoh():
    """cont2discrete's ZOH is the matrix exponential of [[A, B], [0, 0]] dt, to the bit."""
    from scipy.linalg import expm
    plant = IdentifiedPlant()
    for dt in (1e-4, 1e-3, 0.0123):
        m = np.zeros((5, 5))
        m[:4, :4], m[:4, 4:] = plant.A, plant.B
        e = expm(m * dt)
        Ad, Bd = plant.discrete(dt)
        assert np.array_equal(Ad, e[:4, :4]) and np.array_equal(Bd, e[:4, 4:]), dt


_MAGNITUDE = st.floats(-300, 300)


@settings(max_examples=300, deadline=None)
@given(a=st.floats(0.5, 1.0), b=st.floats(0.5, 1.0), c=st.floats(0.5, 1.0),
       ea=_MAGNITUDE, eb=_MAGNITUDE, ec=st.floats(-600, 600),
       signs=st.tuples(st.booleans(), st.booleans(), st.booleans()))
def test_fma_rounds_the_exact_a_b_plus_c_once(a, b, c, ea, eb, ec, signs):
    """The emulated fused multiply-add is the correctly rounded ``a b + c`` (exact rationals)."""
    a, b, c = (v * 2.0 ** int(e) * (-1 if s else 1)
               for v, e, s in zip((a, b, c), (ea, eb, ec), signs))
    assert fma(a, b, c) == float(Fraction(a) * Fraction(b) + Fraction(c))


def test_fma_differs_from_the_twice_rounded_sum_where_it_must():
    """1 + 2^-30 squared less 1: a twice-rounded sum loses the 2^-60 a single rounding keeps."""
    a = 1.0 + 2.0 ** -30
    assert a * a - 1.0 == 2.0 ** -29
    assert fma(a, a, -1.0) == 2.0 ** -29 + 2.0 ** -60


def test_numpy_dot_form_refuses_a_row_it_was_not_made_for():
    assert numpy_dot_form(np.array([1.0, 0.0, 2.0, 3.0])) is None
    assert numpy_dot_form(np.array([0.0, 0.0, 2.0])) is None
    assert numpy_dot_form(np.array([0.0, 0.0, 2.0, 3.0])) is not None


def test_the_yaw_rate_at_rest_and_at_extreme_states_is_numpys():
    """Zeros (signed) and magnitudes beyond the exact product's range go through numpy's dot."""
    plant = IdentifiedPlant()
    speed = plant.params.speed
    assert plant.yaw_rate == float(plant.Ca[0] @ plant.x + plant.Da[0, 0] * 0.0) / speed
    plant._x = (0.0, 0.0, 1e-200, -3e-150)
    assert plant.yaw_rate == float(plant.Ca[0] @ plant.x) / speed
