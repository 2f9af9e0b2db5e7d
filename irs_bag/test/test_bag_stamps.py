"""Which recorded types carry a header stamp first: constants before the fields are skipped."""
from pathlib import Path

from ament_index_python.packages import get_package_share_directory

from irs_bag.stamps import _first_field_type, stamp_reader


def _installed(name: str) -> str:
    return (Path(get_package_share_directory('irs_msgs')) / 'msg' / f'{name}.msg').read_text()


def test_constants_before_the_header_are_no_field():
    for name in ('LateralReference', 'LateralControllerStatus', 'TreadmillState'):
        text = _installed(name)
        assert '=' in text.split('std_msgs/Header')[0], name     # constants come first
        assert _first_field_type(text) == 'std_msgs/Header', name
        assert stamp_reader(text) is not None, name
    assert _first_field_type('uint8 A=1\nint8 B =2\nbuiltin_interfaces/Time t\n') == \
        'builtin_interfaces/Time'
    assert stamp_reader('float64 x\nstd_msgs/Header header\n') is None
    assert _first_field_type('# only comments\n\n') == ''
