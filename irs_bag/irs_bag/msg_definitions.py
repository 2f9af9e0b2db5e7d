r"""Full ROS 2 message definitions (``ros2msg``) as rosbag2 writes them into MCAP schemas.

rosbag2 (``rosbag2_cpp::LocalMessageDefinitionSource``) stores, for every topic type, the
*complete* message definition: the type's own ``.msg`` text followed, for every nested type it
uses (recursively, each type once), by a two-line delimiter and that type's ``.msg`` text::

    <text of pkg/msg/Root.msg>
    ================================================================================
    MSG: other_pkg/Nested
    <text of other_pkg/msg/Nested.msg>

Details reproduced here so the schema bytes match what ``ros2 bag record`` writes:

* the ``.msg`` files are copied verbatim (comments, constants, blank lines, trailing newline);
* dependencies are found with the same regular expression rosbag2 uses (a type token at the
  start of a line, optionally followed by ``[...]``, then white space); a type without a
  package (``Type``) belongs to the package of the file that mentions it (``pkg/Type``);
* the dependencies of one file are visited in sorted (``std::set``) order, depth first, and a
  dependency already emitted anywhere in the definition is not emitted again;
* each delimiter is ``"\n" + "=" * 80 + "\n" + "MSG: " + name + "\n"`` where ``name`` is the
  dependency exactly as spelled in the file (``std_msgs/Header``, no ``/msg/``).

Deviation: rosbag2 does not list ``wstring`` as a primitive type (it would then fail to find a
``.msg`` for it and fall back to IDL); here ``wstring`` is treated as the primitive it is.
Types without a ``.msg`` file (IDL-only) are not supported: :class:`MessageDefinitionError`.

``.msg`` files are looked up as ``<prefix>/share/<pkg>/<namespace>/<Type>.msg`` for every prefix
in ``AMENT_PREFIX_PATH`` (colon separated) and finally ``sys.prefix`` (the venv, which is an
ament prefix in this project). No rclpy import.
"""

from __future__ import annotations

import functools
import json
import os
import re
import sys
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Sequence, Tuple

__all__ = [
    'DELIMITER',
    'MessageDefinitionError',
    'PRIMITIVE_TYPES',
    'ament_prefixes',
    'find_interface_file',
    'get_message_definition',
    'msg_dependencies',
    'split_type_name',
    'type_description_hash',
]

#: The 80 '=' line that separates definitions (without newline).
DELIMITER = '=' * 80

#: Primitive .msg field types (rosbag2's list plus ``wstring``).
PRIMITIVE_TYPES = frozenset({
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring',
})

# Same pattern as rosbag2_cpp local_message_definition_source.cpp (ECMAScript ``^`` without
# multiline == Python ``^`` without re.M: start of text only).
_MSG_FIELD_TYPE_RE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_ROS_NAME = r'[a-zA-Z][a-zA-Z0-9_]*'
_TYPE_2_RE = re.compile(rf'^({_ROS_NAME})/({_ROS_NAME})$')
_TYPE_3_RE = re.compile(rf'^({_ROS_NAME})/({_ROS_NAME})/({_ROS_NAME})$')


class MessageDefinitionError(LookupError):
    """A message type name is malformed or its ``.msg`` file (or a nested one) was not found."""


def ament_prefixes(env: Optional[Dict[str, str]] = None) -> List[str]:
    """Install prefixes to search: ``AMENT_PREFIX_PATH`` entries, then ``sys.prefix``.

    Parameters
    ----------
    env : dict, optional
        Environment mapping to read ``AMENT_PREFIX_PATH`` from (default ``os.environ``).
    """
    env = os.environ if env is None else env
    out: List[str] = []
    for p in env.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if p and p not in out:
            out.append(p)
    if sys.prefix not in out:
        out.append(sys.prefix)
    return out


def split_type_name(type_name: str) -> Tuple[str, str, str]:
    """Split ``pkg/Type`` or ``pkg/msg/Type`` into ``(pkg, namespace, Type)``.

    Raises
    ------
    MessageDefinitionError
        If the name has neither form.
    """
    if not isinstance(type_name, str):
        raise MessageDefinitionError(f'message type name must be a string, got {type_name!r}')
    m = _TYPE_2_RE.match(type_name)
    if m:
        return m.group(1), 'msg', m.group(2)
    m = _TYPE_3_RE.match(type_name)
    if m:
        return m.group(1), m.group(2), m.group(3)
    raise MessageDefinitionError(
        f"invalid message type name {type_name!r}: expected 'pkg/msg/Type' or 'pkg/Type'")


def find_interface_file(type_name: str, prefixes: Optional[Sequence[str]] = None,
                        extension: str = '.msg') -> Path:
    """Return the path of ``share/<pkg>/<ns>/<Type><extension>`` in the first prefix having it.

    Raises
    ------
    MessageDefinitionError
        If no prefix holds the file.
    """
    pkg, ns, name = split_type_name(type_name)
    prefixes = ament_prefixes() if prefixes is None else list(prefixes)
    for prefix in prefixes:
        path = Path(prefix) / 'share' / pkg / ns / f'{name}{extension}'
        if path.is_file():
            return path
    raise MessageDefinitionError(
        f'unknown message type {type_name!r}: no share/{pkg}/{ns}/{name}{extension} in '
        f'AMENT_PREFIX_PATH or {sys.prefix} (searched {len(prefixes)} prefixes)')


def msg_dependencies(text: str, package: str) -> List[str]:
    """Non-primitive field types mentioned in ``.msg`` ``text``, sorted, as rosbag2 finds them.

    Same-package references ``Type`` become ``package/Type``.
    """
    deps = set()
    for m in _MSG_FIELD_TYPE_RE.finditer(text):
        t = m.group(1)
        if t in PRIMITIVE_TYPES:
            continue
        deps.add(t if '/' in t else f'{package}/{t}')
    return sorted(deps)


@functools.lru_cache(maxsize=512)
def _read_msg(type_name: str, prefixes: Tuple[str, ...]) -> str:
    path = find_interface_file(type_name, prefixes)
    try:
        return path.read_bytes().decode('utf-8')
    except (OSError, UnicodeDecodeError) as exc:
        raise MessageDefinitionError(f'cannot read {path}: {exc}') from None


@functools.lru_cache(maxsize=512)
def _full_text(type_name: str, prefixes: Tuple[str, ...]) -> str:
    seen = set()

    def append(name: str, depth: int, parent: Optional[str]) -> str:
        if depth <= 0:
            raise MessageDefinitionError(
                f'nesting too deep while resolving {type_name!r} (recursive definition?)')
        try:
            text = _read_msg(name, prefixes)
        except MessageDefinitionError as exc:
            if parent is None:
                raise
            raise MessageDefinitionError(f'{exc} (field type used by {parent!r}, needed for '
                                         f'{type_name!r})') from None
        pkg = split_type_name(name)[0]
        out = text
        for dep in msg_dependencies(text, pkg):
            if dep in seen:
                continue
            seen.add(dep)
            out += '\n' + DELIMITER + '\n' + 'MSG: ' + dep + '\n'
            out += append(dep, depth - 1, name)
        return out

    return append(type_name, 50, None)


def get_message_definition(type_name: str, prefixes: Optional[Iterable[str]] = None) -> str:
    """Complete ``ros2msg`` definition of ``type_name`` exactly as rosbag2 writes it.

    Parameters
    ----------
    type_name : str
        ``pkg/msg/Type`` (as in topic types) or ``pkg/Type``.
    prefixes : iterable of str, optional
        Install prefixes to search (default :func:`ament_prefixes`).

    Returns
    -------
    str
        The concatenated definition (encode as UTF-8 for the MCAP schema data).

    Raises
    ------
    MessageDefinitionError
        If the name is malformed or any needed ``.msg`` file is missing.
    """
    split_type_name(type_name)
    prefixes = tuple(ament_prefixes() if prefixes is None else prefixes)
    return _full_text(type_name, prefixes)


def type_description_hash(type_name: str, prefixes: Optional[Iterable[str]] = None) -> str:
    """The ``RIHS01_...`` type hash of ``type_name`` from the installed ``<Type>.json``.

    rosidl (Iron and later) installs ``share/<pkg>/msg/<Type>.json`` next to the ``.msg``; its
    ``type_hashes`` list holds the hash rosbag2 writes as ``type_description_hash``.
    Returns ``''`` if the file or entry is missing (rosbag2 also accepts an empty hash).
    """
    try:
        pkg, ns, name = split_type_name(type_name)
        path = find_interface_file(type_name, None if prefixes is None else list(prefixes),
                                   extension='.json')
        data = json.loads(path.read_text(encoding='utf-8'))
    except (MessageDefinitionError, OSError, ValueError):
        return ''
    full = f'{pkg}/{ns}/{name}'
    for item in data.get('type_hashes', []) if isinstance(data, dict) else []:
        if isinstance(item, dict) and item.get('type_name') == full:
            return str(item.get('hash_string', ''))
    return ''
