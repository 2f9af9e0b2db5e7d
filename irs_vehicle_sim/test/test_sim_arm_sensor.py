"""Arm potentiometer model: exact angles, noise statistics, ADC quantisation, seeding."""

import math

import numpy as np
import pytest

from irs_models.arm_kinematics import ArmGeometry, ArmReachError, forward_kinematics
from irs_vehicle_sim.arm_sensor import (ENCODER_STEP, POT_RESOLUTION_RATIO, POT_STEP, ArmSensor,
                                        ArmSensorParams)
from irs_vehicle_sim.rig import RigConfig

POSE = (0.31, -0.12, 0.07)


def test_noise_free_unquantised_is_exact_ik():
    s = ArmSensor(params=ArmSensorParams(enable_noise=False, enable_quantization=False))
    th = s.measure(*POSE)
    pose = forward_kinematics(*th, ArmGeometry())
    assert (pose.x_cg, pose.y_cg, pose.psi) == pytest.approx(POSE, abs=1e-12)


def test_noise_statistics():
    sigma = 1e-3
    s = ArmSensor(params=ArmSensorParams(noise_std=sigma, enable_quantization=False, seed=3))
    true = np.array(s.true_angles(*POSE))
    n = 20000
    err = np.array([s.measure(*POSE) for _ in range(n)]) - true
    assert np.all(np.abs(err.mean(axis=0)) < 4 * sigma / math.sqrt(n))
    np.testing.assert_allclose(err.std(axis=0), sigma, rtol=0.03)
    # joints independent
    c = np.corrcoef(err.T)
    assert np.all(np.abs(c[np.triu_indices(3, 1)]) < 0.03)


def test_quantisation_step_and_error_bound():
    p = ArmSensorParams(enable_noise=False, adc_bits=12, adc_range=2 * math.pi, lsb=0.0)
    assert p.step_size == pytest.approx(2 * math.pi / 4096)
    s = ArmSensor(params=p)
    rng = np.random.default_rng(1)
    for _ in range(200):
        pose = (rng.uniform(-1, 1), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5))
        th = s.measure(*pose)
        true = np.array(s.true_angles(*pose))
        k = th / p.step_size
        np.testing.assert_allclose(k, np.round(k), atol=1e-9)
        assert np.all(np.abs(th - true) <= p.step_size / 2 + 1e-15)
    # explicit lsb overrides bits/range
    p2 = ArmSensorParams(enable_noise=False, lsb=0.01)
    th = ArmSensor(params=p2).measure(*POSE)
    np.testing.assert_allclose(th / 0.01, np.round(th / 0.01), atol=1e-9)


def test_seeded_and_reset_reproducible():
    a = ArmSensor(params=ArmSensorParams(seed=7))
    b = ArmSensor(params=ArmSensorParams(seed=7))
    c = ArmSensor(params=ArmSensorParams(seed=8, enable_quantization=False))
    ra = [a.measure(*POSE) for _ in range(10)]
    rb = [b.measure(*POSE) for _ in range(10)]
    np.testing.assert_array_equal(ra, rb)
    a.reset()
    np.testing.assert_array_equal([a.measure(*POSE) for _ in range(10)], ra)
    assert not np.array_equal([c.measure(*POSE) for _ in range(10)],
                              [ArmSensor(params=ArmSensorParams(seed=7, enable_quantization=False))
                               .measure(*POSE) for _ in range(10)])


def test_unreachable_pose_and_bad_params():
    with pytest.raises(ArmReachError):
        ArmSensor().measure(0.0, -2.0, 0.0)
    with pytest.raises(ValueError, match='noise_std'):
        ArmSensor(params=ArmSensorParams(noise_std=-1.0))
    with pytest.raises(ValueError, match='adc_bits'):
        ArmSensor(params=ArmSensorParams(adc_bits=0))


def test_pots_resolve_ten_times_finer_than_the_encoders_paper_sec_3_2():
    """Default step = encoder step / 10 (paper Sec. 3.2); the noise is no larger than the step."""
    p = ArmSensorParams()
    assert POT_RESOLUTION_RATIO == 10
    assert p.step_size * POT_RESOLUTION_RATIO == pytest.approx(ENCODER_STEP, rel=1e-12)
    assert p.step_size == POT_STEP < ENCODER_STEP
    assert 0.0 < p.noise_std <= p.step_size
    # the rig defaults (rig.yaml values, as RigConfig reads them) agree with the sensor's
    import yaml
    from ament_index_python.packages import get_package_share_directory
    path = f"{get_package_share_directory('irs_vehicle_sim')}/config/rig.yaml"
    with open(path) as f:
        arm = yaml.safe_load(f)['vehicle_sim']['ros__parameters']['arm']
    cfg = RigConfig.from_dict({f'arm.{k}': arm[k] for k in ('noise_std', 'lsb')})
    assert cfg.arm_sensor.step_size == pytest.approx(POT_STEP, rel=1e-12)
    assert cfg.arm_sensor.noise_std == pytest.approx(p.noise_std, rel=1e-12)
    # readings are multiples of the pot step, and the quantisation error is within half a step
    s = ArmSensor(params=ArmSensorParams(enable_noise=False))
    th = s.measure(*POSE)
    np.testing.assert_allclose(th / POT_STEP, np.round(th / POT_STEP), atol=1e-6)
    assert np.all(np.abs(th - np.array(s.true_angles(*POSE))) <= POT_STEP / 2 + 1e-15)


def _reference_measure(sensor, rng, x, y, psi):
    """The plain numpy reference: three normal(0, sigma) draws per call, np.round."""
    th = np.array(sensor.true_angles(x, y, psi), dtype=float)
    p = sensor.params
    if p.enable_noise and p.noise_std > 0.0:
        th = th + rng.normal(0.0, p.noise_std, size=3)
    if p.enable_quantization:
        q = p.step_size
        th = q * np.round(th / q)
    return th


@pytest.mark.parametrize('params', [ArmSensorParams(), ArmSensorParams(seed=5, lsb=0.0),
                                    ArmSensorParams(enable_noise=False),
                                    ArmSensorParams(enable_quantization=False, seed=2),
                                    ArmSensorParams(noise_std=0.02, lsb=0.01, seed=9)])
def test_readings_equal_the_numpy_reference_to_the_bit(params):
    """Block-drawn noise and scalar rounding give the very bits of the per-call numpy version,
    across a noise block boundary and a reset, including the sign of a zero reading.
    """
    s = ArmSensor(params=params)
    ref_rng = np.random.default_rng(params.seed)
    poses = np.random.default_rng(11).uniform([-0.8, -0.5, -0.6], [0.8, 0.5, 0.6], (2500, 3))
    for i, pose in enumerate(poses):
        if i == 1800:
            s.reset()
            ref_rng = np.random.default_rng(params.seed)
        ours = s.measure(*pose)
        ref = _reference_measure(s, ref_rng, *pose)
        assert ours.view(np.int64).tolist() == ref.view(np.int64).tolist(), i
    assert 2500 * 3 > ArmSensor.NOISE_BLOCK    # the run crossed a block boundary


def test_a_reading_rounded_to_zero_keeps_its_sign():
    from irs_vehicle_sim.arm_sensor import _on_grid
    assert math.copysign(1.0, _on_grid(-0.3e-4, 1e-3)) == -1.0
    assert math.copysign(1.0, _on_grid(0.3e-4, 1e-3)) == 1.0
    assert _on_grid(2.5e-3, 1e-3) == 1e-3 * np.round(2.5)   # half to even, as numpy
