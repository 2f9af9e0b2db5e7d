"""Input checks for the edges of the nodes: pure functions, no rclpy, no state but the warner.

Every node checks what it receives before a core sees it, with the same rules and the same
wording, so a log or a status message says the same thing whichever node found the problem.

Values (:func:`finite_problem`, :func:`range_problem`)
    A value is *usable* when it is a real number (``int``, ``float``, numpy scalars; not ``bool``),
    finite (not NaN, not +-inf) and, for a range check, ``low <= value <= high`` (inclusive, in
    the value's unit). Each check returns ``None`` or one sentence naming the input, its value and
    the expected range. ``1e308`` passes the finite check: every physical input also gets a range
    check with a documented physical bound (e.g. ``|y| <= 2 m`` on the 4 x 8 ft belt).
Stamps (:func:`stamp_problem`), integer nanoseconds against the node's clock and the last stamp
    ``FUTURE`` (rejected, never stored), ``REPEAT`` (lock-step resend: the same answer again),
    ``OLD`` (out of order: rejected) or ``OK``.
Throttled warnings (:class:`ThrottledWarner`)
    Logs at most one message per ``key`` every ``period`` seconds of the caller's clock and counts
    the suppressed ones, so a 1 kHz stream of bad data gives one line per second that says how
    many were dropped (the node passes its logger's ``warning`` as ``log``).
"""
from __future__ import annotations

import enum
import math
import numbers
from dataclasses import dataclass, field
from typing import Callable, Optional, Tuple

__all__ = ['StampVerdict', 'finite_problem', 'range_problem', 'abs_limit_problem',
           'stamp_problem', 'ThrottledWarner', 'DEFAULT_FUTURE_TOLERANCE_NS']

#: Default tolerance for stamps ahead of the receiving node's clock [ns] (0.5 s): generous for
#: clock offsets between processes on one machine, far below a stale timeout's consequences.
DEFAULT_FUTURE_TOLERANCE_NS = 500_000_000


def _is_real(value) -> bool:
    # A float answers before the abstract-class check (most of this function's cost).
    return type(value) is float or (isinstance(value, numbers.Real)
                                    and not isinstance(value, bool))


def finite_problem(name: str, value) -> Optional[str]:
    """``None`` if ``value`` is a finite real number, else a sentence naming ``name``."""
    if type(value) is float and math.isfinite(value):   # the common case, answered first
        return None
    if not _is_real(value):
        return f'{name} is not a number ({value!r})'
    if not math.isfinite(value):
        return f'{name} is not finite ({value!r})'
    return None


def range_problem(name: str, value, low: float, high: float, unit: str = '') -> Optional[str]:
    """``None`` if ``value`` is finite and ``low <= value <= high``, else a sentence.

    ``low``/``high`` may be +-inf (one-sided range). ``unit`` is appended to the numbers in the
    message (e.g. ``'m'``).
    """
    if type(value) is float and low <= value <= high and math.isfinite(value):   # common case
        return None
    problem = finite_problem(name, value)
    if problem is not None:
        return problem
    if not low <= value <= high:
        u = f' {unit}' if unit else ''
        return f'{name} = {value:.6g}{u} is outside [{low:.6g}, {high:.6g}]{u}'
    return None


def abs_limit_problem(name: str, value, limit: float, unit: str = '') -> Optional[str]:
    """Symmetric bound ``|value| <= limit``, as ``range_problem(name, value, -limit, limit)``."""
    if type(value) is float and -limit <= value <= limit and math.isfinite(value):   # common
        return None
    return range_problem(name, value, -limit, limit, unit)


class StampVerdict(str, enum.Enum):
    """Outcome of :func:`stamp_problem`: ``'ok'``, ``'future'``, ``'repeat'`` or ``'old'``."""

    OK = 'ok'
    FUTURE = 'future'
    REPEAT = 'repeat'
    OLD = 'old'


def stamp_problem(stamp_ns: int, now_ns: Optional[int], future_tolerance_ns: int,
                  last_ns: Optional[int]) -> Tuple[StampVerdict, Optional[str]]:
    """Classify a message stamp: ``FUTURE``, ``REPEAT``, ``OLD`` or ``OK``.

    The rule, all in integer nanoseconds. With ``now_ns`` the receiving node's clock,
    ``last_ns`` the stamp of the last *accepted* message on that input (``None`` before the
    first) and ``future_tolerance_ns >= 0``:

    * ``stamp_ns > now_ns + future_tolerance_ns`` -> ``FUTURE``: rejected and reported; the stamp
      must **not** be stored as ``last_ns`` (otherwise one reading stamped a day ahead, or at the
      largest representable time, makes every later genuine reading look old). Checked first.
    * ``stamp_ns == last_ns`` -> ``REPEAT``: the same step again (lock-step resend); a node answers
      it with the answer it already gave, its state untouched.
    * ``stamp_ns < last_ns`` -> ``OLD``: out of order; rejected and reported, not stored.
    * otherwise ``OK``: the caller processes the message and stores ``stamp_ns`` as ``last_ns``.

    ``now_ns=None`` skips the future check (e.g. replay without a clock). Negative stamps are
    ``OLD`` only relative to ``last_ns``; the checker has no opinion on the epoch.

    Parameters
    ----------
    stamp_ns : int
        The message's header stamp [ns].
    now_ns : int or None
        The receiving node's clock [ns] (sim time in lock-step); None: no future check.
    future_tolerance_ns : int
        How far ahead of ``now_ns`` a stamp may be [ns] (>= 0).
    last_ns : int or None
        Stamp of the last accepted message on this input [ns]; None before the first.

    Returns
    -------
    (StampVerdict, str or None)
        The verdict and, unless ``OK``, a sentence saying why (with the stamps in seconds).

    Raises
    ------
    ValueError
        ``future_tolerance_ns`` negative (a programming error, not a data error).
    """
    if future_tolerance_ns < 0:
        raise ValueError(f'future_tolerance_ns must be >= 0 ns, got {future_tolerance_ns!r}')
    stamp_ns = int(stamp_ns)
    if now_ns is not None and stamp_ns - int(now_ns) > future_tolerance_ns:
        return StampVerdict.FUTURE, (
            f'stamp {stamp_ns * 1e-9:.9f} s is {(stamp_ns - int(now_ns)) * 1e-9:.3f} s ahead of '
            f'the clock ({int(now_ns) * 1e-9:.9f} s; tolerance {future_tolerance_ns * 1e-9:.3f} s)'
        )
    if last_ns is not None:
        if stamp_ns == int(last_ns):
            return StampVerdict.REPEAT, f'stamp {stamp_ns * 1e-9:.9f} s repeats the last one'
        if stamp_ns < int(last_ns):
            return StampVerdict.OLD, (f'stamp {stamp_ns * 1e-9:.9f} s is older than the last '
                                      f'accepted one ({int(last_ns) * 1e-9:.9f} s)')
    return StampVerdict.OK, None


@dataclass
class ThrottledWarner:
    """At most one warning per ``key`` per ``period`` [s]; counts what it suppressed.

    ``warn(key, text, now)`` calls ``log(text)`` (with `` (N more suppressed)`` appended when
    messages were dropped since the last one) if ``key`` was not logged within ``period`` s
    before ``now`` [s], and returns True when it logged. ``once``/``end`` report a persisting
    condition once per episode instead of once a ``period``. ``now`` is the caller's clock (sim or
    wall time); a clock that jumps back logs again at once.
    """

    log: Callable[[str], object]
    period: float = 1.0
    _last: dict = field(default_factory=dict)
    _suppressed: dict = field(default_factory=dict)
    _episodes: dict = field(default_factory=dict)
    _settling: dict = field(default_factory=dict)

    def warn(self, key: str, text: str, now: float) -> bool:
        last = self._last.get(key)
        if last is not None and 0.0 <= now - last < self.period:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return False
        n = self._suppressed.pop(key, 0)
        self._last[key] = now
        self.log(text + (f' ({n} more suppressed)' if n else ''))
        return True

    def suppressed(self, key: str) -> int:
        """Messages for ``key`` dropped since it was last logged."""
        return self._suppressed.get(key, 0)

    def once(self, key: str, text: str, now: float) -> bool:
        """Log ``text`` at the start of an *episode* of ``key`` only (a condition that persists,
        such as every reading rejected while the car is off the belt), counting the later
        calls until :meth:`end` closes it; episodes that start more often than once a
        ``period`` (a condition that flaps) are throttled as :meth:`warn`. True when it logged.
        """
        self._settling.pop(key, None)
        if key in self._episodes:
            self._episodes[key] += 1
            return False
        self._episodes[key] = 0
        return self.warn(key, f'{text} (reported once while it lasts)', now)

    def end(self, key: str, log_end: Callable[[str], object], text: str, now: float) -> bool:
        """Close the episode of ``key`` if one is open: ``log_end(text)`` with the episode's
        count, throttled like :meth:`warn`. True when it logged.
        """
        n = self._episodes.pop(key, None)
        if n is None:
            return False
        last = self._last.get(key + '/end')
        if last is not None and 0.0 <= now - last < self.period:
            return False
        self._last[key + '/end'] = now
        log_end(f'{text} ({n + 1} in the episode)')
        return True

    def end_settled(self, key: str, log_end: Callable[[str], object], text: str, now: float,
                    settle: float = 1.0) -> bool:
        """Close the episode of ``key`` once the condition has been gone for ``settle`` [s].

        Call it for every good sample while :meth:`in_episode`. The first good sample starts the
        settling time; a :meth:`once` within ``settle`` s (the input stale again) continues the
        episode and counts it, so a flapping input logs one line at the start of the episode
        and one at its end (with the count), not a pair of lines a second. True when it logged.
        """
        if key not in self._episodes:
            return False
        since = self._settling.setdefault(key, now)
        if 0.0 <= now - since < settle:
            return False
        del self._settling[key]
        return self.end(key, log_end, text, now)

    def forget_episodes(self) -> None:
        """Close every open episode without a log line (a reset that restarts the reports)."""
        self._episodes.clear()
        self._settling.clear()

    def in_episode(self, key: str) -> bool:
        return key in self._episodes
