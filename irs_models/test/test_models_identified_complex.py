"""Identified plant with complex zeros/poles, its rig parameters, and the bicycle realisation."""

import math

import control
import numpy as np
import pytest

from irs_models.bicycle import BicycleParams, tf_coefficients
from irs_models.identified import (IdentifiedParams, IdentifiedPlant, bicycle_realisation,
                                   identified_matrices, quadratic_roots)

# The design plant of irs_control.paper_inverse has complex zeros; any conjugate pair will do.
ZEROS = (complex(-18.8, 8.6), complex(-18.8, -8.6))
POLES = (complex(-12.8, 23.4), complex(-12.8, -23.4))


def test_complex_zeros_and_poles_give_the_configured_transfer_function():
    p = IdentifiedParams(gain=8.0, zeros=ZEROS, poles=POLES)
    A, B, C, D, _, _ = identified_matrices(p)
    num = 8.0 * np.real(np.poly(ZEROS))
    ref = control.tf(num, np.real(np.poly([0.0, 0.0, *POLES])))
    got = control.ss(A, B, C, D)
    w = np.logspace(-1, 3, 60)
    np.testing.assert_allclose(got(1j * w), ref(1j * w), rtol=1e-9)
    z = np.sort_complex(control.zeros(got))
    np.testing.assert_allclose(z, np.sort_complex(np.array(ZEROS)), rtol=1e-8)


def test_stepped_complex_plant_follows_the_continuous_response():
    p = IdentifiedParams(gain=8.0, zeros=ZEROS, poles=POLES)
    plant = IdentifiedPlant(p)
    plant.reset()
    t = np.arange(0, 1.001, 1e-3)
    u = 0.01 * np.sign(np.sin(2 * np.pi * 2 * t))          # a 2 Hz square steer [rad]
    ys = []
    for uk in u:
        ys.append(plant.y_s)
        plant.step(float(uk), 0.0, 1e-3)
    A, B, C, D, _, _ = identified_matrices(p)
    sysd = control.c2d(control.ss(A, B, C, D), 1e-3, 'zoh')
    ref = control.forced_response(sysd, T=t, U=u).outputs
    np.testing.assert_allclose(ys, ref, atol=1e-12 + 1e-9 * np.max(np.abs(ref)))


def test_quadratic_roots_and_coefficients_round_trip():
    assert quadratic_roots(7.2, 11.52) == pytest.approx((-4.8, -2.4))
    z = quadratic_roots(37.6, 427.2)
    assert z[0] == z[1].conjugate() and z[0].imag > 0
    n1, n0 = IdentifiedParams(zeros=z).numerator()
    assert (n1, n0) == pytest.approx((37.6, 427.2), rel=1e-12)


@pytest.mark.parametrize('zeros,poles,match', [
    ((complex(-1, 2), complex(-3, -2)), (-8.0, -20.0), 'conjugate'),
    ((complex(-1, 2),), (-8.0, -20.0), 'exactly two'),
    ((-2.4, math.nan), (-8.0, -20.0), 'finite'),
    ((-2.4, -4.8), (complex(0.5, 2), complex(0.5, -2)), 'left half plane'),
    ((-2.4, -4.8), ('x', -20.0), 'two roots'),
])
def test_bad_roots_are_refused_with_a_sentence(zeros, poles, match):
    with pytest.raises(ValueError, match=match):
        IdentifiedParams(zeros=zeros, poles=poles).validate()


def test_eq6_has_no_bicycle_realisation():
    # n1/n0 = (l_r + ds)/U gives l_r = 0.42 m; no positive (m, I_z, C_f, C_r, l_f) fits the poles
    assert bicycle_realisation() is None
    # complex zeros -18.8 +- 8.6j would need l_r + ds = U n1/n0 = 0.106 m < ds: impossible
    assert bicycle_realisation(IdentifiedParams(gain=8.0, zeros=ZEROS, poles=POLES)) is None


def test_a_bicycle_transfer_function_is_realised_as_that_bicycle():
    bp = BicycleParams(mass=1.8, yaw_inertia=0.04, lf=0.14, lr=0.16, c_f=20.0, c_r=15.0,
                       track=0.16, wheel_radius=0.033)
    U, ds = 1.2, 0.33
    num, den = tf_coefficients(bp, U, ds)
    z, p, K = np.roots(num), np.roots(den[:3]), num[0] / den[0]
    real = bicycle_realisation(IdentifiedParams(gain=K, zeros=tuple(z), poles=tuple(p),
                                                speed=U, ds=ds))
    assert real is not None
    scale = bp.mass / real['mass']          # m, I_z, C_f, C_r scale together
    assert real['lf'] == pytest.approx(bp.lf, rel=1e-5)
    assert real['lr'] == pytest.approx(bp.lr, rel=1e-5)
    for key, value in (('yaw_inertia', bp.yaw_inertia), ('c_f', bp.c_f), ('c_r', bp.c_r)):
        assert real[key] * scale == pytest.approx(value, rel=1e-5)


@pytest.mark.parametrize('half,low', [(1.0, 0.25), (0.25, 1.2)])
def test_kinematic_heading_is_not_the_bicycle_heading(half, low):
    """The documented error of psi = v_s / U (docs/vehicle_sim.md): 5 deg doublet on irs_2wd."""
    from irs_models import presets
    from irs_models.lateral_plant import BicyclePlant
    plant = BicyclePlant(presets.get_preset('irs_2wd').params, 1.2, 0.33)
    plant.reset()
    dt, a = 1e-3, math.radians(5.0)
    ys, psi = [], []
    for k in range(int((0.5 + 2 * half + 0.5) / dt)):
        t = k * dt
        delta = a if 0.5 <= t < 0.5 + half else (-a if 0.5 + half <= t < 0.5 + 2 * half else 0.0)
        plant.step(delta, 0.0, dt)
        ys.append(plant.y_s)
        psi.append(plant.psi)
    kinematic = np.gradient(np.array(ys), dt) / 1.2
    rel = np.max(np.abs(kinematic - np.array(psi))) / np.max(np.abs(psi))
    assert low < rel < 2.0 * low + 1.0      # 33 % at 1 s per half, 159 % at 0.25 s


def test_bicycle_heading_of_a_bicycle_transfer_function_is_that_bicycles():
    """heading='bicycle': psi, r and v of the realisation equal the bicycle's own (doublet)."""
    from irs_models import presets
    from irs_models.lateral_plant import BicyclePlant
    bp = presets.get_preset('irs_2wd').params
    U, ds = 1.2, 0.33
    num, den = tf_coefficients(bp, U, ds)
    ident = IdentifiedPlant(IdentifiedParams(
        gain=num[0] / den[0], zeros=tuple(np.roots(num)), poles=tuple(np.roots(den[:3])),
        speed=U, ds=ds, heading='bicycle'))
    bike = BicyclePlant(bp, U, ds)
    ident.reset()
    bike.reset()
    a, err, peak = math.radians(5.0), np.zeros(3), np.zeros(3)
    for k in range(1500):
        t = k * 1e-3
        delta = a if 0.5 <= t < 0.75 else (-a if 0.75 <= t < 1.0 else 0.0)
        ident.step(delta, 0.0, 1e-3)
        bike.step(delta, 0.0, 1e-3)
        got = np.array([ident.psi, ident.yaw_rate, ident.lateral_velocity])
        ref = np.array([bike.psi, bike.yaw_rate, bike.lateral_velocity])
        err = np.maximum(err, np.abs(got - ref))
        peak = np.maximum(peak, np.abs(ref))
    assert np.all(err < 1e-6 * peak)


def test_bicycle_heading_is_refused_for_eq6_with_a_sentence():
    with pytest.raises(ValueError, match='not the transfer function of any bicycle'):
        IdentifiedPlant(IdentifiedParams(heading='bicycle'))
    with pytest.raises(ValueError, match='heading'):
        IdentifiedParams(heading='yaw').validate()
