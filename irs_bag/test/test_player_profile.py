"""The ``bag play`` process's Fast DDS profile (``irs_bag.player.use_player_profile``): named
when the environment names none, left alone when it does, and what it sets.
"""
import xml.etree.ElementTree as ET

from irs_bag.player import PROFILE_VARIABLES, use_player_profile

NS = {'p': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}


def test_the_profile_is_named_when_none_is_and_sets_50_ms_heartbeats():
    env = {}
    path = use_player_profile(env)
    assert path is not None and env == {PROFILE_VARIABLES[0]: path}
    writer = ET.parse(path).getroot().find('p:data_writer', NS)
    assert writer.get('is_default_profile') == 'true'
    period = writer.find('p:times/p:heartbeatPeriod', NS)
    seconds = int(period.find('p:sec', NS).text) + 1e-9 * int(period.find('p:nanosec', NS).text)
    assert seconds == 0.05


def test_a_profile_the_user_names_is_kept():
    for variable in PROFILE_VARIABLES:
        env = {variable: '/etc/my_profile.xml'}
        assert use_player_profile(env) is None
        assert env == {variable: '/etc/my_profile.xml'}
