"""The shared node patterns of irs_common: the lock-step answer cache, yaw <-> quaternion and the
dataclass field checks (no ROS graph needed).
"""
import math
from dataclasses import dataclass

import pytest

from irs_common.answer_cache import AnswerCache
from irs_common.field_checks import check_numbers
from irs_common.orientation import quaternion_from_yaw, yaw_from_quaternion


class Pub:
    """A publisher that logs what it publishes."""

    def __init__(self, log, name):
        self.log, self.name = log, name

    def publish(self, msg):
        self.log.append((self.name, msg))


def test_answer_cache_repeats_the_last_answer_in_order():
    log = []
    a, b = Pub(log, 'a'), Pub(log, 'b')
    cache = AnswerCache()
    cache.repeat()                          # nothing answered yet: nothing to repeat
    assert log == []
    cache.start()
    cache.publish(a, 1)
    cache.publish(b, 2)
    cache.repeat()
    assert log == [('a', 1), ('b', 2), ('a', 1), ('b', 2)]
    cache.start()                           # the next stamp replaces the answer
    cache.publish(b, 3)
    log.clear()
    cache.repeat()
    assert log == [('b', 3)] and len(cache) == 1
    cache.clear()                           # time went back: nothing to repeat
    cache.repeat()
    assert log == [('b', 3)]


@pytest.mark.parametrize('psi', [0.0, 0.3, -1.2, math.pi / 2, 3.0, -3.0, math.pi])
def test_yaw_quaternion_round_trip(psi):
    x, y, z, w = quaternion_from_yaw(psi)
    assert (x, y) == (0.0, 0.0)
    assert math.isclose(z * z + w * w, 1.0, rel_tol=1e-15)
    assert yaw_from_quaternion(x, y, z, w) == pytest.approx(psi, abs=1e-15)


def test_yaw_of_a_general_quaternion():
    # 90 deg about z after a roll: the z of the ZYX Euler angles
    s = math.sqrt(0.5)
    assert yaw_from_quaternion(0.0, 0.0, s, s) == pytest.approx(math.pi / 2)
    assert yaw_from_quaternion(1.0, 0.0, 0.0, 0.0) == pytest.approx(0.0)


@dataclass
class Params:
    """Fields to check."""

    gain: float = 1.0
    margin: float = 0.0
    offset: float = -2.0


@pytest.mark.parametrize('kwargs, rule, message', [
    ({'gain': 0.0}, {'above': 0.0}, r'Params.gain must be a finite number > 0, got 0.0.'),
    ({'gain': math.nan}, {'above': 0.0}, r'Params.gain must be a finite number > 0, got nan.'),
    ({'margin': -0.1}, {'at_least': 0.0},
     r'Params.margin must be a finite number >= 0, got -0.1.'),
    ({'offset': math.inf}, {}, r'Params.offset must be a finite number, got inf.'),
    ({'gain': True}, {}, r'Params.gain must be a finite number, got True.'),
    ({'gain': '1'}, {}, r"Params.gain must be a finite number, got '1'."),
])
def test_check_numbers_names_the_field(kwargs, rule, message):
    name = next(iter(kwargs))
    with pytest.raises(ValueError) as info:
        check_numbers(Params(**kwargs), (name,), **rule)
    assert str(info.value) == message


def test_check_numbers_accepts_good_values():
    check_numbers(Params(), ('gain',), above=0.0)
    check_numbers(Params(), ('margin',), at_least=0.0)
    check_numbers(Params(), ('gain', 'margin', 'offset'))
    with pytest.raises(ValueError, match='at most one'):
        check_numbers(Params(), ('gain',), above=0.0, at_least=0.0)
