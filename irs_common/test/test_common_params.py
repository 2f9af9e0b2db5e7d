"""Parameter tables: descriptors with units and ranges, nested names, value checks (no node)."""
import math

from hypothesis import given, settings, strategies as st
import pytest

from irs_common.params import (Param, check_values, flatten, markdown_table, table_from_defaults,
                               unflatten)


def test_descriptor_carries_unit_range_and_read_only():
    d = Param('gain', 2.0, 'drive gain', 'm/s/V', 0.0, 10.0, read_only=True).descriptor()
    assert d.description == 'drive gain [m/s/V]' and d.read_only
    assert (d.floating_point_range[0].from_value, d.floating_point_range[0].to_value) == (0.0,
                                                                                          10.0)
    i = Param('window', 20, 'fit window', 'samples', 2, 100).descriptor()
    assert (i.integer_range[0].from_value, i.integer_range[0].to_value) == (2, 100)
    assert not Param('flag', True, 'a flag', '-', 0, 1).descriptor().integer_range


def test_parameters_are_read_only_unless_writable():
    assert Param('a', 1.0, 'a', 'm').read_only and not Param('a', 1.0, 'a', 'm').writable
    assert Param('a', 1.0, 'a', 'm').descriptor().read_only
    w = Param('a', 1.0, 'a', 'm', writable=True)
    assert w.writable and not w.read_only and not w.descriptor().read_only
    # the older keyword: read_only=True is the default, read_only=False means writable
    assert Param('a', 1.0, 'a', 'm', read_only=True).read_only
    assert Param('a', 1.0, 'a', 'm', read_only=False).writable
    with pytest.raises(ValueError, match='read_only=True and writable=True'):
        Param('a', 1.0, 'a', 'm', read_only=True, writable=True)


def test_table_from_defaults_requires_documentation_for_every_name():
    table = table_from_defaults({'a.b': 1.0, 'c': 'x', 'd': 2}, {'a.b': ('m', 0, 5, 'length'),
                                                                'c': ('-', None, None, 'name'),
                                                                'd': ('1', 0, 9, 'count')},
                                read_only=('c',), writable=('d',),
                                validators={'d': lambda v: None if v % 2 == 0 else 'odd'})
    assert [(p.name, p.default, p.low, p.read_only) for p in table] == \
        [('a.b', 1.0, 0.0, True), ('c', 'x', None, True), ('d', 2, 0, False)]
    assert table[2].validator(3) == 'odd'
    with pytest.raises(ValueError, match='no unit/description'):
        table_from_defaults({'undocumented': 1.0}, {})
    with pytest.raises(ValueError, match='both read-only and writable'):
        table_from_defaults({'a': 1.0}, {'a': ('m', 0, 5, 'x')}, read_only=('a',), writable=('a',))
    md = markdown_table(table)
    assert '| `a.b` | `1.0` | m | [0.0, 5.0] |  | length |' in md
    assert '| `d` | `2` | 1 | [0, 9] | yes | count |' in md


def test_flatten_and_unflatten_are_inverse():
    nested = {'a': {'b': 1, 'c': {'d': [1, 2]}}, 'e': 'x'}
    flat = flatten(nested)
    assert flat == {'a.b': 1, 'a.c.d': [1, 2], 'e': 'x'}
    assert unflatten(flat) == nested
    assert unflatten({'t': (1, 2)}) == {'t': [1, 2]}


def test_coerce_takes_integers_for_doubles_and_says_what_is_wrong():
    x = Param('x0', 0.5, 'x', 'm', -1.0, 1.0)
    assert x.coerce(0) == 0.0 and type(x.coerce(0)) is float
    arr = Param('arr', [0.5], 'a', '1')
    assert arr.coerce([1, 2]) == [1.0, 2.0] and all(type(v) is float for v in arr.coerce([1, 2]))
    cases = [
        (x, 'abc', "got 'abc' (string), expected a finite double in [-1.0, 1.0]"),
        (x, 2.0, 'got 2.0 (out of range), expected a finite double in [-1.0, 1.0]'),
        (x, math.nan, 'got nan (not a finite number)'),
        (x, True, 'got True (boolean)'),
        (arr, [], 'got an empty array, expected a non-empty array of finite doubles'),
        (arr, None, 'got an empty array'),
        (arr, [1.0, math.inf], 'got inf (not a finite number)'),
        (Param('n', 3, 'n', '1', 0, 10), 2.5, 'got 2.5 (double), expected an integer in [0, 10]'),
        (Param('s', 'a', 's', '-'), 1, 'got 1 (integer), expected a string'),
        (Param('f', False, 'f', '-'), 1, 'got 1 (integer), expected a boolean'),
    ]
    for p, value, message in cases:
        with pytest.raises(ValueError) as info:
            p.coerce(value)
        assert f"parameter '{p.name}': " in str(info.value) and message in str(info.value), \
            (value, str(info.value))
    assert Param('e', ['a'], 'e', '-', allow_empty=True).coerce([]) == []
    odd = Param('k', 2, 'k', '1', validator=lambda v: None if v % 2 == 0 else 'must be even')
    with pytest.raises(ValueError, match="parameter 'k': 3 refused: must be even"):
        odd.coerce(3)
    raising = Param('k', 2, 'k', '1', validator=lambda v: (_ for _ in ()).throw(ValueError('no')))
    with pytest.raises(ValueError, match='refused: no'):
        raising.coerce(2)


def test_check_values_names_unknown_parameters_with_suggestions():
    table = [Param('x0', 0.5, 'x', 'm', -1.0, 1.0), Param('y0', 0.0, 'y', 'm')]
    assert check_values(table, {'x0': 1, 'y0': 0.0}) == {}
    problems = check_values(table, {'x00': 1.0, 'y0': 'a'})
    assert "'x00' is not a parameter (did you mean x0" in problems['x00']
    assert "got 'a' (string)" in problems['y0']
    assert check_values(table, {'x00': 1.0}, unknown=False) == {}


def _oracle(low, high, value):
    """Independent statement of what a double parameter in [low, high] accepts."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    v = float(value)
    if math.isnan(v) or math.isinf(v):
        return None
    if v < low and not math.isclose(v, low, rel_tol=1e-6) or \
            v > high and not math.isclose(v, high, rel_tol=1e-6):
        return None
    return v


values = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                   st.integers(min_value=-10**6, max_value=10**6), st.booleans(),
                   st.text(max_size=3), st.none(), st.lists(st.floats(), max_size=2))


@settings(max_examples=300, deadline=None)
@given(value=values, low=st.floats(-100, 0), high=st.floats(0, 100))
def test_coerce_of_a_double_matches_the_oracle(value, low, high):
    p = Param('x', 0.0, 'x', 'm', low, high)
    expected = _oracle(low, high, value)
    if expected is None:
        with pytest.raises(ValueError, match="^parameter 'x': got .* expected a finite double"):
            p.coerce(value)
    else:
        assert p.coerce(value) == expected


@settings(max_examples=200, deadline=None)
@given(
    value=st.lists(
        st.one_of(st.floats(width=64), st.integers(-1000, 1000), st.text(max_size=2)), max_size=4
    )
)
def test_coerce_of_a_double_array_matches_the_oracle(value):
    p = Param('a', [1.0], 'a', '1')
    ok = bool(value) and all(_oracle(-math.inf, math.inf, v) is not None for v in value)
    if ok:
        assert p.coerce(value) == [float(v) for v in value]
    else:
        with pytest.raises(ValueError, match="^parameter 'a': got "):
            p.coerce(value)
