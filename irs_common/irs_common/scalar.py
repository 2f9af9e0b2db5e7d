"""Scalar helpers that give numpy's results on Python floats, at a fraction of the call cost.

A per-step control law on plain floats avoids numpy's call overhead (several microseconds per
``np.clip`` of a scalar) but must give the bits numpy gave, so that a core's results do not
change. No rclpy.
"""
from __future__ import annotations

__all__ = ['clip']


def clip(x: float, lo: float, hi: float) -> float:
    """``float(np.clip(x, lo, hi))`` for floats, to the bit: ``min(max(x, lo), hi)`` with
    numpy's ``maximum``/``minimum`` rules (a NaN operand gives NaN; between equal values,
    ``0.0`` and ``-0.0`` included, the first operand). ``irs_common/test/test_scalar.py``
    compares it with ``np.clip`` on special and random values.
    """
    if x != x:
        return x
    if lo != lo:
        return lo
    m = x if x >= lo else lo
    if hi != hi:
        return hi
    return m if m <= hi else hi
