"""What every IRS command shares: exit codes, one-line errors, signals (no rclpy, no heavy import).

:func:`run_cli` is the top level of every console script: ``main = lambda argv=None:
run_cli('sweep', _main, argv)``. It installs :class:`SignalGuard` first, runs the command and turns
whatever ends it into one line on stderr, ``<prog>: error: <what>``, and an exit code of
:data:`EXIT_CODES` (the table of docs/cli.md):

* :class:`InputError` (a bad file, argument, bag; the message names it): exit 2;
* a command line ``argparse`` refuses (an unknown option, ``--duration abc``): its message on
  one line with a pointer to ``--help``, not the usage block, exit 2;
* :class:`RunFailed` (a run the command needs did not complete): exit 1;
* ``OSError`` (a file that cannot be read or written, a refused connection): exit 2;
* SIGINT, SIGTERM, SIGHUP: the command's clean-up runs, then exit 128 + the signal number;
* anything else is a bug: ``<prog>: internal error: <type>: <message>`` with a request to report
  it (:data:`BUG_HINT`), exit 70 (``IRS_TRACEBACK=1`` prints the traceback as well).

Signals: the first SIGINT/SIGTERM/SIGHUP raises :class:`Interrupted` in the main thread (or calls
the command's own stop hook, :meth:`SignalGuard.on_first`); a second one, while the command
cleans up, runs the guard's force-exit hooks (e.g. SIGKILL to the node processes) and ends the
process at once with ``os._exit(128 + signum)``.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys
import traceback

EXIT_OK = 0           # done
EXIT_FAILED = 1       # ran to its end, but the result is a failure (a run did not complete, ...)
EXIT_INPUT = 2        # bad input: usage, file, parameter, bag, or the system refused a file/peer
EXIT_BUG = 70         # internal error (EX_SOFTWARE): a bug, reported with BUG_HINT
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: exit code -> meaning (docs/cli.md renders this table).
EXIT_CODES = {
    EXIT_OK: 'done',
    EXIT_FAILED: 'ran, but the result is a failure (a run did not complete, a part failed)',
    EXIT_INPUT: 'bad input: usage, file, parameter, bag, output path, unreachable peer; '
                'one line says what',
    EXIT_BUG: 'internal error: a bug; the line asks for a report',
    128 + signal.SIGHUP: 'stopped by SIGHUP',
    128 + signal.SIGINT: 'stopped by SIGINT (Ctrl-C)',
    128 + signal.SIGTERM: 'stopped by SIGTERM',
}

BUG_HINT = ('this is a bug in IRS: please report it with the command line and this message '
            '(IRS_TRACEBACK=1 prints the traceback)')


class InputError(ValueError):
    """What the user gave (file, argument, bag, output path) is wrong; the message, one line,
    says what and where. Every command's own error class derives from it.
    """


class RunFailed(RuntimeError):
    """A run the command needs did not complete (a node died, the car left the belt); the
    message says which and why. Exit code 1.
    """


class Interrupted(KeyboardInterrupt):
    """A signal asked the command to stop (``signum``); exit code ``128 + signum``."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


def one_line(text) -> str:
    """``text`` (an exception or a string) on one line, whitespace collapsed."""
    return ' '.join(str(text).split())


def os_error_text(exc: OSError) -> str:
    """An ``OSError`` as a sentence: ``<file>: <strerror>`` where both are known."""
    what = exc.strerror or one_line(exc) or type(exc).__name__
    name = exc.filename if exc.filename is not None else None
    return f'{name}: {what}' if name else one_line(exc) or what


class SignalGuard:
    """SIGINT/SIGTERM/SIGHUP handling of a command (module docstring).

    ``on_first(signum)``, when set, is called on the first signal instead of raising
    :class:`Interrupted` (a command with its own polling loop, e.g. the experiment runner, sets a
    flag there and stops at its next check). ``force_hooks`` run on a second signal before the
    process exits.
    """

    def __init__(self):
        self.signum = None            # the first signal received
        self.on_first = None
        self.force_hooks = []
        self.ending = False           # the command has returned: any signal leaves at once
        self._old = {}

    def install(self) -> 'SignalGuard':
        import threading
        if threading.current_thread() is threading.main_thread():
            self._old = {sig: signal.signal(sig, self._handle) for sig in SIGNALS}
        return self

    def restore(self):
        for sig, handler in self._old.items():
            signal.signal(sig, handler)
        self._old = {}

    def _handle(self, signum, _frame):
        if self.signum is not None or self.ending:
            self.force_exit(signum)
        self.signum = signum
        if self.on_first is not None:
            self.on_first(signum)
            return
        raise Interrupted(signum)

    def held(self) -> 'HeldSignals':
        """A ``with`` block that a first signal does not cut: the signal is noted and
        :meth:`HeldSignals.deliver` acts on it afterwards (raises :class:`Interrupted`, or calls
        ``on_first``). For a step whose result must be kept to be cleaned up: a file created and
        its handle returned.
        """
        return HeldSignals(self)

    def force_exit(self, signum):
        """A second signal: run the hooks, leave at once (no clean-up, no traceback)."""
        for hook in list(self.force_hooks):
            try:
                hook()
            except Exception:  # noqa: BLE001 -- leaving anyway
                pass
        try:
            sys.stderr.write(f'{os.path.basename(sys.argv[0] or "irs")}: '
                             f'{signal.Signals(signum).name} again: stopped at once\n')
            sys.stderr.flush()
        except Exception:  # noqa: BLE001
            pass
        os._exit(128 + signum)


class HeldSignals:
    """:meth:`SignalGuard.held`: hold a first signal for a ``with`` block."""

    def __init__(self, guard: SignalGuard | None):
        self.guard = guard
        self._before = None
        self._previous = None

    def __enter__(self) -> 'HeldSignals':
        if self.guard is not None:
            self._before = self.guard.signum
            self._previous = self.guard.on_first
            self.guard.on_first = _note_only
        return self

    def __exit__(self, *exc) -> None:
        if self.guard is not None:
            self.guard.on_first = self._previous

    def deliver(self) -> None:
        """Act on a signal that came during the block, as it would have acted then."""
        guard = self.guard
        if guard is None or guard.signum is None or guard.signum == self._before:
            return
        if self._previous is not None:
            self._previous(guard.signum)
        else:
            raise Interrupted(guard.signum)


def _note_only(_signum) -> None:
    """``on_first`` inside :meth:`SignalGuard.held`: the guard has noted the signal."""


def held_signals() -> HeldSignals:
    """:meth:`SignalGuard.held` of the running command's guard (a no-op without one)."""
    return HeldSignals(GUARD)


#: The guard of the running command (set by :func:`run_cli` and ``run_nodes``); None outside a
#: command.
GUARD: SignalGuard | None = None


def current_guard() -> SignalGuard | None:
    return GUARD


def error(prog: str, text) -> None:
    """Print ``<prog>: error: <text>`` (one line) on stderr."""
    print(f'{prog}: error: {one_line(text)}', file=sys.stderr, flush=True)


def warning(prog: str, text) -> None:
    """Print ``<prog>: warning: <text>`` (one line) on stderr."""
    print(f'{prog}: warning: {one_line(text)}', file=sys.stderr, flush=True)


@contextlib.contextmanager
def _one_line_usage_errors():
    """While a command runs, ``argparse``'s refusals are one line (``<prog>: error: <message>
    (<prog> --help shows the usage)``, exit 2) instead of the usage block and the message. The
    parsers are built inside each command (27 of them, subcommand parsers among them), so the
    method is swapped here, at the one top level, and put back after.
    """
    original = argparse.ArgumentParser.error

    def error(parser, message):
        parser.exit(EXIT_INPUT, f'{parser.prog}: error: {one_line(message)} '
                                f'({parser.prog} --help shows the usage)\n')
    argparse.ArgumentParser.error = error
    try:
        yield
    finally:
        argparse.ArgumentParser.error = original


def run_cli(prog: str, main, argv=None) -> int:
    """Run ``main(argv)`` as the command ``prog``; its exit code (module docstring).

    ``argv`` None (the console script: ``sys.argv``): the guard stays installed to the end of
    the process; given (called in-process): the previous handlers are restored on return.
    """
    global GUARD
    guard = GUARD = SignalGuard()
    try:
        guard.install()     # inside the try: a signal between two handlers' installation too
        with _one_line_usage_errors():
            code = main(argv)
        if guard.signum is not None:     # stopped through on_first: the command returned
            return 128 + guard.signum
        return EXIT_OK if code is None else int(code)
    except Interrupted as exc:
        print(f'{prog}: interrupted ({signal.Signals(exc.signum).name})', file=sys.stderr,
              flush=True)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f'{prog}: interrupted (SIGINT)', file=sys.stderr, flush=True)
        return 128 + signal.SIGINT
    except InputError as exc:
        error(prog, exc)
        return EXIT_INPUT
    except RunFailed as exc:
        error(prog, exc)
        return EXIT_FAILED
    except BrokenPipeError:
        # the reader of stdout left (``experiment list | head``): no more output, no message
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILED
    except OSError as exc:
        error(prog, os_error_text(exc))
        return EXIT_INPUT
    except SystemExit:
        raise
    except BaseException as exc:  # noqa: BLE001 -- the catch-all: anything else is a bug
        if os.environ.get('IRS_TRACEBACK'):
            traceback.print_exc()
        print(f'{prog}: internal error: {type(exc).__name__}: {one_line(exc)[:300]}; {BUG_HINT}',
              file=sys.stderr, flush=True)
        return EXIT_BUG
    finally:
        guard.on_first = None
        if GUARD is guard:
            GUARD = None
        if argv is None:
            guard.ending = True     # the process's main: a signal from here on leaves at once
        else:
            guard.restore()         # called in-process (tests, other commands)


def did_you_mean(name: str, names, what: str, listing: str = '') -> str:
    """``no <what> '<name>' (did you mean X?); installed: ...`` as one sentence: the names if
    there are at most 8, else their number and ``listing`` (the command that lists them).
    """
    import difflib
    names = sorted(names)
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
    if close:   # only the near-best: a shared prefix alone does not make a suggestion
        best = difflib.SequenceMatcher(None, name, close[0]).ratio()
        close = [c for c in close if difflib.SequenceMatcher(None, name, c).ratio() > best - 0.1]
    hint = f" (did you mean {' or '.join(close)}?)" if close else ''
    if len(names) <= 8:
        known = f"installed: {', '.join(names) or 'none'}"
    else:
        known = f'{len(names)} installed' + (f' ({listing} lists them)' if listing else '')
    return f"no {what} '{name}'{hint}; {known}"


def plain_text(rst: str) -> str:
    """reStructuredText of a docstring as a terminal shows it: inline literals lose their
    double backquotes; a role's target stays (``:mod:`~a.b``` and ``:class:`.b``` give ``b``,
    ``:func:`a.b``` gives ``a.b``); a line ending in a double colon ends in one; line breaks are
    kept.
    """
    def role(match):
        target = match.group(1)
        if target.startswith('~'):
            return target.rsplit('.', 1)[-1]
        return target.lstrip('.')
    text = re.sub(r':[a-z]+:`([^`]+)`', role, rst)
    text = text.replace('``', '')
    return re.sub(r'::$', ':', text, flags=re.M)


def describe(doc: str) -> str:
    """A command's ``--help`` description: the first paragraph of its module docstring, on one
    line, in plain text (:func:`plain_text`).
    """
    return plain_text(' '.join((doc or '').strip().split('\n\n')[0].split()))
