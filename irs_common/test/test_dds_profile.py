"""``irs_common.dds_profile``: the profile file the environment names, and the longest writer
heartbeat period it allows, read back from files written here and from the environment's own.
"""
from pathlib import Path

from hypothesis import given, settings, strategies as st
import pytest

from irs_common.dds_profile import (DEFAULT_HEARTBEAT_PERIOD, PROFILE_VARIABLES, profile_file,
                                    writer_heartbeat_period)

ROOT = Path(__file__).resolve().parents[2]
HEAD = ('<?xml version="1.0" encoding="UTF-8" ?>\n'
        '<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">\n')


def _writer(name, default, sec=None, nanosec=None) -> str:
    times = ''
    if sec is not None or nanosec is not None:
        parts = ''.join(f'<{k}>{v}</{k}>' for k, v in (('sec', sec), ('nanosec', nanosec))
                        if v is not None)
        times = f'<times><heartbeatPeriod>{parts}</heartbeatPeriod></times>'
    flag = ' is_default_profile="true"' if default else ''
    return f'<data_writer profile_name="{name}"{flag}>{times}</data_writer>\n'


def _period(tmp_path, body: str) -> float:
    path = tmp_path / 'profile.xml'
    path.write_text(HEAD + body + '</profiles>\n')
    return writer_heartbeat_period({PROFILE_VARIABLES[0]: str(path)})


def test_the_environment_profile_gives_50_ms():
    assert writer_heartbeat_period(
        {PROFILE_VARIABLES[0]: str(ROOT / 'env' / 'fastdds_profiles.xml')}) == 0.05


@settings(max_examples=40, deadline=None)
@given(sec=st.integers(0, 100), nanosec=st.integers(0, 999_999_999))
def test_a_default_writer_period_is_read_in_seconds(tmp_path_factory, sec, nanosec):
    tmp = tmp_path_factory.mktemp('p')
    assert _period(tmp, _writer('w', True, sec, nanosec)) == pytest.approx(sec + nanosec * 1e-9,
                                                                           abs=1e-12)


def test_a_missing_part_counts_as_zero(tmp_path):
    assert _period(tmp_path, _writer('w', True, nanosec=250_000_000)) == 0.25
    assert _period(tmp_path, _writer('w', True, sec=2)) == 2.0


def test_the_longest_of_several_writer_profiles_counts(tmp_path):
    body = _writer('w', True, 0, 50_000_000) + _writer('/pose', False, 1, 0)
    assert _period(tmp_path, body) == 1.0
    # a profile named after a topic without a period gets Fast DDS's default
    assert _period(tmp_path, _writer('w', True, 0, 50_000_000) + _writer('/pose', False)) \
        == DEFAULT_HEARTBEAT_PERIOD


def test_the_profiles_of_services_and_clients_do_not_count(tmp_path):
    body = (_writer('w', True, 0, 50_000_000) + _writer('client', False, 3, 0)
            + _writer('service', False, 3, 0))
    assert _period(tmp_path, body) == 0.05


@pytest.mark.parametrize('body', [
    '',                                                     # no writer profile
    _writer('w', False, 0, 50_000_000),                     # none is the default
    _writer('w', True),                                     # the default sets no period
    _writer('w', True, 'DURATION_INFINITY'),                # not a number of seconds
    '<data_writer profile_name="w" is_default_profile="true"><times>',   # not XML
])
def test_fast_dds_default_where_the_file_sets_no_period(tmp_path, body):
    assert _period(tmp_path, body) == DEFAULT_HEARTBEAT_PERIOD


def test_no_file_or_an_unreadable_one_gives_fast_dds_default(tmp_path):
    assert writer_heartbeat_period({}) == DEFAULT_HEARTBEAT_PERIOD
    assert writer_heartbeat_period({PROFILE_VARIABLES[0]: str(tmp_path / 'none.xml')}) \
        == DEFAULT_HEARTBEAT_PERIOD
    assert writer_heartbeat_period({PROFILE_VARIABLES[0]: str(tmp_path)}) \
        == DEFAULT_HEARTBEAT_PERIOD          # a directory


def test_the_first_variable_set_names_the_file():
    assert profile_file({}) is None
    assert profile_file({PROFILE_VARIABLES[0]: ''}) is None
    assert profile_file({PROFILE_VARIABLES[1]: '/b.xml'}) == '/b.xml'
    assert profile_file({PROFILE_VARIABLES[0]: '/a.xml', PROFILE_VARIABLES[1]: '/b.xml'}) \
        == '/a.xml'
