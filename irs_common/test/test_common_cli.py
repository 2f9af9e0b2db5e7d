"""irs_common.cli: what ends a command is one line and an exit code of the docs/cli.md table."""
import signal
import subprocess
import sys
import textwrap

import pytest

from irs_common.cli import (BUG_HINT, EXIT_BUG, EXIT_CODES, EXIT_FAILED, EXIT_INPUT, InputError,
                            Interrupted, RunFailed, did_you_mean, run_cli)


def _raise(exc):
    def main(_argv):
        raise exc
    return main


@pytest.mark.parametrize('exc,code,line', [
    (InputError('exp.yaml: duration: expected a number'), EXIT_INPUT,
     'prog: error: exp.yaml: duration: expected a number\n'),
    (RunFailed('figure10_pi did not complete: node died'), EXIT_FAILED,
     'prog: error: figure10_pi did not complete: node died\n'),
    (FileNotFoundError(2, 'No such file or directory', 'missing.yaml'), EXIT_INPUT,
     'prog: error: missing.yaml: No such file or directory\n'),
    (Interrupted(signal.SIGTERM), 143, 'prog: interrupted (SIGTERM)\n'),
    (KeyboardInterrupt(), 130, 'prog: interrupted (SIGINT)\n'),
])
def test_known_endings_are_one_line_and_their_code(capsys, exc, code, line):
    assert run_cli('prog', _raise(exc), []) == code
    out, err = capsys.readouterr()
    assert (out, err) == ('', line)
    assert code in EXIT_CODES


@pytest.mark.parametrize('exc', [ZeroDivisionError('division by zero'), KeyError('x'),
                                 ValueError('a bug that raises ValueError'),
                                 AttributeError("'NoneType' object has no attribute 'y'")])
def test_anything_else_is_a_bug_in_one_line_with_the_hint(capsys, exc):
    assert run_cli('prog', _raise(exc), []) == EXIT_BUG
    err = capsys.readouterr().err
    assert err.startswith(f'prog: internal error: {type(exc).__name__}: ')
    assert err.endswith(f'; {BUG_HINT}\n') and err.count('\n') == 1


def test_return_value_and_usage_exit_pass_through(capsys):
    assert run_cli('prog', lambda _a: None, []) == 0
    assert run_cli('prog', lambda _a: 1, []) == 1
    with pytest.raises(SystemExit):
        run_cli('prog', lambda _a: sys.exit(2), [])


def test_a_refused_command_line_is_one_line_with_a_pointer_to_help(capsys):
    import argparse

    def main(argv):
        parser = argparse.ArgumentParser(prog='prog run')
        parser.add_argument('--duration', type=float)
        parser.add_argument('--pace', choices=('log', 'header'))
        parser.parse_args(argv)
    for argv, what in ((['--duration', 'abc'], "argument --duration: invalid float value: 'abc'"),
                       (['--pace', 'foo'], "argument --pace: invalid choice: 'foo'"),
                       (['--bogus'], 'unrecognized arguments: --bogus')):
        with pytest.raises(SystemExit) as info:
            run_cli('prog', main, argv)
        assert info.value.code == EXIT_INPUT
        err = capsys.readouterr().err
        assert err.count('\n') == 1 and err.startswith(f'prog run: error: {what}'), err
        assert err.rstrip().endswith('(prog run --help shows the usage)'), err
    # argparse is itself again after the command
    with pytest.raises(SystemExit):
        argparse.ArgumentParser(prog='plain').parse_args(['--bogus'])
    assert capsys.readouterr().err.startswith('usage: plain')


def test_in_process_call_gives_the_handlers_back():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    run_cli('prog', lambda _a: 0, [])
    assert {s: signal.getsignal(s) for s in before} == before


def test_did_you_mean():
    names = [f'experiment_{i}' for i in range(20)] + ['figure10_pi']
    text = did_you_mean('figure10_pii', names, 'experiment', 'experiment list')
    assert text.startswith("no experiment 'figure10_pii' (did you mean figure10_pi")
    assert text.endswith('; 21 installed (experiment list lists them)')
    assert did_you_mean('x', ['a', 'b'], 'sweep') == "no sweep 'x'; installed: a, b"


SCRIPT = textwrap.dedent("""
    import os, signal, sys, time
    from irs_common.cli import run_cli, current_guard

    def main(argv):
        guard = current_guard()
        guard.force_hooks.append(lambda: print('hook ran', flush=True))
        try:
            print('ready', flush=True)
            while True:
                time.sleep(0.01)
        finally:
            print('cleaning up', flush=True)
            while True:              # a clean-up that never ends: only a second signal helps
                time.sleep(0.01)

    sys.exit(run_cli('prog', main))
""")


def test_a_second_signal_during_clean_up_leaves_at_once(tmp_path):
    proc = subprocess.Popen([sys.executable, '-c', SCRIPT], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == 'ready\n'
    proc.send_signal(signal.SIGINT)
    assert proc.stdout.readline() == 'cleaning up\n'
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 128 + signal.SIGTERM
    assert out == 'hook ran\n' and 'SIGTERM again: stopped at once' in err
    assert 'Traceback' not in err


def test_a_signal_during_a_held_block_is_delivered_after_it():
    """The recorder creates its bag inside ``held_signals()``: a SIGINT landing in the middle
    must not cut the creation (the writer would be lost, the bag left unclosed, no closing
    line); it is acted on right after, as an :class:`Interrupted` the caller's clean-up sees.
    """
    from irs_common import cli
    guard = cli.SignalGuard()
    with pytest.raises(cli.Interrupted):          # outside a held block: raised at once
        guard._handle(signal.SIGINT, None)
    guard = cli.SignalGuard()
    cli.GUARD, before = guard, cli.GUARD
    try:
        steps = []
        with cli.held_signals() as held:
            steps.append('file created')
            guard._handle(signal.SIGINT, None)    # not raised here
            steps.append('handle kept')
        assert steps == ['file created', 'handle kept']
        with pytest.raises(cli.Interrupted):
            held.deliver()
        assert guard.on_first is None            # the guard's own handling is back
        with cli.held_signals() as quiet:        # no new signal in this block: nothing to do
            pass
        quiet.deliver()
        stops = []
        guard2 = cli.SignalGuard()
        guard2.on_first = stops.append           # a running executor's stop hook
        cli.GUARD = guard2
        with cli.held_signals() as held:
            guard2._handle(signal.SIGTERM, None)
        assert stops == []
        held.deliver()
        assert stops == [signal.SIGTERM]
    finally:
        cli.GUARD = before


def test_help_text_is_plain_text_of_the_docstring():
    from irs_common.cli import describe, plain_text
    doc = ('``sweep``: runs :class:`~irs_studies.sweep.Sweep` over\n:mod:`.rig` and '
           ':func:`a.b`.\n\nUsage::\n\n    sweep x\n')
    assert describe(doc) == 'sweep: runs Sweep over rig and a.b.'
    assert plain_text(doc).splitlines()[3] == 'Usage:'
    assert describe('') == ''
