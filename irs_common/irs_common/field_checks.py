"""Checks of parameter dataclasses, written once (ROS-free).

The cores' parameter classes check their numeric fields in ``__post_init__``/``validate`` with
:func:`check_numbers`, so every class refuses the same things with the same wording::

    check_numbers(self, ("gain", "pole"), above=0.0)      # finite and > 0
    check_numbers(self, ("end_margin",), at_least=0.0)     # finite and >= 0
    check_numbers(self, ("x_ref",))                        # finite

A bool is not a number here (``True`` is no gain in 1/s).
"""
from __future__ import annotations

import math
from typing import Iterable, Optional

__all__ = ['check_numbers']


def check_numbers(obj, names: Iterable[str], *, above: Optional[float] = None,
                  at_least: Optional[float] = None) -> None:
    """Raise ``ValueError`` naming the first of ``obj``'s fields ``names`` that is not a finite
    real number, or not ``> above`` / ``>= at_least`` when given.

    The message reads ``"<Class>.<field> must be a finite number > 0, got -1.0."``.
    """
    if above is not None and at_least is not None:
        raise ValueError('check_numbers: give at most one of above and at_least')
    if above is not None:
        bound, ok = f' > {above:g}', (lambda v: v > above)
    elif at_least is not None:
        bound, ok = f' >= {at_least:g}', (lambda v: v >= at_least)
    else:
        bound, ok = '', (lambda v: True)
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or not ok(v):
            raise ValueError(f'{type(obj).__name__}.{name} must be a finite number{bound}, '
                             f'got {v!r}.')
