"""Tyre model, surfaces and wheel encoders of the torque car (ROS-free)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_vehicle_sim.surface import SurfaceSpec
from irs_vehicle_sim.tyre import (TyreParams, lateral_slip, magic_shape, slip_rate,
                                  sliding_ratio, tyre_forces)
from irs_vehicle_sim.wheel_encoder import EncoderParams, WheelEncoders

P = TyreParams()
FZ = 7.0


def test_small_slip_is_linear_with_the_stiffnesses():
    fx, fy = tyre_forces(1e-4, 0.0, FZ, 0.8, P)
    assert fx == pytest.approx(P.c_kappa * FZ * 1e-4, rel=1e-4) and fy == 0.0
    fx, fy = tyre_forces(0.0, 1e-4, FZ, 0.3, P)
    assert fy == pytest.approx(-P.c_alpha * FZ * 1e-4, rel=1e-4) and fx == 0.0


@pytest.mark.parametrize('mu', [0.3, 0.8])
def test_peak_and_sliding_friction(mu):
    kappas = np.linspace(-1.0, 0.0, 20001)
    fx = np.array([tyre_forces(k, 0.0, FZ, mu, P)[0] for k in kappas])
    assert -fx.min() == pytest.approx(mu * FZ, rel=1e-4)      # peak: mu F_z
    k_peak = kappas[np.argmin(fx)]
    assert k_peak == pytest.approx(-P.shape_c * math.tan(math.pi / (2 * P.shape_c)) * mu
                                   / P.c_kappa, abs=1e-3)
    assert magic_shape(1e7, P) == pytest.approx(sliding_ratio(P), abs=1e-6)
    assert 0.5 < sliding_ratio(P) < 1.0


@settings(max_examples=200, deadline=None)
@given(st.floats(-1.0, 3.0), st.floats(-20.0, 20.0), st.floats(0.05, 1.5))
def test_combined_force_within_friction_circle_and_opposing_slip(kappa, s_y, mu):
    fx, fy = tyre_forces(kappa, s_y, FZ, mu, P)
    assert math.hypot(fx, fy) <= mu * FZ * (1 + 1e-9)
    # the force points along (C_k kappa, -C_a s_y)
    assert fx * kappa >= 0.0 and fy * s_y <= 0.0


def test_braking_slip_takes_cornering_force_away():
    fy_free = tyre_forces(0.0, 0.1, FZ, 0.8, P)[1]
    fy_locked = tyre_forces(-1.0, 0.1, FZ, 0.8, P)[1]
    assert abs(fy_locked) < 0.2 * abs(fy_free)


def test_slip_definitions_at_standstill_and_locked():
    assert lateral_slip(0.0, 0.0, P) == 0.0 and slip_rate(0.0, 0.0, 0.0, P) == 0.0
    assert math.isfinite(lateral_slip(0.0, 0.05, P))
    assert slip_rate(-1.0, 0.0, 1.2, P) == pytest.approx(0.0)        # locked wheel: kappa = -1
    assert slip_rate(0.1, 1.1 * 1.2, 1.2, P) == pytest.approx(0.0)   # 10 % drive slip
    assert tyre_forces(0.1, 0.1, -1.0, 0.8, P) == (0.0, 0.0)          # lifted wheel


def test_bad_tyre_parameters_refused():
    with pytest.raises(ValueError, match='shape_c'):
        TyreParams(shape_c=2.5)
    with pytest.raises(ValueError, match='c_kappa'):
        TyreParams(c_kappa=-1.0)
    with pytest.raises(ValueError, match='unknown tyre'):
        TyreParams.from_dict({'c_kapa': 10.0})


def test_surfaces():
    assert SurfaceSpec().mu_at(0.0, 0.0, 0.0) == 0.8
    patch = SurfaceSpec.from_dict({'kind': 'patch', 'mu': 0.8, 'mu_patch': 0.2,
                                   'x_start': 0.1, 'x_end': 0.4})
    assert [patch.mu_at(x, 0.0, 0.0) for x in (0.0, 0.2, 0.5)] == [0.8, 0.2, 0.8]
    split = SurfaceSpec.from_dict({'kind': 'split', 'mu_left': 0.9, 'mu_right': 0.2})
    assert (split.mu_at(0.0, 0.05, 0.0), split.mu_at(0.0, -0.05, 0.0)) == (0.9, 0.2)
    step = SurfaceSpec.from_dict({'kind': 'step', 'mu': 0.8, 'mu_after': 0.3, 't_step': 2.0})
    assert (step.mu_at(0, 0, 1.9), step.mu_at(0, 0, 2.0)) == (0.8, 0.3)
    assert split.mu_max == 0.9


@pytest.mark.parametrize('spec, match', [
    ({'kind': 'ice'}, 'kind must be one of'),
    ({'kind': 'split', 'mu': 0.5}, 'reads only'),
    ({'kind': 'uniform', 'mu': 0.0}, 'friction coefficient'),
    ({'kind': 'patch', 'x_start': 0.5, 'x_end': 0.1}, 'x_start < x_end'),
    ({'kind': 'step', 't_step': float('nan')}, 'finite'),
    ('wet', 'mapping'),
])
def test_bad_surfaces_refused(spec, match):
    with pytest.raises(ValueError, match=match):
        SurfaceSpec.from_dict(spec)


def test_encoder_counts_and_velocity():
    enc = WheelEncoders(EncoderParams(counts_per_rev=2048, window=5))
    w = np.array([36.0, -36.0, 0.0, 10.0])
    for _ in range(100):
        counts, vel = enc.step(w, 1e-3)
    assert np.array_equal(counts, np.floor(w * 0.1 * 2048 / (2 * np.pi)).astype(int))
    res = 2 * np.pi / (2048 * 5e-3)
    assert np.all(np.abs(vel - w) <= res + 1e-9)
    assert np.all(np.abs(vel / res - np.round(vel / res)) < 1e-9)   # quantised
    with pytest.raises(ValueError, match='finite wheel speeds'):
        enc.step([np.nan, 0, 0, 0], 1e-3)
    with pytest.raises(ValueError, match='integer >= 1'):
        EncoderParams(window=0)
