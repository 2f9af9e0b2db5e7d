"""The lines a process printed itself, without Fast DDS's own log lines.

Fast DDS logs some transport problems of its own to the process's output, e.g.
``[RTPS_TRANSPORT_SHM Error] Failed init_port ...`` when a shared-memory port's lock is held by
a process that was killed (it then uses another port, or UDP). Tests that count a command's
lines ("one line naming what is wrong") count the lines the IRS code printed: :func:`own_lines`.
"""
import re

#: Fast DDS's log line: ``<time> [RTPS_<CATEGORY> Error|Warning|Info] ...`` (colour codes around)
_COLOUR = r'(?:\x1b\[[0-9;]*m)*'
_FAST_DDS = re.compile(rf'\[{_COLOUR}RTPS_[A-Z_]+{_COLOUR} (?:Error|Warning|Info)\]')


def own_lines(text: str) -> list[str]:
    """The non-blank lines of ``text`` that are not Fast DDS's log lines."""
    return [ln for ln in text.splitlines() if ln.strip() and not _FAST_DDS.search(ln)]
