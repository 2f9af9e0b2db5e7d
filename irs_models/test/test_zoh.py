"""irs_models.zoh: the exact ZOH equals scipy.signal.cont2discrete to the bit."""
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays
import numpy as np
import pytest
from scipy.signal import cont2discrete

from irs_models.zoh import zoh

ELEMENT = st.floats(min_value=-50.0, max_value=50.0, allow_nan=False, allow_infinity=False)


@st.composite
def systems(draw):
    n = draw(st.integers(1, 6))
    m = draw(st.integers(1, 3))
    a = draw(arrays(np.float64, (n, n), elements=ELEMENT))
    b = draw(arrays(np.float64, (n, m), elements=ELEMENT))
    dt = draw(st.sampled_from([1e-4, 1e-3, 5e-3, 0.01, 0.1]))
    return a, b, dt


@settings(max_examples=200, deadline=None)
@given(systems())
def test_zoh_equals_cont2discrete_to_the_bit(system):
    a, b, dt = system
    ad, bd = zoh(a, b, dt)
    ad_ref, bd_ref, *_ = cont2discrete((a, b, np.eye(a.shape[0]), np.zeros_like(b)), dt,
                                       method='zoh')
    assert ad.tobytes() == np.ascontiguousarray(ad_ref).tobytes()
    assert bd.tobytes() == np.ascontiguousarray(bd_ref).tobytes()


def test_zoh_of_a_double_integrator():
    ad, bd = zoh([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], 0.1)
    np.testing.assert_allclose(ad, [[1.0, 0.1], [0.0, 1.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(bd, [[0.005], [0.1]], rtol=0, atol=1e-15)


def test_zoh_refuses_mismatched_shapes():
    with pytest.raises(ValueError, match='A n x n and B n x m'):
        zoh(np.eye(3), np.ones((2, 1)), 0.001)
