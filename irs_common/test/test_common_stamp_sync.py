"""StampSync: exact-time pairing of lock-step inputs."""
import pytest

from irs_common.stamp_sync import StampSync


def test_releases_a_set_only_when_every_input_of_the_stamp_is_there():
    sync = StampSync(('y', 'ref'))
    assert sync.add('y', 2, 'y2') == []
    assert sync.add('ref', 1, 'r1') == []
    assert sync.add('ref', 2, 'r2') == [(2, {'y': 'y2', 'ref': 'r2'})]
    assert sync.add('y', 1, 'y1') == [(1, {'y': 'y1', 'ref': 'r1'})]


def test_releases_in_stamp_order_and_a_later_value_replaces_an_earlier_one():
    sync = StampSync(('a', 'b'))
    sync.add('a', 5, 'old')
    sync.add('a', 5, 'new')
    sync.add('a', 3, 'a3')
    sync.add('b', 3, 'b3')
    assert sync.add('b', 5, 'b5') == [(5, {'a': 'new', 'b': 'b5'})]


def test_bounded_and_validated():
    sync = StampSync(('a', 'b'), max_pending=2)
    for stamp in range(4):
        sync.add('a', stamp, stamp)
    assert sync.dropped == 2
    with pytest.raises(KeyError):
        sync.add('c', 0, 0)
    with pytest.raises(ValueError):
        StampSync(())
