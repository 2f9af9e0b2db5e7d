"""A fast CDR serialiser for rclpy messages, generated per message class (no rclpy import).

The composed recorder serialises every message it records in the 1 kHz loop's thread
(:mod:`irs_common.intra_process`). ``rclpy.serialization.serialize_message`` converts the Python
message to its C struct field by field, then Fast CDR writes it: 5-12 us per message in a tight
loop, 15-40 us inside the running loop, 16 % of a composed lock-step Figure 10 step (13 topics
recorded at 1 kHz). The libraries that write CDR from Python are slower or refuse rclpy's
messages: ``mcap_ros2``'s dynamic encoder takes 19 us for a JointState and rejects numpy arrays;
``rosbags``' generated serialiser is 1.7x faster than rclpy but rejects ``array.array``
sequences (rclpy's type for ``sequence<double>``). So this module generates, once per message
class, a Python function that writes the same CDR with as few interpreter steps as possible:

* nested messages are flattened into one function (``m._header._stamp._sec``: slot reads, not
  the property calls);
* runs of fixed-size fields become one ``struct.Struct.pack`` call, from one of 8 precompiled
  layouts chosen by the current offset mod 8 (the alignment padding differs);
* numeric arrays and sequences are written with ``tobytes()`` (numpy arrays, ``array.array``).

Encoding and supported types: :func:`cdr_serializer`.
"""
from __future__ import annotations

import importlib
import struct
import sys

__all__ = ['cdr_serializer', 'CDR_LE_HEADER', 'class_of', 'message_fields']

#: Encapsulation header of a little-endian plain CDR payload (representation id 0x0001).
CDR_LE_HEADER = b'\x00\x01\x00\x00'

#: rosidl basic type -> (struct code, size [bytes]).
_BASIC = {
    'boolean': ('?', 1), 'int8': ('b', 1), 'uint8': ('B', 1), 'int16': ('h', 2),
    'uint16': ('H', 2), 'int32': ('i', 4), 'uint32': ('I', 4), 'int64': ('q', 8),
    'uint64': ('Q', 8), 'float': ('f', 4), 'double': ('d', 8),
    'octet': ('c', 1),          # rclpy: a bytes object of length 1
}
#: Numbers that ``tobytes()`` may write for a sequence/array (bool: packed from rclpy's list).
_NUMERIC = {k: v for k, v in _BASIC.items() if k not in ('boolean', 'octet')}

_cache: dict = {}


class _Unsupported(ValueError):
    """A field type this generator does not write (the caller falls back to rclpy)."""


def cdr_serializer(msg_class):
    """``f(msg) -> bytes``, the CDR of a ``msg_class`` message; None if a field is unsupported.

    Generated and compiled on the first call per class, then cached.

    Encoding (OMG CDR, XCDR1, little endian, as ROS 2's Fast DDS writes it): A 4-byte encapsulation
    header ``00 01 00 00`` (CDR_LE), then the fields in order. A primitive of size s (1, 2, 4 or 8
    bytes) starts at an offset (from the end of the header) that is a multiple of s; the padding
    bytes are zero here (Fast DDS leaves them uninitialised). A string is a uint32 length counting
    a terminating NUL, the UTF-8 bytes and the NUL. A sequence is a uint32 element count, then the
    elements; a fixed array only the elements. Like Fast CDR, an empty sequence of primitives adds
    no alignment padding after its count.

    Supported: every basic type but ``char``/``wchar``/``long double``, strings (bounded or not),
    nested messages, and arrays and sequences (bounded or not) of numbers, bools, strings and
    messages. :func:`cdr_serializer` returns None for a class with anything else (wide strings,
    collections of octet or char); the caller then uses rclpy's serialiser. The tests
    (``test_cdr.py``) check, on random messages of every type the project publishes, that rclpy and
    mcap_ros2's reader decode these bytes to the values that went in, bit for bit, and that they
    are at most as long as rclpy's own (which may end in extra padding).
    """
    if msg_class in _cache:
        return _cache[msg_class]
    try:
        fn = _Generator().top_level(msg_class)
    except _Unsupported:
        fn = None
    _cache[msg_class] = fn
    return fn


def class_of(namespaced):
    """rosidl ``NamespacedType`` -> the Python message class."""
    module = importlib.import_module('.'.join(namespaced.namespaces))
    return getattr(module, namespaced.name)


def message_fields(msg_class):
    """``[(slot name, rosidl type)]`` of a message class, in wire order."""
    slots = [s for s in msg_class.__slots__ if s != '_check_fields']
    types = list(msg_class.SLOT_TYPES)
    if len(slots) != len(types):
        raise _Unsupported(f'{msg_class.__name__}: slots and slot types differ')
    return list(zip(slots, types))


def _group_structs(codes_sizes):
    """The 8 ``struct.Struct`` of a run of primitives, one per start offset mod 8."""
    out = []
    for start in range(8):
        off, fmt = start, '<'
        for code, size in codes_sizes:
            pad = -off % size
            fmt += 'x' * pad + code
            off += pad + size
        out.append(struct.Struct(fmt))
    return tuple(out)


class _Generator:
    """Writes the Python source of the serialisers (module docstring)."""

    def __init__(self):
        self.consts: dict = {'_pack': struct.pack, '_U32': _U32}
        self.n = 0
        self.functions: dict = {}   # class -> name of its appending function

    def _name(self, prefix):
        self.n += 1
        return f'{prefix}{self.n}'

    def top_level(self, msg_class):
        body = self._function(msg_class)
        src = ['def _serialize(m):',
               f'    b = bytearray({CDR_LE_HEADER!r})',
               f'    {body}(b, m)',
               '    return bytes(b)']
        return self._compile(src, '_serialize')

    def _function(self, msg_class):
        """Name of the generated ``f(b, m)`` that appends ``m``'s fields to bytearray ``b``."""
        if msg_class in self.functions:
            return self.functions[msg_class]
        name = self._name('_w')
        self.functions[msg_class] = name
        lines = [f'def {name}(b, m):']
        run = []            # pending run of primitives: (code, size, expression)
        self._emit_fields(msg_class, 'm', lines, run)
        self._flush_run(lines, run)
        lines.append('    return')
        self.consts[name] = self._compile(lines, name)
        return name

    def _emit_fields(self, msg_class, expr, lines, run):
        for slot, t in message_fields(msg_class):
            self._emit(t, f'{expr}.{slot}', lines, run)

    def _emit(self, t, expr, lines, run):
        kind = type(t).__name__
        if kind == 'BasicType':
            if t.typename not in _BASIC:
                raise _Unsupported(t.typename)
            code, size = _BASIC[t.typename]
            run.append((code, size, expr))
            return
        if kind == 'NamespacedType':     # nested message: flattened into this function
            self._emit_fields(class_of(t), expr, lines, run)
            return
        self._flush_run(lines, run)
        if kind in ('UnboundedString', 'BoundedString'):
            self._emit_string(expr, lines, '    ')
        elif kind == 'Array':
            self._emit_collection(t.value_type, expr, lines, counted=False, size=t.size)
        elif kind in ('UnboundedSequence', 'BoundedSequence'):
            self._emit_collection(t.value_type, expr, lines, counted=True)
        else:
            raise _Unsupported(kind)

    def _flush_run(self, lines, run):
        if not run:
            return
        g = self._name('_G')
        self.consts[g] = _group_structs([(c, s) for c, s, _ in run])
        values = ', '.join(e for _, _, e in run)
        lines.append(f'    b += {g}[(len(b) - 4) & 7].pack({values})')
        run.clear()

    @staticmethod
    def _emit_string(expr, lines, indent):
        lines.append(f'{indent}s = {expr}.encode()')
        lines.append(f'{indent}b += _U32[(len(b) - 4) & 7].pack(len(s) + 1)')
        lines.append(f'{indent}b += s')
        lines.append(f'{indent}b.append(0)')

    def _emit_collection(self, vt, expr, lines, counted, size=None):
        kind = type(vt).__name__
        lines.append(f'    v = {expr}')
        if counted:
            lines.append('    b += _U32[(len(b) - 4) & 7].pack(len(v))')
        elif size is not None:
            lines.append(f'    if len(v) != {size}:')
            lines.append(f"        raise ValueError('array of {size} expected')")
        if kind == 'BasicType' and vt.typename == 'boolean':    # rclpy keeps a list of bool
            lines.append("    b += _pack('<%d?' % len(v), *v)")
        elif kind == 'BasicType':
            if vt.typename not in _NUMERIC:
                raise _Unsupported(f'collection of {vt.typename}')
            code, item = _NUMERIC[vt.typename]
            # Fast CDR aligns the elements only when there are some.
            lines.append('    if len(v):')
            lines.append(f'        b += bytes(-(len(b) - 4) % {item})')
            native = 'True' if sys.byteorder == 'little' else 'False'   # tobytes(): native order
            lines.append(f"        if {native} and getattr(v, 'itemsize', 0) == {item} and "
                         f"getattr(v, 'typecode', getattr(getattr(v, 'dtype', None), 'char', "
                         f"None)) == {code!r}:")
            lines.append('            b += v.tobytes()')
            lines.append('        else:')
            lines.append(f"            b += _pack('<%d{code}' % len(v), *v)")
        elif kind in ('UnboundedString', 'BoundedString'):
            lines.append('    for e in v:')
            self._emit_string('e', lines, '        ')
        elif kind == 'NamespacedType':
            fn = self._function(class_of(vt))
            lines.append('    for e in v:')
            lines.append(f'        {fn}(b, e)')
        else:
            raise _Unsupported(f'collection of {kind}')

    def _compile(self, lines, name):
        namespace = dict(self.consts)
        exec('\n'.join(lines), namespace)    # noqa: S102 -- our own generated source
        return namespace[name]


_U32 = _group_structs([('I', 4)])
