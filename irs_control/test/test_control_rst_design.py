"""Diophantine solver and RST design on textbook cases with hand-derived answers."""
import numpy as np
import pytest

from irs_control.polynomials import (DiophantineError, common_roots, poly_from_roots,
                                     solve_diophantine)
from irs_control.rst_design import RstDesignError, design_rst, select_cancelled_zeros


def test_diophantine_double_integrator():
    # s^2 (s + x0) + (y1 s + y0) = (s + 1)^3 = s^3 + 3 s^2 + 3 s + 1
    # => x0 = 3, y1 = 3, y0 = 1
    X, Y = solve_diophantine([1, 0, 0], [1], poly_from_roots([-1, -1, -1]))
    np.testing.assert_allclose(X, [1, 3], atol=1e-12)
    np.testing.assert_allclose(Y, [3, 1], atol=1e-12)


def test_diophantine_nonconstant_b():
    # A = s (s + 1), B = s + 2, C = (s + 3)^3 = s^3 + 9 s^2 + 27 s + 27.
    # X = s + x0, Y = y1 s + y0:  s^3 + (1 + x0) s^2 + x0 s + (y1 s^2 + (2 y1 + y0) s + 2 y0)
    # s^2: 1 + x0 + y1 = 9;  s: x0 + 2 y1 + y0 = 27;  1: 2 y0 = 27 -> y0 = 13.5
    # => x0 + y1 = 8, x0 + 2 y1 = 13.5 -> y1 = 5.5, x0 = 2.5
    X, Y = solve_diophantine(np.polymul([1, 0], [1, 1]), [1, 2], poly_from_roots([-3] * 3))
    np.testing.assert_allclose(X, [1, 2.5], atol=1e-12)
    np.testing.assert_allclose(Y, [5.5, 13.5], atol=1e-12)


def test_diophantine_common_root_fails():
    with pytest.raises(DiophantineError, match='no solution'):
        solve_diophantine(np.polymul([1, 0], [1, 1]), [1, 1], poly_from_roots([-3] * 3))


def test_first_order_mrc_astrom_wittenmark():
    # Plant b/(s + a), model bm/(s + am), Ao = 1, no zeros:
    # (s + a) * 1 + b S = s + am -> S = (am - a)/b ; R = 1 ; T = bm / b.
    a, b, am, bm = 1.0, 0.5, 2.0, 2.0
    d = design_rst([b], [1, a], [bm], [1, am], [1.0])
    np.testing.assert_allclose(d.R, [1.0])
    np.testing.assert_allclose(d.S, [(am - a) / b])
    np.testing.assert_allclose(d.T, [bm / b])


def test_double_integrator_design():
    # A = s^2, B = 1, Am = s^2 + 2 z w s + w^2, Bm = w^2, Ao = s + ao.
    # s^2 (s + r1) + s1 s + s0 = (s^2 + 2 z w s + w^2)(s + ao):
    # r1 = 2 z w + ao, s1 = w^2 + 2 z w ao, s0 = w^2 ao, T = w^2 (s + ao).
    z, w, ao = 0.7, 2.0, 4.0
    d = design_rst([1.0], [1, 0, 0], [w ** 2], [1, 2 * z * w, w ** 2], [1, ao])
    np.testing.assert_allclose(d.R, [1, 2 * z * w + ao], atol=1e-12)
    np.testing.assert_allclose(d.S, [w ** 2 + 2 * z * w * ao, w ** 2 * ao], atol=1e-12)
    np.testing.assert_allclose(d.T, [w ** 2, w ** 2 * ao], atol=1e-12)
    assert d.closed_loop_freq_error() < 1e-12


def test_zero_cancellation_puts_b_plus_in_r():
    # Plant 2 (s + 3) / (s (s + 1)): cancel the zero -> R = R' (s + 3), B- = 2.
    d = design_rst([2, 6], [1, 1, 0], [2.0], [1, 3, 2], [1.0])
    np.testing.assert_allclose(d.B_plus, [1, 3])
    np.testing.assert_allclose(d.B_minus, [2])
    assert np.any(np.isclose(np.roots(d.R), -3.0))
    assert d.closed_loop_freq_error() < 1e-12


def test_coprimeness_error_names_root():
    # A = s (s + 1), B = s + 1 kept (cancel='none'): common root -1.
    with pytest.raises(RstDesignError, match=r'not coprime.*-1'):
        design_rst([1, 1], [1, 1, 0], [1, 1], [1, 2, 1], [1, 5], cancel='none')


def test_causality_error_deg_s():
    # A = s^2, B = 1, Am = (s + 1)^2, Ao = 1 -> R = 1 (deg 0), S = 2 s + 1 (deg 1) > deg R.
    with pytest.raises(RstDesignError, match=r'Non-causal.*deg S = 1 > deg R = 0'):
        design_rst([1.0], [1, 0, 0], [1.0], [1, 2, 1], [1.0])


def test_causality_error_deg_t():
    # Bm = s + 1 over Am = (s + 1)^2: pole excess 1 < 2 = pole excess of 1/s^2.
    with pytest.raises(RstDesignError, match=r'Non-causal.*deg T = 2 > deg R = 1'):
        design_rst([1.0], [1, 0, 0], [1, 1], [1, 2, 1], [1, 2])


def test_bminus_not_in_bm_raises_and_absorb_option():
    B, A = [1, 2], [1, 1, 0]
    with pytest.raises(RstDesignError, match='not zeros of the reference model'):
        design_rst(B, A, [2.0], [1, 3, 2], [1, 4], cancel='none')
    d = design_rst(B, A, [2.0], [1, 3, 2], [1, 4], cancel='none', absorb_zeros=True)
    np.testing.assert_allclose(d.Bm, [1, 2])  # 2 * (s + 2)/2
    assert d.closed_loop_freq_error() < 1e-12


def test_unstable_observer_and_nonmonic_rejected():
    with pytest.raises(RstDesignError, match='open left half plane'):
        design_rst([1.0], [1, 0, 0], [1.0], [1, 2, 1], [1, -1])
    with pytest.raises(RstDesignError, match='monic'):
        design_rst([1.0], [2, 0, 0], [1.0], [1, 2, 1], [1, 1])


def test_select_cancelled_zeros_thresholds():
    zeros = [-2.0, 1.0, complex(-0.1, 3.0), complex(-0.1, -3.0)]
    canc, kept = select_cancelled_zeros(zeros, 'stable', zeta_min=0.5)
    np.testing.assert_allclose(canc, [-2.0])
    assert len(kept) == 3
    canc, kept = select_cancelled_zeros(zeros, 'none')
    assert canc.size == 0 and kept.size == 4
    with pytest.raises(RstDesignError, match='not in the open left half plane'):
        select_cancelled_zeros(zeros, [1.0])
    with pytest.raises(RstDesignError, match='not a zero'):
        select_cancelled_zeros(zeros, [-5.0])


def test_common_roots():
    assert common_roots([1, 3, 2], [1, 1]) == [complex(-1.0)]
    assert common_roots([1, 3, 2], [1, 5]) == []
