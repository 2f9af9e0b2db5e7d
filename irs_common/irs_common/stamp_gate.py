"""The stamp rule every node applies at its edge, with the state it needs (no rclpy).

:class:`StampGate` holds the stamp of the last accepted message of one input (or one step) and
classifies each new stamp against it and against the node's clock ``now`` (integer
nanoseconds), following :func:`irs_common.input_checks.stamp_problem` with one addition, the
*time reset*:

* ``FUTURE``: ``stamp > now + future_tolerance`` -> the message is dropped (no answer, no state
  change) and reported through the node's throttled warner; the stamp is **not** stored, so a
  message stamped a day ahead, or at the largest time, never silences the input.
* ``REPEAT``: ``stamp == last`` -> the same step again (lock-step resend): the node answers with
  the answer it already gave, its state untouched.
* ``OLD``: ``last - reset_after < stamp < last`` -> out of order: dropped, reported.
* ``RESET``: ``stamp <= last - reset_after`` (default 1 s back) -> time went back (a replay
  loop, a restarted publisher, a restarted rig): the node resets its time state (stamps,
  histories, controller state, stale timers) and **accepts** the message; the stamp is stored.
* ``OK``: newer than the last one -> accepted, the stamp is stored.

A rig also ages each command by the sample it answers (:func:`answer_age`).

``now=None`` skips the future check. The fast path (``OK``) is a few integer comparisons: the
gate runs on every message of the 1 kHz loops. :meth:`reason` builds the sentence for a log
line only when one is printed.
"""
from .input_checks import DEFAULT_FUTURE_TOLERANCE_NS

__all__ = ['StampGate', 'OK', 'REPEAT', 'FUTURE', 'OLD', 'RESET', 'DEFAULT_TIME_RESET_NS',
           'answer_age']

OK = 'ok'
REPEAT = 'repeat'
FUTURE = 'future'
OLD = 'old'
RESET = 'reset'

#: A stamp this far [ns] behind the last accepted one is a time reset, not an out-of-order one.
DEFAULT_TIME_RESET_NS = 1_000_000_000


class StampGate:
    """Stamp rule of one input (module docstring)."""

    __slots__ = ('future_tolerance_ns', 'reset_after_ns', 'last_ns')

    def __init__(self, future_tolerance_ns: int = DEFAULT_FUTURE_TOLERANCE_NS,
                 reset_after_ns: int = DEFAULT_TIME_RESET_NS):
        if future_tolerance_ns < 0 or reset_after_ns <= 0:
            raise ValueError(f'future_tolerance_ns must be >= 0 and reset_after_ns > 0; got '
                             f'{future_tolerance_ns!r}, {reset_after_ns!r}')
        self.future_tolerance_ns = int(future_tolerance_ns)
        self.reset_after_ns = int(reset_after_ns)
        self.last_ns = None

    def check(self, stamp_ns: int, now_ns) -> str:
        """Classify ``stamp_ns``; stores it for ``OK`` and ``RESET`` (see the module docstring)."""
        if now_ns is not None and stamp_ns - now_ns > self.future_tolerance_ns:
            return FUTURE
        last = self.last_ns
        if last is not None and stamp_ns <= last:
            if stamp_ns == last:
                return REPEAT
            if last - stamp_ns < self.reset_after_ns:
                return OLD
            self.last_ns = stamp_ns
            return RESET
        self.last_ns = stamp_ns
        return OK

    def take_step(self, stamp_ns: int, now_ns, answer, drop, reset) -> bool:
        """The lock-step rule of a node that answers each step: whether to compute this one.

        ``OK`` -> ``True``. ``REPEAT`` -> ``answer.repeat()`` (the answer cache,
        :mod:`irs_common.answer_cache`, publishes the answer already given), ``False``.
        ``FUTURE``/``OLD`` -> ``drop(verdict, stamp_ns, now_ns)`` (count, warn), ``False``.
        ``RESET`` -> ``reset(verdict, stamp_ns, now_ns)`` (the node resets its time state, which
        may clear this gate: the new stamp is kept all the same), ``True``.
        """
        verdict = self.check(stamp_ns, now_ns)
        if verdict == OK:
            return True
        if verdict == REPEAT:
            answer.repeat()
            return False
        if verdict != RESET:
            drop(verdict, stamp_ns, now_ns)
            return False
        last = self.last_ns
        reset(verdict, stamp_ns, now_ns)
        self.last_ns = last
        return True

    def admit(self, stamp_ns: int, now_ns, pairing: bool = True):
        """Whether an input message stamped ``stamp_ns`` may join a stamp pairing of steps
        (:mod:`irs_common.stamp_sync`): ``FUTURE`` or, with ``pairing``, ``OLD`` (older than
        the last step taken, yet not a time reset: it can never make a step, and the pairing's
        pending sets must not grow without bound) to drop; ``None`` to admit. Stores nothing:
        the gate classifies the steps, with :meth:`check`, not their inputs.
        """
        if now_ns is not None and stamp_ns - now_ns > self.future_tolerance_ns:
            return FUTURE
        last = self.last_ns
        if pairing and last is not None and last - self.reset_after_ns < stamp_ns < last:
            return OLD
        return None

    def clear(self) -> None:
        """Forget the last stamp (time reset from elsewhere, e.g. ``/clock`` jumping back)."""
        self.last_ns = None

    def reason(self, verdict: str, stamp_ns: int, now_ns) -> str:
        """One sentence for a log line or a status message about ``verdict``."""
        s = stamp_ns * 1e-9
        if verdict == FUTURE:
            return (f'stamp {s:.9f} s is {(stamp_ns - now_ns) * 1e-9:.3f} s ahead of the clock '
                    f'({now_ns * 1e-9:.9f} s; tolerance {self.future_tolerance_ns * 1e-9:.3f} s):'
                    ' message dropped')
        last = 'none' if self.last_ns is None else f'{self.last_ns * 1e-9:.9f} s'
        if verdict == OLD:
            return (f'stamp {s:.9f} s is older than the last accepted one ({last}): '
                    'out of order, dropped')
        if verdict == RESET:
            return (f'stamp {s:.9f} s is more than {self.reset_after_ns * 1e-9:.3g} s older than '
                    'the last accepted one: time went back, state reset')
        if verdict == REPEAT:
            return f'stamp {s:.9f} s repeats the last one: answered again'
        return ''


def answer_age(stamp_ns: int, first_ns: int, now_ns: int) -> float:
    """Age [s] of the rig sample a command answers: ``(now_ns - stamp_ns) / 1e9`` for a stamp
    the rig gave out (from its first sample ``first_ns`` up to its current one ``now_ns``), else
    0 (a stamp before the run, e.g. ``ros2 topic pub``'s 0, or one ahead of the rig's time).

    Commands answer the rig's samples with their stamps. A rig that judges a command by this
    age, rather than by its arrival, sees a graph that falls behind (a process short of CPU
    answering a queue of old samples) as late as a silent one.
    """
    if stamp_ns < first_ns or stamp_ns >= now_ns:
        return 0.0
    return (now_ns - stamp_ns) * 1e-9
