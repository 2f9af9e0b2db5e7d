"""``irs_common.scalar.clip`` against ``np.clip``, to the bit."""
import itertools
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from irs_common.scalar import clip

SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 2.0, math.inf, -math.inf, math.nan, 5e-324]


def _bits(v: float) -> tuple:
    return ('nan',) if math.isnan(v) else (v, math.copysign(1.0, v))


def test_special_values_give_numpys_bits():
    for x, lo, hi in itertools.product(SPECIAL, repeat=3):
        assert _bits(clip(x, lo, hi)) == _bits(float(np.clip(x, lo, hi))), (x, lo, hi)


@settings(max_examples=500, deadline=None)
@given(st.floats(), st.floats(), st.floats())
def test_any_floats_give_numpys_bits(x, lo, hi):
    expected = float(np.clip(x, lo, hi))
    got = clip(x, lo, hi)
    assert _bits(got) == _bits(expected)
