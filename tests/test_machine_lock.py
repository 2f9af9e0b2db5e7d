"""The machine lock of parallel test runs (the repository's root ``conftest.py``).

Probed with non-blocking ``flock`` calls from other open files, so every check is immediate.
"""
import fcntl
import importlib.util
from pathlib import Path
import threading
import time

import pytest

_spec = importlib.util.spec_from_file_location(
    'irs_root_conftest', Path(__file__).resolve().parents[1] / 'conftest.py')
root_conftest = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(root_conftest)


def _can_take(path: Path, mode: int) -> bool:
    """Whether another holder could take ``mode`` on ``path`` now (taken and released at once)."""
    with open(path, 'a') as f:
        try:
            fcntl.flock(f, mode | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        fcntl.flock(f, fcntl.LOCK_UN)
        return True


@pytest.mark.parametrize('exclusive', [False, True])
def test_shared_tests_run_together_and_an_exclusive_one_alone(tmp_path, exclusive):
    lock = tmp_path / 'irs_test_machine_run1.lock'
    gate = tmp_path / 'irs_test_machine_run1.turnstile'
    with root_conftest.machine_lock('run1', exclusive, lock_dir=str(tmp_path)):
        assert _can_take(lock, fcntl.LOCK_SH) is not exclusive
        assert not _can_take(lock, fcntl.LOCK_EX)
        assert _can_take(gate, fcntl.LOCK_EX), 'the turnstile is let go once the lock is held'
        assert _can_take(tmp_path / 'irs_test_machine_run2.lock', fcntl.LOCK_EX), \
            'another test run has a lock of its own'
    assert _can_take(lock, fcntl.LOCK_EX), 'released after the body'


def test_a_failing_test_releases_the_lock(tmp_path):
    with pytest.raises(AssertionError):
        with root_conftest.machine_lock('run1', True, lock_dir=str(tmp_path)):
            raise AssertionError('the test failed')
    assert _can_take(tmp_path / 'irs_test_machine_run1.lock', fcntl.LOCK_EX)


def test_a_waiting_exclusive_test_holds_the_turnstile_against_new_shared_ones(tmp_path):
    """While a writer waits for the lock it holds the turnstile, which every shared taker passes
    first: a new shared test queues behind the writer instead of overtaking it.
    """
    lock = tmp_path / 'irs_test_machine_run1.lock'
    gate = tmp_path / 'irs_test_machine_run1.turnstile'
    entered = threading.Event()
    with root_conftest.machine_lock('run1', False, lock_dir=str(tmp_path)):
        writer = threading.Thread(target=lambda: _enter_exclusive(tmp_path, entered))
        writer.start()
        # the writer takes the turnstile, then blocks on the lock we hold in shared mode
        deadline = time.monotonic() + 10.0
        while _can_take(gate, fcntl.LOCK_EX):
            assert writer.is_alive() and time.monotonic() < deadline
        assert not entered.is_set()
    writer.join(10.0)
    assert entered.is_set() and not writer.is_alive()
    assert _can_take(lock, fcntl.LOCK_EX) and _can_take(gate, fcntl.LOCK_EX)


def _enter_exclusive(tmp_path, entered):
    with root_conftest.machine_lock('run1', True, lock_dir=str(tmp_path)):
        entered.set()


def test_a_run_of_exclusive_tests_keeps_the_lock_until_a_shared_test_follows(tmp_path):
    lock = tmp_path / 'irs_test_machine_run1.lock'
    turn = root_conftest.MachineTurn('run1', lock_dir=str(tmp_path))
    # two exclusive tests in a row: the lock is not let go between them
    with turn.test(exclusive=True, next_exclusive=True):
        assert not _can_take(lock, fcntl.LOCK_SH)
    assert turn.holding and not _can_take(lock, fcntl.LOCK_SH), 'kept for the next one'
    with turn.test(exclusive=True, next_exclusive=False):
        assert not _can_take(lock, fcntl.LOCK_SH)
    assert not turn.holding and _can_take(lock, fcntl.LOCK_EX), 'let go before a shared test'
    with turn.test(exclusive=False, next_exclusive=True):
        assert _can_take(lock, fcntl.LOCK_SH) and not _can_take(lock, fcntl.LOCK_EX)
    assert _can_take(lock, fcntl.LOCK_EX)


def test_a_failing_exclusive_test_before_a_shared_one_lets_the_lock_go(tmp_path):
    turn = root_conftest.MachineTurn('run1', lock_dir=str(tmp_path))
    with pytest.raises(AssertionError):
        with turn.test(exclusive=True, next_exclusive=False):
            raise AssertionError('the test failed')
    assert not turn.holding
    assert _can_take(tmp_path / 'irs_test_machine_run1.lock', fcntl.LOCK_EX)
