"""call_idempotent: a call whose reply is lost is sent again, up to its attempts."""
from concurrent.futures import Future

import pytest

from irs_system_tests.service_calls import call_idempotent


def settled(result=None) -> Future:
    """A future done with ``result``, or never done (None): what a lost reply leaves."""
    future = Future()
    if result is not None:
        future.set_result(result)
    return future


class Ros:
    """spin_until without ROS: the predicate's value at once (the futures are settled)."""

    def spin_until(self, predicate, timeout):
        return predicate()


def test_the_call_is_sent_again_until_an_answer_comes():
    replies = iter([settled(), settled(), settled('answer'), settled('second answer')])
    sent = []

    def request():
        sent.append(1)
        return next(replies)
    assert call_idempotent(Ros(), request) == 'answer'
    assert len(sent) == 3


def test_no_answer_in_all_attempts_fails_naming_them():
    sent = []

    def request():
        sent.append(1)
        return settled()
    with pytest.raises(AssertionError, match='no answer in 2 calls of 0.5 s'):
        call_idempotent(Ros(), request, attempts=2, timeout=0.5)
    assert len(sent) == 2
