"""``irs_bringup.graph.call_rig_start``: a ``rig/start`` answer lost on its way is called for
again, and the rig's "already running" then means the unanswered call started it.

The client and the watcher are stand-ins with the calls the function makes (``call_async``,
``remove_pending_request``; ``spin_until``): whether DDS loses an answer depends on discovery
timing, which no test can order, so the rule is tested on scripted answers.
"""
from rclpy.task import Future
from std_srvs.srv import Trigger

from irs_bringup import graph
from irs_common.start_gate import ALREADY_RUNNING


class ScriptedClient:
    """Answers call k with ``script[k]``: None leaves the call unanswered."""

    def __init__(self, script):
        self.script = list(script)
        self.calls = 0
        self.removed = []

    def call_async(self, request):
        assert isinstance(request, Trigger.Request)
        future = Future()
        answer = self.script[min(self.calls, len(self.script) - 1)]
        self.calls += 1
        if answer is not None:
            success, message = answer
            future.set_result(Trigger.Response(success=success, message=message))
        return future

    def remove_pending_request(self, future):
        self.removed.append(future)


class InstantWatcher:
    """``spin_until`` without waiting: the predicate as it stands."""

    def spin_until(self, predicate, timeout):
        return bool(predicate())


def _call(script, trying_for=10.0):
    client = ScriptedClient(script)
    ok, message = graph.call_rig_start(InstantWatcher(), client, trying_for=trying_for)
    return ok, message, client


def test_a_started_rig_answers_once(monkeypatch):
    monkeypatch.setattr(graph.time, 'sleep', lambda s: None)
    ok, message, client = _call([(True, 'started (lockstep)')])
    assert (ok, message, client.calls, client.removed) == (True, 'started (lockstep)', 1, [])


def test_a_lost_answer_is_called_again_and_already_running_then_means_started(monkeypatch):
    monkeypatch.setattr(graph.time, 'sleep', lambda s: None)
    ok, message, client = _call([None, (False, ALREADY_RUNNING)])
    assert ok and message == ALREADY_RUNNING and client.calls == 2
    assert len(client.removed) == 1          # the unanswered request is dropped from the client


def test_already_running_without_a_lost_answer_is_a_failure(monkeypatch):
    monkeypatch.setattr(graph.time, 'sleep', lambda s: None)
    clock = iter(range(0, 1000, 5))          # each reading 5 s later: two calls, then give up
    monkeypatch.setattr(graph.time, 'monotonic', lambda: next(clock))
    ok, message, client = _call([(False, ALREADY_RUNNING)], trying_for=6.0)
    assert not ok and message == ALREADY_RUNNING and client.calls == 2


def test_a_rig_that_never_answers_fails_with_the_reason(monkeypatch):
    monkeypatch.setattr(graph.time, 'sleep', lambda s: None)
    clock = iter(range(0, 1000, 5))
    monkeypatch.setattr(graph.time, 'monotonic', lambda: next(clock))
    ok, message, client = _call([None], trying_for=6.0)
    assert not ok and message.startswith('no answer within') and client.calls == 2
    assert len(client.removed) == 2


def test_a_rig_still_coming_up_is_called_until_it_starts(monkeypatch):
    monkeypatch.setattr(graph.time, 'sleep', lambda s: None)
    ok, message, client = _call([(False, 'link not up'), (False, 'link not up'),
                                 (True, 'started (realtime)')])
    assert ok and message == 'started (realtime)' and client.calls == 3
