"""Chosen fields of chosen topics of a bag as numpy columns, read in one pass (no rclpy).

A *spec* maps a topic suffix (matched with or without a namespace: any topic whose name is the
suffix or ends with ``/<suffix>``) to ``{column: field path}``; a path is dotted with optional
indexes (``pose.pose.position.x``, ``position[2]``) or a tuple of alternatives, the first that
the topic's messages have being used. :func:`read_columns` decodes every message of the matched
topics once and returns, per suffix, ``t`` [s] (``header.stamp``, else the log time) and one
float64 array per column (NaN where a message lacks the field). The plots, the rerun export and
the experiment runner share one read: the runner merges their specs (:func:`merge_specs`).

Decoding: ``rosbags``' generated CDR readers, built from the definitions stored in the bag
(42 us per message against 79 us for :func:`irs_bag.reader.deserialize`: Odometry,
PointStamped and SteeringActuatorState of a Figure 10 bag, CPU time on the loaded shared VM,
2026-12-02, commit 4c0f247); a type rosbags cannot parse falls back to
:func:`irs_bag.reader.deserialize`.
"""
from __future__ import annotations

import functools
import re
from operator import attrgetter
from typing import Callable, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .reader import BagError, deserialize, reading

__all__ = ['Columns', 'find_topic', 'merge_specs', 'read_columns', 'getter']

Path = Union[str, Tuple[str, ...]]
Spec = Mapping[str, Mapping[str, Path]]
#: suffix -> {'t': times [s], column: values}
Columns = Dict[str, Dict[str, np.ndarray]]

_INDEX = re.compile(r'^(\w+)\[(\d+)\]$')


def find_topic(topics, suffix: str) -> Optional[str]:
    """The shortest topic named ``suffix`` or ending with ``/<suffix>``, or None."""
    suffix = suffix.strip('/')
    for t in sorted(topics, key=len):
        if t.strip('/') == suffix or t.endswith('/' + suffix):
            return t
    return None


def getter(path: str) -> Callable:
    """A function reading ``path`` (``a.b.c``, ``position[2]``) from a message."""
    steps = []
    for part in path.split('.'):
        m = _INDEX.match(part)
        steps.append((m.group(1), int(m.group(2))) if m else (part, None))

    def get(msg):
        for name, index in steps:
            msg = getattr(msg, name)
            if index is not None:
                msg = msg[index]
        return msg
    return get


def merge_specs(*specs: Spec) -> Dict[str, Dict[str, Path]]:
    """One spec holding every column of ``specs`` (same suffix and column: same path)."""
    out: Dict[str, Dict[str, Path]] = {}
    for spec in specs:
        for suffix, cols in spec.items():
            out.setdefault(suffix, {}).update(cols)
    return out


class _Decoders:
    """Per message type: rosbags' reader if it parses the stored definition, else mcap_ros2's."""

    def __init__(self, schemas: Dict[str, str]):
        self.schemas = schemas
        self.funcs: Dict[str, Callable[[bytes], object]] = {}

    def __call__(self, type_name: str) -> Callable[[bytes], object]:
        fn = self.funcs.get(type_name)
        if fn is None:
            fn = self.funcs[type_name] = self._make(type_name)
        return fn

    def _make(self, type_name: str):
        text = self.schemas.get(type_name, '')
        slow = functools.partial(deserialize, type_name, text)
        try:
            from rosbags.typesys import Stores, get_typestore, get_types_from_msg
            store = get_typestore(Stores.EMPTY)
            store.register(get_types_from_msg(text, type_name))
            msgdef = store.get_msgdef(type_name)
        except Exception:   # a definition rosbags refuses: the reader's decoder
            return slow
        # The generated little-endian reader itself: Typestore.deserialize_cdr also insists
        # that the message ends within 3 bytes of the last field, which Fast DDS's alignment
        # padding after an empty trailing float64 sequence (JointState velocity, effort) fails.
        read, cls = msgdef.deserialize_cdr_le, msgdef.cls

        def fast(data):
            if bytes(data[:2]) != b'\x00\x01':      # not little-endian CDR
                return slow(data)
            try:
                return read(memoryview(data)[4:], 0, cls, store)[0]
            except Exception:
                return slow(data)
        return fast


def _split(path: str) -> Tuple[str, Optional[int]]:
    """``'position[2]'`` -> ``('position', 2)``; ``'a.b'`` -> ``('a.b', None)``."""
    head, _, last = path.rpartition('.')
    m = _INDEX.match(last)
    if m is None:
        return path, None
    return (f'{head}.{m.group(1)}' if head else m.group(1)), int(m.group(2))


class _Plan:
    """How one suffix's columns come out of its topic's messages: one ``attrgetter`` call per
    message (C code) fetching every base field (plus the stamp), indexes applied at the end.
    """

    def __init__(self, cols: Mapping[str, Path]):
        self.cols = cols
        self.get = None
        self.rows: list = []
        self.log_ns: list = []

    def bind(self, msg) -> None:
        """Choose, on the first message, each column's alternative and build the getter."""
        self.chosen: Dict[str, Tuple[int, Optional[int]]] = {}
        bases: list = []
        for col, path in self.cols.items():
            for alt in ((path,) if isinstance(path, str) else tuple(path)):
                try:
                    float(getter(alt)(msg))
                except (AttributeError, IndexError, TypeError, ValueError):
                    continue
                base, index = _split(alt)
                if base not in bases:
                    bases.append(base)
                self.chosen[col] = (bases.index(base), index)
                break
        self.stamped = getattr(getattr(msg, 'header', None), 'stamp', None) is not None
        if self.stamped:
            bases += ['header.stamp.sec', 'header.stamp.nanosec']
        self.nbase = len(bases)
        self.get = attrgetter(*bases) if bases else (lambda m: ())
        if len(bases) == 1:
            one = self.get
            self.get = lambda m: (one(m),)

    def take(self, msg, log_ns: int) -> None:
        """Append ``msg``'s fields (NaN where the message lacks one) and its log time [ns]."""
        if self.get is None:
            self.bind(msg)
        try:
            self.rows.append(self.get(msg))
        except (AttributeError, IndexError, TypeError):
            self.rows.append((np.nan,) * self.nbase)
        self.log_ns.append(log_ns)

    def columns(self) -> Dict[str, np.ndarray]:
        n = len(self.rows)
        if self.stamped:
            t = np.fromiter((r[-2] for r in self.rows), float, n) + \
                1e-9 * np.fromiter((r[-1] for r in self.rows), float, n)
        else:
            t = np.asarray(self.log_ns, dtype=float) * 1e-9
        out = {'t': t}
        for col in self.cols:
            if col not in self.chosen:
                out[col] = np.full(n, np.nan)
                continue
            k, index = self.chosen[col]
            if index is None:
                out[col] = np.fromiter((_num(r[k]) for r in self.rows), float, n)
            else:
                out[col] = np.fromiter((_num(r[k][index]) if len(r[k]) > index else np.nan
                                        for r in self.rows), float, n)
        if n > 1 and np.any(np.diff(t) < 0):       # file order: sort by time (stable)
            order = np.argsort(t, kind='stable')
            out = {c: v[order] for c, v in out.items()}
        return out


def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return np.nan


def read_columns(bag, spec: Spec) -> Columns:
    """The columns of ``spec`` (module docstring) from ``bag`` (a path, opened strictly, or an
    open :class:`~irs_bag.reader.BagReader`); suffixes with no topic in the bag are absent.
    Each suffix's rows are sorted by ``t``.

    Raises
    ------
    BagError
        Unreadable bag, or a message that does not decode.
    """
    with reading(bag) as r:
        topics = r.topics
        plans: Dict[str, list] = {}
        by_suffix: Dict[str, _Plan] = {}
        for suffix, cols in spec.items():
            topic = find_topic(topics, suffix)
            if topic is not None:
                by_suffix[suffix] = _Plan(cols)
                plans.setdefault(topic, []).append(by_suffix[suffix])
        if not plans:
            return {}
        decoders = _Decoders(r.schemas)
        for m in r.messages(list(plans)):
            try:
                msg = decoders(m.type)(m.data)
            except BagError:
                raise
            except Exception as exc:
                raise BagError(f'cannot decode a {m.type!r} message on {m.topic} '
                               f'({type(exc).__name__}: {exc})') from None
            for plan in plans[m.topic]:
                plan.take(msg, m.log_time_ns)
    return {s: p.columns() for s, p in by_suffix.items() if p.rows}


def columns_of(columns: Columns, suffix: str, *names: str) -> Optional[Sequence[np.ndarray]]:
    """``(t, *values)`` of ``suffix`` if it has every named column with a finite value."""
    cols = columns.get(suffix)
    if cols is None or not len(cols['t']):
        return None
    if any(n not in cols or not np.isfinite(cols[n]).any() for n in names):
        return None
    return (cols['t'], *(cols[n] for n in names))
