"""The identified plant's state update in plain floats, against numpy's product to the bit.

:class:`irs_models.identified.IdentifiedPlant` steps its four states without numpy, each row
summed as ``((a0 x0 + a2 x2) + (a1 x1 + a3 x3)) + b delta``: the order in which numpy's
OpenBLAS kernels ``Haswell`` and ``SkylakeX`` sum a 4 x 4 matrix-vector product. The lock-step
digests (``data/figure10_digests.json``, one set per kernel) are those of ``Ad @ x + b delta``,
so under each kernel the file holds every step must be numpy's product, bit for bit; under
another kernel the test is skipped with its name (docs/testing.md, "The same bits on every
machine").
"""
import json
from pathlib import Path

from hypothesis import given, settings, strategies as st
import pytest

from irs_models.identified import IdentifiedParams, IdentifiedPlant
from irs_system_tests.blas import openblas_core

DIGESTS = Path(__file__).parent / 'data' / 'figure10_digests.json'
KERNELS = sorted(json.loads(DIGESTS.read_text())['kernels'])


@pytest.fixture(scope='module', autouse=True)
def _a_kernel_the_digests_hold():
    core = openblas_core()
    if core not in KERNELS:
        pytest.skip(f'OpenBLAS kernel {core!r}: the digests hold {KERNELS}')


@settings(max_examples=60, deadline=None)
@given(y0=st.floats(-0.5, 0.5),
       steer=st.lists(st.floats(-0.6, 0.6), min_size=1, max_size=200),
       dt=st.sampled_from([0.001, 0.002, 0.0005]),
       speed=st.sampled_from([1.2, 0.8, 2.0]))
def test_each_step_is_numpys_product_to_the_bit(y0, steer, dt, speed):
    plant = IdentifiedPlant(IdentifiedParams(speed=speed))
    plant.reset(y0)
    ad, bd = plant.discrete(dt)
    for k, delta in enumerate(steer):
        expected = ad @ plant.x + bd[:, 0] * delta
        plant.step(delta, 0.0, dt)
        assert plant.x.tobytes() == expected.tobytes(), (k, plant.x, expected)
    # the outputs read the same state
    assert plant.y_s == float(expected[0])
    assert plant.psi == float(expected[1]) / speed


@settings(max_examples=60, deadline=None)
@given(y0=st.floats(-0.5, 0.5),
       steer=st.lists(st.floats(-0.6, 0.6), min_size=1, max_size=200),
       speed=st.sampled_from([1.2, 0.8, 2.0]))
def test_the_kinematic_yaw_rate_is_numpys_dot_to_the_bit(y0, steer, speed):
    """``a_s = Ca x + Da delta`` in floats, in the form this kernel's dot takes (plain, or with
    the second product fused), equals numpy's, and the plant found the form (no numpy call).
    """
    plant = IdentifiedPlant(IdentifiedParams(speed=speed))
    assert plant._ca_form is not None, openblas_core()
    plant.reset(y0)
    for k, delta in enumerate(steer):
        plant.step(delta)
        expected = float(plant.Ca[0] @ plant.x + plant.Da[0, 0] * delta) / speed
        assert plant.yaw_rate == expected, (k, plant.yaw_rate, expected)
