"""Tyre model, surfaces and wheel encoders of the torque car (ROS-free).

The tyre's peaks are checked against their sources by optimising the force curves with scipy
(not by reading the parameters back): the longitudinal peak slip and friction, the locked /
peak ratio against Burckhardt's surfaces, the exponent of the peak slip over mu against
Burckhardt's peaks, and the lateral peak angle of both axles.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import minimize_scalar

from irs_models.torque_car import CORNERING_STIFFNESS_PER_LOAD
from irs_vehicle_sim.surface import SurfaceSpec
from irs_vehicle_sim.tyre import (TyreParams, characteristic, contact, damped_slip, lateral_slip,
                                  peak_slips, relaxation_length, slip_rate, tmeasy_curve,
                                  tyre_forces)
from irs_vehicle_sim.wheel_encoder import EncoderParams, WheelEncoders

P = TyreParams()
FZ = 7.0
#: Burckhardt's mu(s) = c1 (1 - exp(-c2 s)) - c3 s (Kiencke and Nielsen, Automotive Control
#: Systems, 2005): dry asphalt, wet asphalt, snow.
BURCKHARDT = {'asphalt_dry': (1.2801, 23.99, 0.52), 'asphalt_wet': (0.857, 33.822, 0.347),
              'snow': (0.1946, 94.129, 0.0646)}


def _peak(f, hi):
    """``(x, f(x))`` of the maximum of ``f`` on ``[0, hi]`` (bounded Brent, 1e-10)."""
    r = minimize_scalar(lambda x: -f(x), bounds=(0.0, hi), method='bounded',
                        options={'xatol': 1e-10})
    return float(r.x), -float(r.fun)


def _burckhardt_peaks():
    """``(mu_peak, s_peak, mu_locked)`` of each Burckhardt surface."""
    out = []
    for c1, c2, c3 in BURCKHARDT.values():
        def mu(s):
            return c1 * (1.0 - math.exp(-c2 * s)) - c3 * s
        s, m = _peak(mu, 1.0)
        out.append((m, s, mu(1.0)))
    return np.array(out)


def test_small_slip_is_linear_with_the_stiffnesses():
    fx, fy = tyre_forces(1e-5, 0.0, FZ, 0.8, P)
    assert fx == pytest.approx(P.c_kappa * FZ * 1e-5, rel=1e-4) and fy == 0.0
    fx, fy = tyre_forces(0.0, 1e-5, FZ, 0.3, P)
    assert fy == pytest.approx(-P.c_alpha * FZ * 1e-5, rel=1e-4) and fx == 0.0


def test_burckhardt_surfaces_give_the_slip_exponent_and_the_sliding_ratio():
    b = _burckhardt_peaks()
    q = np.polyfit(np.log(b[:, 0]), np.log(b[:, 1]), 1)[0]
    assert q == pytest.approx(P.slip_mu_exponent, abs=0.01)          # 0.564
    ratios = b[:, 2] / b[:, 0]
    assert ratios.min() - 0.01 <= P.sliding_ratio_x <= ratios.max()  # 0.636 .. 0.684


@pytest.mark.parametrize('mu', [0.3, 0.5, 0.8, 1.0])
def test_longitudinal_peak_and_locked_friction(mu):
    """Braking slip: the peak of -F_x over kappa in [-1, 0] by scipy, against the source values:
    peak slip 0.16 (mu / 0.8)^0.56, peak mu F_z, locked wheel 0.65 of the peak.
    """
    s_pk, f_pk = _peak(lambda s: -tyre_forces(-s, 0.0, FZ, mu, P)[0], 1.0)
    assert s_pk == pytest.approx(0.16 * (mu / 0.8) ** 0.56, rel=1e-5)
    assert f_pk == pytest.approx(mu * FZ, rel=1e-9)
    locked = -tyre_forces(-1.0, 0.0, FZ, mu, P)[0]
    assert locked / f_pk == pytest.approx(0.65, rel=1e-9)
    # not in proportion to mu (the normalised-slip tyre put it at 0.287 mu)
    assert s_pk == pytest.approx(peak_slips(mu, P)[0], rel=1e-5)


@pytest.mark.parametrize('mu', [0.3, 0.8])
@pytest.mark.parametrize('axle', [0, 1])
def test_lateral_peak_angle_is_a_rubber_1_10_tyres(mu, axle):
    """Slip angle of the lateral peak (scipy over alpha in [0, 80 deg]), both axles' stiffness:
    18.3 deg on mu 0.8, 10.8 deg on mu 0.3, inside the 10-20 deg of rubber RC tyres, and the
    same on both axles (the peak slip is a tyre parameter, not a multiple of mu / C_a).
    """
    ca = CORNERING_STIFFNESS_PER_LOAD[axle]
    a_pk, f_pk = _peak(lambda a: -tyre_forces(0.0, math.tan(a), FZ, mu, P, c_alpha=ca)[1],
                       math.radians(80.0))
    assert math.tan(a_pk) == pytest.approx(0.33 * (mu / 0.8) ** 0.56, rel=1e-5)
    assert f_pk == pytest.approx(mu * FZ, rel=1e-9)
    assert 10.0 <= math.degrees(a_pk) <= 20.0


@pytest.mark.parametrize('mu', [0.3, 0.8])
@pytest.mark.parametrize('c', [P.c_kappa] + list(CORNERING_STIFFNESS_PER_LOAD))
def test_force_curves_are_concave_up_to_the_peak(mu, c):
    """TMeasy is concave from zero only with ``dF0 s_M / F_M >= 2``: the chosen peaks keep it."""
    lateral = c != P.c_kappa
    s_m = peak_slips(mu, P)[1 if lateral else 0]
    s = np.linspace(0.0, s_m, 2001)
    if lateral:
        f = np.array([-tyre_forces(0.0, x, FZ, mu, P, c_alpha=c)[1] for x in s])
    else:
        f = np.array([tyre_forces(x, 0.0, FZ, mu, P)[0] for x in s])
    assert np.all(np.diff(f, 2) <= 1e-12)


def test_tmeasy_curve_shape():
    assert tmeasy_curve(0.1, 10.0, 0.1, 0.8, 1.0, 0.5) == pytest.approx(0.8)
    assert tmeasy_curve(1.0, 10.0, 0.1, 0.8, 1.0, 0.5) == pytest.approx(0.5)
    assert tmeasy_curve(5.0, 10.0, 0.1, 0.8, 1.0, 0.5) == 0.5
    assert tmeasy_curve(0.55, 10.0, 0.1, 0.8, 1.0, 0.5) == pytest.approx(0.65)   # midpoint


@settings(max_examples=200, deadline=None)
@given(st.floats(-1.0, 3.0), st.floats(-20.0, 20.0), st.floats(0.05, 1.5))
def test_combined_force_within_friction_circle_and_opposing_slip(kappa, s_y, mu):
    fx, fy = tyre_forces(kappa, s_y, FZ, mu, P)
    assert math.hypot(fx, fy) <= mu * FZ * (1 + 1e-9)
    # the force points along (kappa, -s_y), scaled per direction
    assert fx * kappa >= 0.0 and fy * s_y <= 0.0


SPEED = st.floats(-2.0, 2.0) | st.sampled_from([0.0, -0.0, P.v_low_damping, -P.v_low_damping])


@settings(max_examples=2000, deadline=None)
@given(st.floats(-1.5, 1.5) | st.just(0.0), st.floats(-3.0, 3.0), SPEED, st.floats(-20.0, 20.0),
       st.floats(-2.0, 15.0) | st.just(0.0), st.floats(0.01, 2.0) | st.just(0.0) | st.just(-0.1),
       st.sampled_from([P.c_alpha, CORNERING_STIFFNESS_PER_LOAD[0]]))
def test_contact_equals_the_three_functions_to_the_bit(kappa, omega_r, v_cx, s_y, fz, mu, ca):
    kap = damped_slip(kappa, omega_r, v_cx, P)
    fx, fy = tyre_forces(kap, s_y, fz, mu, P, c_alpha=ca)
    sigma = relaxation_length(kap, s_y, v_cx, mu, P, c_alpha=ca)
    got = contact(kappa, omega_r, v_cx, s_y, fz, mu, P, ca)
    assert [x.hex() for x in got] == [x.hex() for x in (kap, fx, fy, sigma)]


def _combined_formula(kappa, s_y, mu, params, ca):
    """The combined-slip characteristic written out in one piece (Rill 2012 sec. 3.4.2, as
    :func:`tyre_forces` documents it): ``(F, cos phi, sin phi, dF0 s_N)``.
    """
    k = (mu / params.mu_ref) ** params.slip_mu_exponent
    sxm, sym = params.peak_slip_x * k, params.peak_slip_y * k
    hx, hy = mu / params.c_kappa, mu / ca
    nx = sxm / (sxm + sym) + hx / (hx + hy)
    ny = sym / (sxm + sym) + hy / (hx + hy)
    sxn, syn = kappa / nx, -s_y / ny
    s = math.hypot(sxn, syn)
    if s < 1e-15:
        return 0.0, 1.0, 0.0, 0.0
    c, sn = sxn / s, syn / s
    df0 = math.hypot(params.c_kappa * nx * c, ca * ny * sn)
    s_m = math.hypot(sxm / nx * c, sym / ny * sn)
    f_s = mu * math.hypot(params.sliding_ratio_x * c, params.sliding_ratio_y * sn)
    s_s = math.hypot(params.sliding_slip_x / nx * c, params.sliding_slip_y / ny * sn)
    return tmeasy_curve(s, df0, s_m, mu, s_s, f_s), c, sn, df0 * s


@settings(max_examples=2000, deadline=None)
@given(st.floats(-1.5, 1.5) | st.just(0.0), st.floats(-20.0, 20.0) | st.just(0.0),
       st.floats(0.01, 2.0), st.sampled_from([P.c_alpha, CORNERING_STIFFNESS_PER_LOAD[0]]),
       st.floats(0.1, 15.0))
def test_held_characteristic_gives_the_formulas_forces_to_the_bit(kappa, s_y, mu, ca, fz):
    """The two-track model computes the slip-independent part once per wheel and step."""
    f, c, sn, lin = _combined_formula(kappa, s_y, mu, P, ca)
    want = (0.0, 0.0) if lin == 0.0 else (fz * f * c, fz * f * sn)
    assert [x.hex() for x in tyre_forces(kappa, s_y, fz, mu, P, c_alpha=ca)] == \
        [x.hex() for x in want]
    ch = characteristic(mu, P, ca)
    for v_cx in (1.2, 0.01):     # at speed, and faded in (relaxation length from the ratio)
        assert [x.hex() for x in contact(kappa, 0.0, v_cx, s_y, fz, mu, P, ca, ch)] == \
            [x.hex() for x in contact(kappa, 0.0, v_cx, s_y, fz, mu, P, ca)]


def test_braking_slip_takes_cornering_force_away():
    fy_free = tyre_forces(0.0, 0.1, FZ, 0.8, P)[1]
    fy_locked = tyre_forces(-1.0, 0.1, FZ, 0.8, P)[1]
    assert abs(fy_locked) < 0.2 * abs(fy_free)


def test_saturated_relaxation_length_is_shorter_at_standstill_only():
    assert relaxation_length(-1.0, 0.0, 0.0, 0.8, P) == pytest.approx(
        max(P.relaxation_length_min, P.relaxation_length * 0.65 * 0.8 / P.c_kappa))
    assert relaxation_length(-1.0, 0.0, 1.2, 0.8, P) == P.relaxation_length
    assert relaxation_length(0.0, 0.0, 0.0, 0.8, P) == P.relaxation_length


def test_slip_definitions_at_standstill_and_locked():
    assert lateral_slip(0.0, 0.0, P) == 0.0 and slip_rate(0.0, 0.0, 0.0, P) == 0.0
    assert math.isfinite(lateral_slip(0.0, 0.05, P))
    assert slip_rate(-1.0, 0.0, 1.2, P) == pytest.approx(0.0)        # locked wheel: kappa = -1
    assert slip_rate(0.1, 1.1 * 1.2, 1.2, P) == pytest.approx(0.0)   # 10 % drive slip
    assert tyre_forces(0.1, 0.1, -1.0, 0.8, P) == (0.0, 0.0)          # lifted wheel


def test_bad_tyre_parameters_refused():
    with pytest.raises(ValueError, match='peak_slip_x must be below sliding_slip_x'):
        TyreParams(peak_slip_x=1.2)
    with pytest.raises(ValueError, match='sliding_ratio_y must be in'):
        TyreParams(sliding_ratio_y=1.5)
    with pytest.raises(ValueError, match='slip_mu_exponent'):
        TyreParams(slip_mu_exponent=2.0)
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
    ({'kind': 'uniform', 'mu': 5e-324}, r'friction coefficient in \[0.01, 2.0\], got 5e-324'),
    ({'kind': 'split', 'mu_right': 2.5}, 'friction coefficient'),
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
