"""The sweep's linear metrics: the margins of a loop with a pure delay against python-control."""
import math

import control
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from irs_studies.sweep.metrics import OMEGA, delayed_loop_margins


def _loop(kp, ki, gain, pole, lag):
    """PI x gain/(s (s + pole)) x lag/(s + lag): the shape of a sweep point's steering loop."""
    return (control.tf([kp, ki], [1.0, 0.0]) * control.tf([gain], [1.0, pole, 0.0])
            * control.tf([lag], [1.0, lag]))


def _ours(G, delay):
    num, den = (np.asarray(c[0][0], float) for c in control.tfdata(G))
    return delayed_loop_margins(num, den, delay, OMEGA)


def _same(a, b, rel):
    """Each of (gm, pm, wgc) equal within ``rel``, or both inf, or both nan."""
    for x, y in zip(a, b):
        if math.isinf(y) or math.isnan(y):
            assert (math.isinf(x) and x == y) or (math.isnan(x) and math.isnan(y)), (a, b)
        else:
            assert x == pytest.approx(y, rel=rel), (a, b)


LOOPS = dict(kp=st.floats(0.1, 20.0), ki=st.floats(0.1, 20.0), gain=st.floats(0.5, 50.0),
             pole=st.floats(0.5, 30.0), lag=st.floats(5.0, 200.0))


@settings(max_examples=60, deadline=None)
@given(**LOOPS)
def test_without_delay_the_margins_are_python_controls(kp, ki, gain, pole, lag):
    """No delay: the margins of the transfer function by control.stability_margins (its
    polynomial method, exact).
    """
    G = _loop(kp, ki, gain, pole, lag)
    gm, pm, _sm, _wpc, wgc, _wms = control.stability_margins(G)
    _same(_ours(G, 0.0), (gm, pm, wgc), rel=1e-7)


@settings(max_examples=60, deadline=None)
@given(delay=st.floats(0.001, 0.05), **LOOPS)
def test_with_a_delay_the_margins_are_those_of_its_frequency_response(delay, kp, ki, gain, pole,
                                                                      lag):
    """With a delay: control.stability_margins of the loop's frequency response on the same
    frequencies (its spline interpolation), within that interpolation's error.
    """
    G = _loop(kp, ki, gain, pole, lag)
    resp = G(1j * OMEGA) * np.exp(-1j * OMEGA * delay)
    gm, pm, _sm, _wpc, wgc, _wms = control.stability_margins(control.frd(resp, OMEGA))
    _same(_ours(G, delay), (gm, pm, wgc), rel=1e-6)


def test_a_delay_costs_phase_w_tau_at_the_unchanged_crossover():
    """A delay leaves |L| and so the gain crossover unchanged, takes w_c tau of phase and
    lowers the gain margin.
    """
    G = _loop(5.0, 3.0, 10.0, 4.0, 60.0)
    gm0, pm0, wc0 = _ours(G, 0.0)
    gm1, pm1, wc1 = _ours(G, 0.02)
    assert 1.0 < gm1 < gm0                 # the delay brings the phase crossover down
    assert wc1 == pytest.approx(wc0, rel=1e-9)
    assert pm1 == pytest.approx(pm0 - math.degrees(wc0 * 0.02), abs=1e-6)


def test_a_loop_that_never_crosses_has_infinite_margins():
    """|L| < 1 and no phase crossing on the grid: gm and pm inf, no crossover (nan)."""
    gm, pm, wgc = _ours(control.tf([0.001], [1.0, 1.0]), 0.0)
    assert math.isinf(gm) and math.isinf(pm) and math.isnan(wgc)
