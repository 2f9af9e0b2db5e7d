"""``irs_bag.player.Interrupt`` under a command's signal guard: a signal the guard has already
taken counts, even when the guard's ``Interrupted`` never reached the command.

Python ignores an exception raised while it runs a weakref callback or a ``__del__`` (it prints
"Exception ignored in ..."); a signal handler that raises there loses the signal. The suite saw
it once: SIGINT at ``bag play --loop``'s start-up raised inside the import system's module-lock
callback, and the player then looped until killed.
"""
import signal

from irs_bag.player import Interrupt
from irs_common import cli


def test_a_signal_the_guard_took_before_the_flag_existed_sets_it(monkeypatch):
    guard = cli.SignalGuard()
    monkeypatch.setattr(cli, 'GUARD', guard)
    guard.signum = signal.SIGINT            # taken; its Interrupted went nowhere
    flag = Interrupt()
    assert flag and flag.exit_code == 130


def test_without_an_earlier_signal_the_flag_waits_for_one(monkeypatch):
    guard = cli.SignalGuard()
    monkeypatch.setattr(cli, 'GUARD', guard)
    flag = Interrupt()
    assert not flag
    guard.on_first(signal.SIGTERM)          # what the guard's handler calls on a first signal
    assert flag and flag.exit_code == 143
