"""StampSync: exact-time pairing of lock-step inputs."""
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.sampled_from('abc'), st.integers(0, 6)), max_size=60))
def test_releases_what_a_full_scan_of_the_waiting_sets_would(arrivals):
    """Against the plain model: after each arrival, every complete set, in stamp order."""
    sync = StampSync(('a', 'b', 'c'))
    model = {}
    for name, stamp in arrivals:
        model.setdefault(stamp, {})[name] = (name, stamp)
        expected = [(s, model.pop(s)) for s in sorted(model) if len(model[s]) == 3]
        assert sync.add(name, stamp, (name, stamp)) == expected


def test_expire_takes_out_the_sets_that_waited_since_the_last_call_and_names_what_was_missing():
    sync = StampSync(('pose', 'velocity', 'belt'))
    sync.add('pose', 1, 'p1')                       # alone
    sync.add('pose', 2, 'p2')
    sync.add('belt', 2, 'b2')                       # velocity lost
    assert sync.expire() == []                      # first call: they have not waited yet
    sync.add('velocity', 5, 'v5')                   # arrived after that call: still waits
    assert sync.expire() == [(1, ('velocity', 'belt')), (2, ('velocity',))]
    assert sync.expired == 2
    assert sync.add('pose', 5, 'p5') == [] and sync.add('belt', 5, 'b5') == [
        (5, {'velocity': 'v5', 'pose': 'p5', 'belt': 'b5'})]
    assert sync.expire() == []
