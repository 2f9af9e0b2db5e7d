"""Reference signal generators."""
import math

import pytest

from irs_control.reference import Constant, Sine, Square, Step, from_dict


def test_step():
    s = Step(amplitude=0.2, start_time=1.0, offset=0.05)
    assert s(0.999) == pytest.approx(0.05)
    assert s(1.0) == pytest.approx(0.25)


def test_square():
    q = Square(amplitude=0.1, period=4.0, offset=0.0, start_time=1.0)
    assert q(0.5) == 0.0
    assert q(1.5) == pytest.approx(0.1)
    assert q(3.5) == pytest.approx(-0.1)
    assert q(5.5) == pytest.approx(0.1)


def test_sine_and_constant():
    s = Sine(amplitude=0.1, period=2.0)
    assert s(0.5) == pytest.approx(0.1)
    assert s(1.0) == pytest.approx(0.0, abs=1e-12)
    assert Constant(0.3)(123.0) == 0.3


def test_from_dict():
    q = from_dict({'type': 'square', 'amplitude': 0.1, 'period': 8.0})
    assert isinstance(q, Square) and q.period == 8.0
    assert from_dict({'type': 'constant', 'value': 0.2})(0) == 0.2


@pytest.mark.parametrize('spec,msg', [
    ({'amplitude': 1}, "'type' key"),
    ({'type': 'ramp'}, 'Unknown reference type'),
    ({'type': 'step', 'amplitud': 1}, 'Unknown parameter'),
    ({'type': 'square', 'period': 0.0}, 'period must be positive'),
    ({'type': 'sine', 'amplitude': math.nan}, 'finite number'),
    ({'type': 'square', 'duty': 1.5}, 'duty'),
])
def test_validation(spec, msg):
    with pytest.raises(ValueError, match=msg):
        from_dict(spec)
