"""The floor's verdict on failed exclusive tests (``irs_system_tests.floor_verdict``).

An inner pytest run (``pytester``) loads the plugin with its floor measurement replaced by
fixed results (one per measurement, the last one repeated), and every call of it counted in a
file: what is reported, and when the floor is measured.
"""
import pytest

pytest_plugins = ['pytester']
#: the inner runs need none of the suite's other plugins
LEAN = [arg for name in ('hypothesispytest', 'cov', 'repeat', 'rerunfailures', 'cacheprovider')
        for arg in ('-p', f'no:{name}')]

INNER_CONFTEST = """
from pathlib import Path
import time

import pytest

import irs_system_tests.floor_verdict as verdict

pytest_plugins = ['irs_system_tests.floor_verdict']
CALLS = Path(__file__).parent / 'floor_calls'
MISSES = {misses!r}          # [%] of each measurement in turn, the last one repeated
REAL = pytest.StashKey()


def pytest_configure(config):
    config.addinivalue_line('markers', 'exclusive: real time, alone')
    config.stash[REAL] = verdict.measure_floor, verdict.RECOVERY_WAIT, verdict.RECOVERY_IDLE
    verdict.measure_floor = fake_floor
    verdict.RECOVERY_WAIT, verdict.RECOVERY_IDLE = 0.5, 0.05


def pytest_unconfigure(config):      # the inner run shares the module with the outer one
    verdict.measure_floor, verdict.RECOVERY_WAIT, verdict.RECOVERY_IDLE = config.stash[REAL]


def fake_floor(seconds=verdict.FLOOR_SECONDS):
    calls = len(CALLS.read_text()) if CALLS.exists() else 0
    with open(CALLS, 'a') as f:
        f.write('x')
    miss = MISSES[min(calls, len(MISSES) - 1)]
    if miss is None:
        raise RuntimeError('no DDS')
    time.sleep(0.1)                  # a floor takes time: the recovery wait counts it
    return {{'miss_pct': miss, 'latency_p99_ms': 12.5, 'cpu_per_hop_us': 800.0}}



@pytest.fixture
def broken():
    raise RuntimeError('set-up failed')
"""

INNER_TESTS = """
import pytest


@pytest.mark.exclusive
def test_exclusive_fails():
    assert 1 == 2, 'the car left the belt'


@pytest.mark.exclusive
def test_exclusive_passes():
    pass


@pytest.mark.exclusive
def test_exclusive_setup_fails(broken):
    pass


def test_shared_fails():
    assert 1 == 2, 'a shared test'
"""

#: A test that fails in its first run only (the file it leaves is how it knows).
FLAKY_TEST = """
from pathlib import Path

import pytest

RUNS = Path(__file__).parent / 'runs'


@pytest.fixture
def graph():
    with open(Path(__file__).parent / 'setups', 'a') as f:
        f.write('x')
    return 'graph'


@pytest.mark.exclusive
def test_fails_once(graph):
    first = not RUNS.exists()
    RUNS.write_text('ran')
    assert not first, 'the car left the belt'
"""


def _run(pytester, misses, *args, tests=INNER_TESTS):
    misses = misses if isinstance(misses, list) else [misses]
    pytester.makeconftest(INNER_CONFTEST.format(misses=misses))
    pytester.makepyfile(test_inner=tests)
    # (the conftest imports the plugin before pytest loads it: no assertion rewriting there)
    result = pytester.runpytest('-rsfE', '-W', 'ignore::pytest.PytestAssertRewriteWarning',
                                *LEAN, *args)
    calls = pytester.path / 'floor_calls'
    return result, len(calls.read_text()) if calls.exists() else 0


def test_a_machine_that_misses_the_floor_turns_the_failure_into_a_skip_that_says_why(pytester):
    result, calls = _run(pytester, 92.0)
    result.assert_outcomes(passed=1, failed=1, skipped=1, errors=1)
    # the failed call of the exclusive test, then the wait for the floor to hold (0.5 s of
    # 0.1 s floors, each after 0.05 s idle): nothing else is measured
    assert 3 <= calls <= 6, calls
    result.stdout.fnmatch_lines([
        '*SKIPPED*test_inner.py:*the machine could not run a 1 kHz graph just now: the floor*'
        'missed 92.0 % of its deadlines (p99 12.50 ms, 800 us of CPU per hop), measured right '
        'after this test failed with: AssertionError: the car left the belt; the floor did not '
        'hold 1 kHz again within 0.5 s*'])
    result.stdout.fnmatch_lines(['FAILED test_inner.py::test_shared_fails*'])
    result.stdout.fnmatch_lines(['ERROR test_inner.py::test_exclusive_setup_fails*'])


def test_a_machine_that_holds_the_floor_lets_the_failure_stand_with_its_figures(pytester):
    result, calls = _run(pytester, 0.8)
    result.assert_outcomes(passed=1, failed=2, errors=1)
    assert calls == 1
    result.stdout.fnmatch_lines(['*floor*missed 0.8 % of its deadlines*the machine held 1 kHz, '
                                 'the failure stands*'])


@pytest.mark.parametrize('miss, env', [(None, {}), (92.0, {'IRS_FLOOR_VERDICT': '0'})])
def test_without_a_floor_or_with_the_verdict_off_every_failure_stands(pytester, monkeypatch,
                                                                      miss, env):
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    result, calls = _run(pytester, miss)
    result.assert_outcomes(passed=1, failed=2, errors=1)
    assert calls == (0 if env else 1)
    if miss is None:
        result.stdout.fnmatch_lines(["*the floor could not be measured: RuntimeError('no DDS')*"])


def test_the_inner_runs_leave_the_real_floor_in_place():
    import irs_system_tests.floor_verdict as verdict
    assert verdict.measure_floor.__module__ == 'irs_system_tests.floor_verdict'
    assert (verdict.RECOVERY_WAIT, verdict.RECOVERY_IDLE) == (90.0, 20.0)


def test_the_machine_is_left_idle_before_each_floor_of_the_recovery_wait(monkeypatch):
    import irs_system_tests.floor_verdict as verdict
    events, now = [], [0.0]
    monkeypatch.setattr(verdict.time, 'sleep', lambda s: (events.append(('idle', s)),
                                                          now.__setitem__(0, now[0] + s)))

    def floor():
        now[0] += 5.0
        events.append(('floor', now[0]))
        return {'miss_pct': 50.0 if len(events) < 4 else 1.0}
    held = verdict.wait_for_recovery(floor, 60.0, clock=lambda: now[0], idle=20.0)
    assert held == {'miss_pct': 1.0}
    assert events == [('idle', 20.0), ('floor', 25.0), ('idle', 20.0), ('floor', 50.0)]
    events.clear()
    now[0] = 0.0
    assert verdict.wait_for_recovery(lambda: {'miss_pct': 50.0}, 30.0, clock=lambda: now[0],
                                     idle=20.0) is None
    assert events == [('idle', 20.0), ('idle', 10.0)]


def test_the_skip_crosses_xdist_workers(pytester):
    result, calls = _run(pytester, 92.0, '-p', 'xdist', '-n', '1')
    result.stdout.fnmatch_lines(['*1 worker*'])
    result.assert_outcomes(passed=1, failed=1, skipped=1, errors=1)
    assert calls >= 3


@pytest.mark.parametrize('args', [(), ('-p', 'xdist', '-n', '1')], ids=['alone', 'xdist'])
def test_a_failure_in_a_slow_phase_runs_again_once_the_floor_holds(pytester, args):
    # the floor blames the machine, then holds: the test runs again, from its set-up, and passes
    # with a warning that names its first failure and both floors
    result, calls = _run(pytester, [92.0, 0.5], *args, tests=FLAKY_TEST)
    result.assert_outcomes(passed=1, warnings=1)
    assert calls == 2
    assert (pytester.path / 'setups').read_text() == 'xx'
    result.stdout.fnmatch_lines([
        '*PytestWarning: passed when run again: its first run failed with "AssertionError: the '
        "car left the belt*\" while the floor's 3-process loop at 1 kHz missed 92.0 % of its "
        "deadlines*; before the second run the floor's 3-process loop at 1 kHz missed 0.5 %*"])


@pytest.mark.parametrize('misses, outcome', [([92.0, 0.5, 0.5], 'failed'),
                                             ([92.0, 0.5, 92.0], 'skipped')])
def test_a_second_run_is_judged_like_the_first(pytester, misses, outcome):
    # the inner test fails every time: with the floor holding after it the failure stands;
    # with the floor out again it is a skip that names both runs
    always = FLAKY_TEST.replace('assert not first', 'assert False')
    result, calls = _run(pytester, misses, tests=always)
    result.assert_outcomes(**{outcome: 1})
    assert calls == 3
    assert (pytester.path / 'setups').read_text() == 'xx'
    if outcome == 'skipped':
        result.stdout.fnmatch_lines([
            '*SKIPPED*missed 92.0 %*failed with: AssertionError: the car left the belt*'
            '(its second run; the first failed with "AssertionError: the car left the belt*" '
            "while the floor's*missed 92.0 %*"])
    else:
        result.stdout.fnmatch_lines(['*missed 0.5 %*the machine held 1 kHz, the failure stands*'])
