"""Tests of the linear bicycle model (irs_models.bicycle)."""

import math

import numpy as np
import pytest
from scipy import signal

from irs_models.bicycle import (BicycleParams, bicycle_state_space, tf_coefficients,
                                     transfer_function, zpk)

SCALE = BicycleParams(mass=2.2, yaw_inertia=0.04, lf=0.12, lr=0.14, c_f=30.0, c_r=40.0,
                      track=0.17, wheel_radius=0.033, rear_steer=True)
SEDAN = BicycleParams(mass=1550.0, yaw_inertia=2600.0, lf=1.04, lr=1.58, c_f=81e3, c_r=75e3,
                      track=1.45, wheel_radius=0.31)


def eq5_front(p, V, ds):
    """Independent transcription of the paper's Eq. (5) (reconstructed, see bicycle.py)."""
    m, Iz, L1, L2, Cf, Cr = p.mass, p.yaw_inertia, p.lf, p.lr, p.c_f, p.c_r
    L = L1 + L2
    num = [Cf * V**2 * (m * L1 * ds + Iz), Cf * Cr * L * V * (ds + L2), Cf * Cr * L * V**2]
    den = [Iz * m * V**2, V * (Iz * (Cr + Cf) + m * (Cr * L2**2 + Cf * L1**2)),
           m * V**2 * (Cr * L2 - Cf * L1) + Cf * Cr * L**2, 0.0, 0.0]
    return np.array(num), np.array(den)


def ss_tf(p, V, ds, col):
    A, B, C, D = bicycle_state_space(p, V, ds)
    num, den = signal.ss2tf(A, B[:, [col]], C, D[:, [col]])
    num = np.trim_zeros(num[0], 'f')
    # drop numerically-zero leading terms
    while abs(num[0]) < 1e-9 * np.max(np.abs(num)):
        num = num[1:]
    return num / den[0], den / den[0]


@pytest.mark.parametrize(
    'p,V,ds',
    [(SCALE, 1.2, 0.33), (SCALE, 0.7, 0.0), (SEDAN, 12.0, 0.0), (SEDAN, 25.0, 1.9),
     (SEDAN, 12.0, -0.5)],
)
def test_state_space_matches_symbolic_eq5_front(p, V, ds):
    n_sym, d_sym = eq5_front(p, V, ds)
    n_ss, d_ss = ss_tf(p, V, ds, 0)
    np.testing.assert_allclose(d_ss, d_sym / d_sym[0], rtol=1e-9, atol=1e-9 * np.max(np.abs(d_ss)))
    np.testing.assert_allclose(n_ss, n_sym / d_sym[0], rtol=1e-8)
    n_mod, d_mod = tf_coefficients(p, V, ds, 'front')
    np.testing.assert_allclose(n_mod, n_sym, rtol=1e-12)
    np.testing.assert_allclose(d_mod, d_sym, rtol=1e-12)


@pytest.mark.parametrize('p,V,ds', [(SCALE, 1.2, 0.33), (SEDAN, 12.0, 0.0), (SEDAN, 20.0, 1.5)])
def test_state_space_matches_symbolic_rear(p, V, ds):
    n_sym, d_sym = tf_coefficients(p, V, ds, 'rear')
    n_ss, d_ss = ss_tf(p, V, ds, 1)
    np.testing.assert_allclose(n_ss, n_sym / d_sym[0], rtol=1e-8)
    np.testing.assert_allclose(d_ss, d_sym / d_sym[0], rtol=1e-9, atol=1e-9 * np.max(np.abs(d_ss)))
    # rear numerator C_r[(I_z - m l_r d_s) s^2 + C_f L V (l_f - d_s) s - C_f L V^2]: both zeros in
    # the LHP iff all three coefficients share a sign (Routh for a quadratic); at d_s = 0 exactly
    # one RHP zero (non-minimum phase).
    z, _, _ = zpk(p, V, ds, 'rear')
    same_sign = np.all(n_sym < 0) or np.all(n_sym > 0)
    assert bool(np.all(z.real < 0)) == bool(same_sign)
    z0, _, _ = zpk(p, V, 0.0, 'rear')
    assert np.sum(z0.real > 0) == 1


@pytest.mark.parametrize('p,V,ds', [(SCALE, 1.2, 0.33), (SEDAN, 12.0, 0.0), (SEDAN, 30.0, 2.0)])
def test_zero_reciprocal_sum_is_lr_plus_ds_over_speed(p, V, ds):
    z, poles, _ = zpk(p, V, ds)
    assert np.sum(np.abs(poles) == 0.0) == 2  # double integrator
    np.testing.assert_allclose(np.sum(1.0 / z).real, -(p.lr + ds) / V, rtol=1e-9)
    np.testing.assert_allclose(
        np.prod(z).real, p.c_r * p.wheelbase / (p.yaw_inertia + p.mass * p.lf * ds), rtol=1e-9
    )


def test_positive_front_steer_turns_left():
    A, B, C, D = bicycle_state_space(SEDAN, 12.0, 0.0)
    x_ss = -np.linalg.solve(A[:2, :2], B[:2, 0])  # steady v_y, r for unit delta_f
    assert x_ss[1] > 0.0  # CCW yaw rate
    # understeer: r/delta below the kinematic V/L
    assert x_ss[1] < 12.0 / SEDAN.wheelbase


def test_rear_input_column_is_physical_even_without_rear_steer():
    p = BicycleParams(**{**SEDAN.to_dict(), 'rear_steer': False})
    _, B, _, _ = bicycle_state_space(p, 12.0, 0.0)
    np.testing.assert_allclose(B[:2, 1], [p.c_r / p.mass, -p.c_r * p.lr / p.yaw_inertia])


def test_output_matrix_uses_ds():
    _, _, C, D = bicycle_state_space(SCALE, 1.2, 0.33)
    np.testing.assert_allclose(C, [[0, 0, 1, 0.33]])
    np.testing.assert_allclose(D, 0.0)


def test_actuator_lag_multiplies_response():
    wa = 2 * math.pi * 4.6
    n0, d0 = transfer_function(SCALE, 1.2, 0.33, as_control=False)
    n1, d1 = transfer_function(SCALE, 1.2, 0.33, actuator_pole=-wa, as_control=False)
    w = np.array([0.5, 3.0, 20.0, 100.0])
    _, h0 = signal.freqs(n0, d0, worN=w)
    _, h1 = signal.freqs(n1, d1, worN=w)
    np.testing.assert_allclose(h1, h0 * wa / (1j * w + wa), rtol=1e-10)
    _, p, _ = zpk(SCALE, 1.2, 0.33, actuator_pole=wa)
    assert np.min(np.abs(p + wa)) < 1e-9


def test_control_transfer_function_object():
    import control

    G = transfer_function(SEDAN, 12.0, 0.0)
    assert isinstance(G, control.TransferFunction)
    z, p, k = zpk(SEDAN, 12.0, 0.0)
    np.testing.assert_allclose(np.sort_complex(control.poles(G)), np.sort_complex(p), atol=1e-8)
    np.testing.assert_allclose(k, SEDAN.c_f / SEDAN.mass, rtol=1e-12)  # ds = 0: k = C_f/m


@pytest.mark.parametrize(
    'field,value',
    [('mass', -1.0), ('yaw_inertia', 0.0), ('lf', float('nan')), ('c_r', 'abc'),
     ('track', float('inf')), ('rear_steer', 'yes')],
)
def test_params_validation(field, value):
    with pytest.raises(ValueError, match=field):
        BicycleParams(**{**SCALE.to_dict(), field: value})


def test_bad_speed_ds_axle():
    with pytest.raises(ValueError, match='speed'):
        bicycle_state_space(SCALE, 0.0, 0.3)
    with pytest.raises(ValueError, match='ds'):
        bicycle_state_space(SCALE, 1.0, float('nan'))
    with pytest.raises(ValueError, match='axle'):
        transfer_function(SCALE, 1.0, 0.3, axle='middle')
    with pytest.raises(ValueError, match='actuator_pole'):
        transfer_function(SCALE, 1.0, 0.3, actuator_pole=0.0)
