"""The one error type of the bag library, and the one-line text of any exception.

Every failure to open, read, validate or recover a bag is a :class:`BagError` whose ``str()``
is one line naming the file and what is wrong; :func:`one_line` turns a library exception into
such a line. Every module of :mod:`irs_bag` (and every user of it) takes both from here.
A :class:`BagError` is bad input to a command (``irs_common.cli.InputError``): one that reaches
``run_cli`` is the line ``<prog>: error: <what>`` and exit code 2.
"""

from irs_common.cli import InputError

__all__ = ['BagError', 'one_line']


class BagError(InputError):
    """A bag cannot be opened, read or validated; ``str()`` is a one-line explanation."""


def one_line(exc: BaseException, limit: int = 300) -> str:
    """``Type: text`` of an exception on one line, at most ``limit`` characters."""
    text = ' '.join(str(exc).split())
    name = type(exc).__name__
    out = f'{name}: {text}' if text else name
    return out if len(out) <= limit else out[:limit - 3] + '...'
