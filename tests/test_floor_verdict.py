"""The floor's verdict on failed exclusive tests (``irs_system_tests.floor_verdict``).

An inner pytest run (``pytester``) loads the plugin with its floor measurement replaced by a
fixed result, and every call of it counted in a file: what is reported, and when the floor is
measured.
"""
import pytest

pytest_plugins = ['pytester']
#: the inner runs need none of the suite's other plugins
LEAN = [arg for name in ('hypothesispytest', 'cov', 'repeat', 'rerunfailures', 'cacheprovider')
        for arg in ('-p', f'no:{name}')]

INNER_CONFTEST = """
from pathlib import Path

import pytest

import irs_system_tests.floor_verdict as verdict

pytest_plugins = ['irs_system_tests.floor_verdict']
CALLS = Path(__file__).parent / 'floor_calls'
MISS = {miss!r}
REAL = pytest.StashKey()


def pytest_configure(config):
    config.addinivalue_line('markers', 'exclusive: real time, alone')
    config.stash[REAL] = verdict.measure_floor
    verdict.measure_floor = fake_floor


def pytest_unconfigure(config):      # the inner run shares the module with the outer one
    verdict.measure_floor = config.stash[REAL]


def fake_floor(seconds=verdict.FLOOR_SECONDS):
    with open(CALLS, 'a') as f:
        f.write('x')
    if MISS is None:
        raise RuntimeError('no DDS')
    return {{'miss_pct': MISS, 'latency_p99_ms': 12.5, 'cpu_per_hop_us': 800.0}}



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


def _run(pytester, miss, *args):
    pytester.makeconftest(INNER_CONFTEST.format(miss=miss))
    pytester.makepyfile(test_inner=INNER_TESTS)
    # (the conftest imports the plugin before pytest loads it: no assertion rewriting there)
    result = pytester.runpytest('-rsfE', '-W', 'ignore::pytest.PytestAssertRewriteWarning',
                                *LEAN, *args)
    calls = pytester.path / 'floor_calls'
    return result, len(calls.read_text()) if calls.exists() else 0


def test_a_machine_that_misses_the_floor_turns_the_failure_into_a_skip_that_says_why(pytester):
    result, calls = _run(pytester, 92.0)
    result.assert_outcomes(passed=1, failed=1, skipped=1, errors=1)
    assert calls == 1, 'only the failed call of an exclusive test is measured'
    result.stdout.fnmatch_lines([
        '*SKIPPED*test_inner.py:*the machine could not run a 1 kHz graph just now: the floor*'
        'missed 92.0 % of its deadlines (p99 12.50 ms, 800 us of CPU per hop), measured right '
        'after this test failed with: AssertionError: the car left the belt*'])
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


def test_the_skip_crosses_xdist_workers(pytester):
    result, calls = _run(pytester, 92.0, '-p', 'xdist', '-n', '1')
    result.stdout.fnmatch_lines(['*1 worker*'])
    result.assert_outcomes(passed=1, failed=1, skipped=1, errors=1)
    assert calls == 1
