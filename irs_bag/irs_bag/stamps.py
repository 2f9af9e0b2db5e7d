"""The header stamp of a recorded message, and whether a bag runs on simulated time (no rclpy).

:func:`stamp_reader` reads the leading ``std_msgs/Header`` or ``builtin_interfaces/Time`` of a
CDR message without decoding it: both start with ``int32 sec, uint32 nanosec`` right after the
4-byte encapsulation header, so the stamp [ns] is ``sec * 1e9 + nanosec`` at byte offset 4
(byte order from the encapsulation header).

:func:`clock_mode` tells a lock-step bag (header stamps are simulated time, receive times are
how fast the graph stepped) from a real-time one: the ``clock`` entry of the ``irs_experiment``
metadata record (written by the experiment runner), else the ``clock:`` key of the experiment
file stored in that record, else a recorded ``/clock`` topic (only the lock-step rig publishes
one).
"""
from __future__ import annotations

import re
import struct
from typing import Callable, Dict, Iterable, Optional, Tuple

import yaml

__all__ = ['clock_mode', 'lockstep_reason', 'stamp_reader']

_STAMPED_FIRST = ('std_msgs/Header', 'std_msgs/msg/Header', 'Header',
                  'builtin_interfaces/Time', 'builtin_interfaces/msg/Time')


#: A constant's line of a ``ros2msg`` definition: ``TYPE NAME = VALUE`` (spaces optional).
_CONSTANT = re.compile(r'^\S+\s+\w+\s*=')


def _first_field_type(definition: str) -> str:
    """Type of the first field of a ``ros2msg`` definition ('' if none; constants skipped)."""
    for line in definition.splitlines():
        s = line.split('#', 1)[0].strip()
        if not s:
            continue
        if s.startswith('=' * 10):
            break
        if _CONSTANT.match(s):        # 'uint8 SOURCE_FUNCTION = 0' as well as 'NAME=0'
            continue
        parts = s.split()
        if len(parts) >= 2:
            return parts[0]
    return ''


def _read_stamp(data: bytes) -> Optional[int]:
    if len(data) < 12:
        return None
    sec, nsec = struct.unpack_from('<iI' if data[1] & 1 else '>iI', data, 4)
    return sec * 1_000_000_000 + nsec


def stamp_reader(definition: str) -> Optional[Callable[[bytes], Optional[int]]]:
    """A function ``cdr_bytes -> stamp [ns]`` for messages that start with a Header or a Time
    (None for a message too short to hold one), or None if the type has no leading stamp.
    """
    return _read_stamp if _first_field_type(definition) in _STAMPED_FIRST else None


def clock_mode(metadata_records: Iterable[Tuple[str, Dict[str, str]]],
               topics: Iterable[str]) -> Tuple[Optional[str], str]:
    """``('lockstep' | 'realtime' | None, why)`` from a bag's metadata records and topic names.

    None means the bag does not say (no experiment record, no ``/clock``): such a bag is
    treated as real time.
    """
    for name, data in metadata_records:
        if name != 'irs_experiment':
            continue
        mode = data.get('clock', '')
        if mode in ('lockstep', 'realtime'):
            return mode, f'the experiment record says clock: {mode}'
        try:
            doc = yaml.safe_load(data.get('experiment_yaml', ''))
        except yaml.YAMLError:
            doc = None
        if isinstance(doc, dict) and doc.get('clock') in ('lockstep', 'realtime'):
            return doc['clock'], f"its experiment file says clock: {doc['clock']}"
    if '/clock' in set(topics):
        return 'lockstep', 'it has /clock'
    return None, 'no experiment record and no /clock'


def lockstep_reason(metadata_records, topics) -> Optional[str]:
    """Why a bag is a lock-step recording (header stamps = sim time), or None if it is not."""
    mode, why = clock_mode(metadata_records, topics)
    return why if mode == 'lockstep' else None
