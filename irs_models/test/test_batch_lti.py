"""BatchLti: many linear systems stepped at once equal scipy.signal.dlsim one by one."""
import numpy as np
import pytest
from scipy.signal import dlsim

from irs_models.batch_lti import BatchLti
from irs_models.identified import IdentifiedParams, identified_matrices


def systems(n):
    return [identified_matrices(IdentifiedParams(gain=g))[:4] for g in np.linspace(5, 20, n)]


def test_equals_dlsim_per_system():
    b = BatchLti.from_continuous(systems(5), 1e-3)
    rng = np.random.default_rng(1)
    u = rng.normal(0, 0.05, (5, 400, 1))
    x0 = rng.normal(0, 0.01, (5, 4))
    y, x = b.simulate(u, x0)
    for i in range(5):
        _, yd, xd = dlsim((b.Ad[i], b.Bd[i], b.C[i], b.D[i], 1e-3), u[i], x0=x0[i])
        np.testing.assert_allclose(y[i], yd, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(x[i], xd, rtol=1e-12, atol=1e-15)


def test_shared_input_and_shape_errors():
    b = BatchLti.from_continuous(systems(3), 1e-3)
    y, _ = b.simulate(np.ones(50))
    assert y.shape == (3, 50, 1)
    assert not np.allclose(y[0], y[2])      # different gains, different outputs
    with pytest.raises(ValueError, match='shape'):
        b.simulate(np.ones((2, 50, 1)))
    with pytest.raises(ValueError, match='dt'):
        BatchLti(b.Ad, b.Bd, b.C, b.D, 0.0)
