"""Reference signal generators."""
import math

import pytest

from hypothesis import given, settings, strategies as st
import numpy as np

from irs_control.reference import Chirp, Constant, Schedule, Sine, Square, Step, from_dict
from irs_control.reference_params import PARAMS, signal_from_params


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
    ({'type': 'schedule', 'times': [1.0, 2.0], 'values': [1.0]}, 'one value per time'),
    ({'type': 'schedule', 'times': [2.0, 1.0], 'values': [1.0, 2.0]}, 'strictly increasing'),
    ({'type': 'schedule', 'times': [], 'values': []}, 'must not be empty'),
    ({'type': 'schedule', 'times': [0.0], 'values': [math.inf]}, 'finite number'),
    ({'type': 'schedule', 'times': 1.0, 'values': [1.0]}, 'list of finite numbers'),
    ({'type': 'chirp', 'f0': 0.0}, 'must be positive Hz'),
    ({'type': 'chirp', 'f1': -1.0}, 'must be positive Hz'),
    ({'type': 'chirp', 'sweep_time': 0.0}, 'sweep_time must be positive'),
    ({'type': 'chirp', 'amplitude': math.nan}, 'finite number'),
])
def test_validation(spec, msg):
    with pytest.raises(ValueError, match=msg):
        from_dict(spec)


def test_schedule_piecewise_constant():
    s = from_dict({'type': 'schedule', 'times': [1.0, 3.0, 4.0], 'values': [2.0, -0.5, 0.0],
                   'offset': 0.25})
    assert isinstance(s, Schedule)
    assert [s(t) for t in (0.0, 0.999, 1.0, 2.9, 3.0, 3.5, 4.0, 100.0)] == \
        [0.25, 0.25, 2.0, 2.0, -0.5, -0.5, 0.0, 0.0]


def test_chirp_sweeps_logarithmically_and_holds_offset_outside():
    c = Chirp(amplitude=2.0, f0=0.5, f1=8.0, sweep_time=10.0, start_time=1.0, offset=0.3)
    assert c(0.5) == 0.3 and c(11.5) == 0.3
    assert c(1.0) == pytest.approx(0.3, abs=1e-12)       # a sine: starts at the offset
    assert c(1.001) > 0.3                                # ... going up
    # logarithmic: the frequency doubles every sweep_time / log2(f1/f0) = 2.5 s
    assert c.frequency(1.0) == pytest.approx(0.5)
    assert c.frequency(3.5) == pytest.approx(1.0)
    assert c.frequency(11.0) == pytest.approx(8.0)
    # zero crossings of the first second: the phase is 2 pi f0 T/ln(f1/f0) (...), counted
    t = np.arange(1.0, 11.0, 1e-4)
    v = np.array([c(x) for x in t]) - 0.3
    crossings = np.count_nonzero(np.diff(np.signbit(v)))
    cycles = 0.5 * 10.0 / math.log(16.0) * (16.0 - 1.0)      # f0 T/ln(f1/f0) (f1/f0 - 1)
    assert crossings == pytest.approx(2 * cycles, abs=2)
    assert np.max(np.abs(v)) == pytest.approx(2.0, rel=1e-3)


def test_chirp_with_equal_frequencies_is_a_sine():
    c = Chirp(amplitude=1.0, f0=2.0, f1=2.0, sweep_time=5.0)
    assert c(0.125) == pytest.approx(1.0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1e4, allow_nan=False), min_size=1, max_size=8, unique=True),
       st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=8, max_size=8),
       st.floats(-1e3, 1e3, allow_nan=False))
def test_schedule_value_at_each_time(times, values, offset):
    times = sorted(times)
    values = values[:len(times)]
    s = Schedule(times, values, offset)
    for t, v in zip(times, values):
        assert s(t) == v
    assert s(times[0] - 1e-3) == offset
    assert s(times[-1] + 1e6) == values[-1]


@settings(max_examples=60, deadline=None)
@given(st.floats(-1e3, 1e3), st.floats(1e-3, 1e3), st.floats(1e-3, 1e3),
       st.floats(1e-3, 1e4), st.floats(0.0, 1e3), st.floats(-1e3, 1e3),
       st.floats(-1e6, 1e6))
def test_chirp_is_finite_and_bounded(amplitude, f0, f1, sweep_time, start_time, offset, t):
    c = Chirp(amplitude, f0, f1, sweep_time, start_time, offset)
    v = c(t)
    assert math.isfinite(v)
    assert abs(v - offset) <= abs(amplitude) * (1 + 1e-9) + 1e-12


def _defaults(**over):
    p = {q.name: q.default for q in PARAMS}
    p.update(over)
    return p


def test_signal_from_params_schedule_and_chirp():
    s = signal_from_params(_defaults(**{'signal.type': 'schedule', 'signal.times': [1.0, 2.0],
                                        'signal.values': [0.1, 0.2]}))
    assert (s(0.5), s(1.5), s(2.5)) == (0.0, 0.1, 0.2)
    c = signal_from_params(_defaults(**{'signal.type': 'chirp', 'signal.f0': 1.0,
                                        'signal.f1': 4.0, 'signal.sweep_time': 2.0,
                                        'signal.start_time': 0.0, 'signal.amplitude': 0.05}))
    assert isinstance(c, Chirp) and c.f1 == 4.0 and c(0.25) == pytest.approx(
        0.05 * math.sin(2 * math.pi * 1.0 * 2.0 / math.log(4.0) * (4.0 ** (0.25 / 2.0) - 1)))
    with pytest.raises(ValueError, match='one value per time'):
        signal_from_params(_defaults(**{'signal.type': 'schedule', 'signal.times': [1.0, 2.0]}))


def test_the_generator_keeps_its_reference_on_the_belt():
    """+-0.6096 m (the belt's half width) for every value and for the signal as a whole."""
    from irs_control.reference_params import PARAMS, REFERENCE_LIMIT, reference_problem
    from irs_models.constants import BELT_HALF_WIDTH
    assert REFERENCE_LIMIT == BELT_HALF_WIDTH
    amp = next(p for p in PARAMS if p.name == 'signal.amplitude')
    assert (amp.low, amp.high) == (-BELT_HALF_WIDTH, BELT_HALF_WIDTH)
    assert reference_problem({'signal.type': 'sine', 'signal.amplitude': 0.5,
                              'signal.offset': 0.1}) is None
    assert "beyond the belt's edges at +-0.6096 m" in reference_problem(
        {'signal.type': 'sine', 'signal.amplitude': 0.4, 'signal.offset': 0.4})
