"""irs_common.cdr against rclpy and an independent decoder, on random messages of every type the
project publishes.

For each type, hypothesis draws messages (NaN, inf, empty and long sequences, unicode strings);
the generated serialiser's bytes must decode, with rclpy and with mcap_ros2's own CDR reader, to
the very values that went in (floats compared bit for bit), and be at most as long as rclpy's.
"""
import importlib
import math
import struct

from hypothesis import given, settings, strategies as st
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from irs_common.cdr import CDR_LE_HEADER, cdr_serializer, class_of, message_fields

IRS_TYPES = ['BeltSpeed', 'DriverCommand', 'LateralControllerStatus', 'LateralReference',
             'RigStatus', 'SensingStatus', 'SteeringActuatorState', 'SteeringCommand',
             'TreadmillDriveCommand', 'TreadmillState', 'TyreState', 'WheelEncoders',
             'WheelTorqueCommand']
STANDARD_TYPES = ['sensor_msgs/msg/JointState', 'nav_msgs/msg/Odometry',
                  'geometry_msgs/msg/PointStamped', 'geometry_msgs/msg/PoseStamped',
                  'geometry_msgs/msg/TwistStamped', 'rosgraph_msgs/msg/Clock',
                  'std_msgs/msg/String', 'std_msgs/msg/Float64',
                  'diagnostic_msgs/msg/DiagnosticArray']
ALL_TYPES = [f'irs_msgs/msg/{n}' for n in IRS_TYPES] + STANDARD_TYPES

_INT_RANGES = {'int8': 8, 'int16': 16, 'int32': 32, 'int64': 64}


def _class(type_name):
    pkg, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{pkg}.{kind}'), name)


def _basic(name):
    if name == 'boolean':
        return st.booleans()
    if name == 'octet':
        return st.binary(min_size=1, max_size=1)
    if name == 'double':
        return st.floats(allow_nan=True, allow_infinity=True)
    if name == 'float':
        return st.floats(width=32, allow_nan=True, allow_infinity=True)
    if name.startswith('uint'):
        return st.integers(0, 2 ** int(name[4:]) - 1)
    bits = _INT_RANGES[name]
    return st.integers(-2 ** (bits - 1), 2 ** (bits - 1) - 1)


def _strategy(t):
    kind = type(t).__name__
    if kind == 'BasicType':
        return _basic(t.typename)
    if kind in ('UnboundedString', 'BoundedString'):
        bound = getattr(t, 'maximum_size', 12)
        return st.text(st.characters(blacklist_categories=('Cs',), blacklist_characters='\0'),
                       max_size=min(12, bound))
    if kind == 'NamespacedType':
        return _message(class_of(t))
    if kind == 'Array':
        return st.lists(_strategy(t.value_type), min_size=t.size, max_size=t.size)
    if kind in ('UnboundedSequence', 'BoundedSequence'):
        bound = getattr(t, 'maximum_size', 5)
        return st.lists(_strategy(t.value_type), max_size=min(5, bound))
    raise AssertionError(f'no strategy for {kind}')


def _message(cls):
    fields = [(slot[1:], t) for slot, t in message_fields(cls)]

    def build(values):
        msg = cls()
        for (name, _), value in zip(fields, values):
            setattr(msg, name, value)
        return msg
    return st.tuples(*[_strategy(t) for _, t in fields]).map(build)


def _canon(value):
    """Values comparable bit for bit: floats as their IEEE bytes (NaN == NaN of same bits)."""
    if hasattr(value, 'get_fields_and_field_types'):
        return tuple(_canon(getattr(value, f)) for f in value.get_fields_and_field_types())
    if isinstance(value, bytes) and len(value) == 1:
        return value[0]                 # an octet: rclpy gives bytes, mcap_ros2 an int
    if isinstance(value, (str, bytes)):
        return value
    if isinstance(value, bool):
        return int(value)
    if hasattr(value, '__len__'):
        return tuple(_canon(v) for v in value)
    if isinstance(value, float) or type(value).__name__.startswith('float'):
        return struct.pack('<d', float(value))
    return int(value)


@pytest.mark.parametrize('type_name', ALL_TYPES)
def test_every_type_the_project_publishes_is_covered(type_name):
    assert cdr_serializer(_class(type_name)) is not None


@pytest.mark.parametrize('type_name', ALL_TYPES)
def test_random_messages_decode_to_what_went_in(type_name):
    cls = _class(type_name)
    fast = cdr_serializer(cls)

    @settings(max_examples=60, deadline=None)
    @given(_message(cls))
    def check(msg):
        ours = fast(msg)
        assert ours[:4] == CDR_LE_HEADER
        assert _canon(deserialize_message(ours, cls)) == _canon(msg)
        assert len(ours) <= len(serialize_message(msg))   # rclpy may add trailing padding
    check()


@pytest.mark.parametrize('type_name', ALL_TYPES)
def test_an_independent_decoder_reads_the_same_values(type_name):
    """mcap_ros2's pure-Python CDR reader, given the type's .msg definition."""
    from mcap_ros2._dynamic import generate_dynamic

    from irs_bag.msg_definitions import get_message_definition
    cls = _class(type_name)
    decode = generate_dynamic(type_name, get_message_definition(type_name))[type_name]
    fast = cdr_serializer(cls)

    def plain(value):
        if hasattr(value, '__slots__') and not isinstance(value, (str, bytes)):
            return tuple(plain(getattr(value, s)) for s in value.__slots__)
        if isinstance(value, (list, tuple)):
            return tuple(plain(v) for v in value)
        return value

    @settings(max_examples=30, deadline=None)
    @given(_message(cls))
    def check(msg):
        theirs = plain(decode(fast(msg)))
        mine = _canon(msg)
        assert _canon(theirs) == mine
    check()


def test_a_fixed_array_of_the_wrong_length_is_refused():
    from nav_msgs.msg import Odometry
    msg = Odometry()
    fast = cdr_serializer(Odometry)
    object.__setattr__(msg.pose, '_covariance', [0.0] * 35)   # past rclpy's own setter check
    with pytest.raises(ValueError, match='array of 36'):
        fast(msg)


def test_nan_and_signed_zero_keep_their_bits():
    from std_msgs.msg import Float64
    fast = cdr_serializer(Float64)
    for x in (math.nan, -0.0, math.inf, -math.inf, 5e-324):
        data = fast(Float64(data=x))
        assert data[4:] == struct.pack('<d', x)
