"""Parameter tables: descriptors with units and ranges, nested names."""
import pytest

from irs_common.params import Param, flatten, markdown_table, table_from_defaults, unflatten


def test_descriptor_carries_unit_range_and_read_only():
    d = Param('gain', 2.0, 'drive gain', 'm/s/V', 0.0, 10.0, read_only=True).descriptor()
    assert d.description == 'drive gain [m/s/V]' and d.read_only
    assert (d.floating_point_range[0].from_value, d.floating_point_range[0].to_value) == (0.0, 10.0)
    i = Param('window', 20, 'fit window', 'samples', 2, 100).descriptor()
    assert (i.integer_range[0].from_value, i.integer_range[0].to_value) == (2, 100)
    assert not Param('flag', True, 'a flag', '-', 0, 1).descriptor().integer_range


def test_table_from_defaults_requires_documentation_for_every_name():
    table = table_from_defaults({'a.b': 1.0, 'c': 'x'}, {'a.b': ('m', 0, 5, 'length'),
                                                        'c': ('-', None, None, 'name')},
                                read_only=('c',))
    assert [(p.name, p.default, p.low, p.read_only) for p in table] == \
        [('a.b', 1.0, 0.0, False), ('c', 'x', None, True)]
    with pytest.raises(ValueError, match='no unit/description'):
        table_from_defaults({'undocumented': 1.0}, {})
    assert '| `a.b` | `1.0` | m |' in markdown_table(table)


def test_flatten_and_unflatten_are_inverse():
    nested = {'a': {'b': 1, 'c': {'d': [1, 2]}}, 'e': 'x'}
    flat = flatten(nested)
    assert flat == {'a.b': 1, 'a.c.d': [1, 2], 'e': 'x'}
    assert unflatten(flat) == nested
    assert unflatten({'t': (1, 2)}) == {'t': [1, 2]}
