"""irs_common.msg_builder against rosidl's own constructor, on random fields of every message type
the project publishes (the types and value strategies of ``test_cdr.py``).
"""
import array

from hypothesis import given, settings, strategies as st
import numpy
import pytest

from irs_common import msg_builder
from irs_common.cdr import message_fields
from irs_common.msg_builder import builder
from test_cdr import ALL_TYPES, _canon, _class, _strategy


def _same(ours, theirs, path='msg'):
    """Equal slot by slot, the same Python type in every slot, floats bit for bit."""
    assert type(ours) is type(theirs), f'{path}: {type(ours).__name__} != {type(theirs).__name__}'
    if hasattr(theirs, 'get_fields_and_field_types'):
        assert ours._check_fields == theirs._check_fields, path
        for slot, _ in message_fields(type(theirs)):
            _same(getattr(ours, slot), getattr(theirs, slot), f'{path}.{slot[1:]}')
        return
    if isinstance(theirs, array.array):
        assert ours.typecode == theirs.typecode, path
    if isinstance(theirs, numpy.ndarray):
        assert ours.dtype == theirs.dtype, path
    assert _canon(ours) == _canon(theirs), path


def _some_fields(cls):
    """A random subset of ``cls``'s fields with random values."""
    fields = [(slot[1:], t) for slot, t in message_fields(cls)]
    return st.tuples(*[st.one_of(st.none(), _strategy(t)) for _, t in fields]).map(
        lambda values: {name: v for (name, _), v in zip(fields, values) if v is not None})


@pytest.mark.parametrize('type_name', ALL_TYPES)
def test_a_built_message_equals_rosidls(type_name):
    cls = _class(type_name)
    new = builder(cls)
    assert new is not cls

    @settings(max_examples=60, deadline=None)
    @given(_some_fields(cls))
    def check(fields):
        _same(new(**fields), cls(**fields))
    check()


@pytest.mark.parametrize('type_name', ALL_TYPES)
def test_defaults_are_never_shared_between_messages(type_name):
    """Two messages built without fields share no mutable object (a nested message, an array)."""
    cls = _class(type_name)
    new = builder(cls)

    def mutables(msg):
        for slot, _ in message_fields(type(msg)):
            value = getattr(msg, slot)
            if hasattr(value, 'get_fields_and_field_types'):
                yield value
                yield from mutables(value)
            elif isinstance(value, (list, array.array, numpy.ndarray)):
                yield value
    a, b = list(mutables(new())), list(mutables(new()))
    assert len(a) == len(b)
    assert all(x is not y for x, y in zip(a, b))


def test_a_given_sequence_is_converted_as_rosidl_does():
    from sensor_msgs.msg import JointState
    js = builder(JointState)(position=[1.0, 2.0])
    assert isinstance(js.position, array.array) and js.position.tolist() == [1.0, 2.0]
    from nav_msgs.msg import Odometry
    covariance = [float(i) for i in range(36)]
    odom = builder(Odometry)()
    assert isinstance(odom.pose.covariance, numpy.ndarray)
    from geometry_msgs.msg import PoseWithCovariance
    pose = builder(PoseWithCovariance)(covariance=covariance)
    assert pose.covariance.dtype == numpy.float64 and pose.covariance.tolist() == covariance


def test_an_unknown_field_is_a_type_error():
    from std_msgs.msg import Header
    with pytest.raises(TypeError, match='stampp'):
        builder(Header)(stampp=None)


def test_with_rosidls_field_checks_on_the_builder_is_the_class(monkeypatch):
    """ROS_PYTHON_CHECK_FIELDS=1 (read by each message module at import): every check runs."""
    import std_msgs.msg._float64 as module
    from std_msgs.msg import Float64
    monkeypatch.setattr(msg_builder, '_cache', {})
    monkeypatch.setattr(module, 'ros_python_check_fields', '1')
    new = builder(Float64)
    assert new is Float64
    with pytest.raises(AssertionError):
        new(data='not a number')
