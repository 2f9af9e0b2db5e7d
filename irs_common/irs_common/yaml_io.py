"""YAML documents parsed by libyaml.

:func:`safe_load` is ``yaml.safe_load`` with PyYAML's ``CSafeLoader``: libyaml's C scanner and
parser under PyYAML's own safe constructor and resolver; ROS reads ``--params-file`` with
libyaml too (``rcl_yaml_param_parser``). It gives the values of
``yaml.safe_load`` for every YAML file of the tree and for every document ``yaml.safe_dump``
writes (``irs_common/test/test_yaml_io.py``). Off well-formed YAML the parsers differ: libyaml
accepts a tab as separation space, a comment right after a block-scalar header and a
byte-order mark, which PyYAML's parser refuses, and an empty node with the non-specific tag
``!`` (``a: !``) is ``''``, not ``None``. It parses the tree's parameter files about nine times
faster (8 ms against 71 ms for the 14 ``config/*.yaml``, 2026-12-03). An experiment reads each
node's parameter files several times (the runner's checks, the offline twin, the node itself):
with the pure-Python parser that was about a tenth of a short offline run. Where PyYAML was
built without libyaml, ``SafeLoader`` is used. Errors are ``yaml.YAMLError`` either way; their
text differs (libyaml's names the line and column without quoting the line).
"""

import yaml

__all__ = ['LOADER', 'safe_load']

LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)


def safe_load(stream):
    """The one YAML document in ``stream`` (``str``, ``bytes`` or an open file) as plain Python
    values (``dict``, ``list``, ``str``, ``int``, ``float``, ``bool``, ``None``, dates);
    ``yaml.YAMLError`` if it is not YAML.
    """
    return yaml.load(stream, Loader=LOADER)   # noqa: S506 - a safe loader
