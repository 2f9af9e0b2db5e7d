"""The rig's identified-plant section: zeros and poles as quadratics, complex pairs allowed."""
import numpy as np
import pytest

from irs_models.identified import IdentifiedParams, identified_matrices
from irs_vehicle_sim.rig import RigConfig


def test_default_quadratics_are_eq6_exactly():
    cfg = RigConfig.from_dict({'identified': {'numerator': [7.2, 11.52],
                                              'denominator': [28.0, 160.0]}})
    assert cfg.identified.zeros == IdentifiedParams().zeros
    assert cfg.identified.poles == IdentifiedParams().poles


def test_complex_quadratics_reach_the_stepped_model():
    cfg = RigConfig.from_dict({'identified': {'gain': 8.0, 'numerator': [37.6, 427.2],
                                              'denominator': [25.7, 714.0]}})
    z, p = np.array(cfg.identified.zeros), np.array(cfg.identified.poles)
    assert np.all(z.imag != 0) and np.all(p.imag != 0)
    np.testing.assert_allclose(np.real(np.poly(z)), [1, 37.6, 427.2], rtol=1e-12)
    A, *_ = identified_matrices(cfg.identified)
    # the z-dynamics rows carry the denominator s^2 + 25.7 s + 714
    np.testing.assert_allclose(A[3, 2:], [-714.0, -25.7], rtol=1e-12)


@pytest.mark.parametrize('section,match', [
    ({'numerator': [1.0]}, 'two coefficients'),
    ({'numerator': ['a', 2.0]}, 'two coefficients'),
    ({'denominator': [-1.0, 5.0]}, 'left half plane'),
])
def test_bad_quadratics_are_refused(section, match):
    with pytest.raises(ValueError, match=match):
        RigConfig.from_dict({'identified': section})


def test_bicycle_heading_for_eq6_is_refused_at_configuration():
    with pytest.raises(ValueError, match='not the transfer function of any bicycle'):
        RigConfig.from_dict({'identified': {'heading': 'bicycle'}})
    with pytest.raises(ValueError, match='heading'):
        RigConfig.from_dict({'identified': {'heading': 'yaw'}})


def test_bicycle_heading_on_the_rig_for_a_bicycle_transfer_function():
    from irs_models import presets
    from irs_models.bicycle import tf_coefficients
    num, den = tf_coefficients(presets.get_preset('irs_2wd').params, 1.2, 0.33)
    cfg = RigConfig.from_dict({'identified': {
        'gain': float(num[0] / den[0]), 'numerator': [float(c) for c in num[1:] / num[0]],
        'denominator': [float(c) for c in den[1:3] / den[0]], 'heading': 'bicycle'}})
    assert cfg.identified.heading == 'bicycle'
