"""Tests for irs_bag.msg_definitions (rosbag2-style ros2msg full definitions)."""

import json
import sys

from pathlib import Path

import pytest
from mcap_ros2._dynamic import generate_dynamic
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from irs_bag.msg_definitions import (DELIMITER, MessageDefinitionError, ament_prefixes,
                                         get_message_definition, msg_dependencies,
                                         split_type_name, type_description_hash)

SHARE = Path(sys.prefix) / 'share'
TYPES = [
    'sensor_msgs/msg/JointState',
    'geometry_msgs/msg/PoseStamped',
    'std_msgs/msg/Header',
    'geometry_msgs/msg/TwistStamped',
    'sensor_msgs/msg/Imu',
    'nav_msgs/msg/Odometry',
    'geometry_msgs/msg/PoseArray',
    'std_msgs/msg/Float64MultiArray',
]


def _msg(pkg, name):
    return (SHARE / pkg / 'msg' / f'{name}.msg').read_text()


def test_delimiter_is_80_equals():
    assert DELIMITER == '=' * 80


def test_joint_state_exact_text():
    """Root text verbatim, then Header, then (nested in Header) Time, each once."""
    expected = (_msg('sensor_msgs', 'JointState')
                + '\n' + '=' * 80 + '\nMSG: std_msgs/Header\n' + _msg('std_msgs', 'Header')
                + '\n' + '=' * 80 + '\nMSG: builtin_interfaces/Time\n'
                + _msg('builtin_interfaces', 'Time'))
    assert get_message_definition('sensor_msgs/msg/JointState') == expected
    # pkg/Type spelling gives the same text
    assert get_message_definition('sensor_msgs/JointState') == expected


def test_pose_stamped_exact_text_sorted_depth_first():
    """Dependencies of one file in sorted order (rosbag2 std::set), depth first;
    same-package 'Pose' -> geometry_msgs/Pose.
    """
    sep = '\n' + '=' * 80 + '\n'
    expected = (_msg('geometry_msgs', 'PoseStamped')
                + sep + 'MSG: geometry_msgs/Pose\n' + _msg('geometry_msgs', 'Pose')
                + sep + 'MSG: geometry_msgs/Point\n' + _msg('geometry_msgs', 'Point')
                + sep + 'MSG: geometry_msgs/Quaternion\n' + _msg('geometry_msgs', 'Quaternion')
                + sep + 'MSG: std_msgs/Header\n' + _msg('std_msgs', 'Header')
                + sep + 'MSG: builtin_interfaces/Time\n' + _msg('builtin_interfaces', 'Time'))
    assert get_message_definition('geometry_msgs/msg/PoseStamped') == expected


def _make_pkg(root: Path):
    msg = root / 'share' / 'my_pkg' / 'msg'
    msg.mkdir(parents=True)
    (msg / 'Outer.msg').write_text(
        '# comment line with Type word\n'
        'uint8 MODE_A=1  # constant\n'
        'string NAME="x y"\n'
        'Leaf[] leaves\n'
        'my_pkg/Inner[<=3] inners   # bounded\n'
        'Inner[2] pair\n'
        'builtin_interfaces/Duration d\n'
        'float64[] values\n'
        'string<=10 short\n'
        'wstring w\n'
        'int32 a 5\n')
    (msg / 'Inner.msg').write_text('Leaf leaf\nstd_msgs/Header header\n')
    (msg / 'Leaf.msg').write_text('float32 v\n')
    return root


def test_custom_package_arrays_bounded_same_package_constants(tmp_path, monkeypatch):
    prefix = _make_pkg(tmp_path / 'prefix')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(prefix))
    text = get_message_definition('my_pkg/msg/Outer')
    sep = '\n' + '=' * 80 + '\n'
    share = prefix / 'share' / 'my_pkg' / 'msg'
    expected = ((share / 'Outer.msg').read_text()
                + sep + 'MSG: builtin_interfaces/Duration\n' + _msg('builtin_interfaces',
                                                                    'Duration')
                + sep + 'MSG: my_pkg/Inner\n' + (share / 'Inner.msg').read_text()
                + sep + 'MSG: my_pkg/Leaf\n' + (share / 'Leaf.msg').read_text()
                + sep + 'MSG: std_msgs/Header\n' + _msg('std_msgs', 'Header')
                + sep + 'MSG: builtin_interfaces/Time\n' + _msg('builtin_interfaces', 'Time'))
    assert text == expected
    assert text.count('MSG: my_pkg/Leaf') == 1
    # both parsers accept it
    types = get_types_from_msg(text, 'my_pkg/msg/Outer')
    assert {'my_pkg/msg/Outer', 'my_pkg/msg/Inner', 'my_pkg/msg/Leaf',
            'std_msgs/msg/Header'} <= set(types)
    assert 'my_pkg/Outer' in generate_dynamic('my_pkg/Outer', text) or \
        'my_pkg/msg/Outer' in generate_dynamic('my_pkg/msg/Outer', text)


def test_msg_dependencies_regex():
    text = '# Foo bar\nuint8 X=1\nPoint[] pts\nother/Type[<=2] t\n  Point p\nstring<=3 s\n'
    assert msg_dependencies(text, 'pkg') == ['other/Type', 'pkg/Point']


def test_prefix_order_and_fallback(tmp_path, monkeypatch):
    monkeypatch.setenv('AMENT_PREFIX_PATH', f'{tmp_path}/a:{tmp_path}/b')
    assert ament_prefixes() == [f'{tmp_path}/a', f'{tmp_path}/b', sys.prefix]
    monkeypatch.delenv('AMENT_PREFIX_PATH')
    assert ament_prefixes() == [sys.prefix]
    # still found through sys.prefix
    assert get_message_definition('std_msgs/msg/Header').startswith('# Standard metadata')


@pytest.mark.parametrize('name', ['nonexistent_pkg/msg/Foo', 'std_msgs/msg/NoSuchType'])
def test_unknown_type_raises(name):
    with pytest.raises(MessageDefinitionError, match='unknown message type'):
        get_message_definition(name)


@pytest.mark.parametrize('name', ['JointState', 'a/b/c/d', '', 'sensor_msgs//JointState', 3])
def test_malformed_type_raises(name):
    with pytest.raises(MessageDefinitionError):
        get_message_definition(name)


def test_missing_nested_type_names_parent(tmp_path, monkeypatch):
    msg = tmp_path / 'share' / 'bad_pkg' / 'msg'
    msg.mkdir(parents=True)
    (msg / 'A.msg').write_text('Missing m\n')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    with pytest.raises(MessageDefinitionError, match=r'bad_pkg/Missing.*bad_pkg/msg/A'):
        get_message_definition('bad_pkg/msg/A')


def test_split_type_name():
    assert split_type_name('a/msg/B') == ('a', 'msg', 'B')
    assert split_type_name('a/B') == ('a', 'msg', 'B')


@pytest.mark.parametrize('type_name', TYPES)
def test_rosbags_parses_definition_to_jazzy_hash(type_name):
    """rosbags parses our text; the RIHS01 hash of what it parsed equals rosbags' own Jazzy
    type store hash and the hash installed by rosidl (<Type>.json).
    """
    text = get_message_definition(type_name)
    types = get_types_from_msg(text, type_name)
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    ours = store.hash_rihs01(type_name)
    assert ours == jazzy.hash_rihs01(type_name)
    assert ours == type_description_hash(type_name)
    assert ours.startswith('RIHS01_')
    # field-for-field equal to the built-in Jazzy definitions for every parsed type
    for name in types:
        if name in jazzy.fielddefs:
            assert store.fielddefs[name] == jazzy.fielddefs[name], name


@pytest.mark.parametrize('type_name', TYPES)
def test_mcap_ros2_parses_definition(type_name):
    decoders = generate_dynamic(type_name, get_message_definition(type_name))
    assert type_name in decoders


def test_type_description_hash_matches_json():
    data = json.loads((SHARE / 'sensor_msgs' / 'msg' / 'JointState.json').read_text())
    expected = [h['hash_string'] for h in data['type_hashes']
                if h['type_name'] == 'sensor_msgs/msg/JointState'][0]
    assert type_description_hash('sensor_msgs/msg/JointState') == expected
    assert type_description_hash('nonexistent_pkg/msg/Foo') == ''
