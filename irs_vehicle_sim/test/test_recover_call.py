"""``irs_vehicle_sim.recover_call``: a ``rig/recover`` answer lost on its way is recognised by
``rig/status``, and only then.

Whether DDS loses an answer depends on discovery timing, which no test can order, so the rule
is tested on scripted statuses and answers: ``spin_until`` stand-ins advance a scripted world
one event per spin.
"""
from types import SimpleNamespace

import pytest
from rclpy.task import Future
from std_srvs.srv import Trigger

from irs_common.cli import RunFailed
from irs_msgs.msg import RigStatus
from irs_vehicle_sim.recover_call import recovery_index, take_answer

RUN, HOLD, STOPPING, STOPPED, RECOVERING = (
    RigStatus.SAFE_RUNNING, RigStatus.SAFE_HOLDING, RigStatus.SAFE_STOPPING,
    RigStatus.SAFE_STOPPED, RigStatus.SAFE_RECOVERING)


def _statuses(states):
    return [SimpleNamespace(safe_state=s) for s in states]


@pytest.mark.parametrize('states,index', [
    ([], None),
    ([RUN, RUN, HOLD, RUN], None),             # running all along: nothing says the call was taken
    ([STOPPED, STOPPED], None),                # still stopped
    ([RUN, RECOVERING, RECOVERING, RUN], 1),   # vehicle_sim: its recovering state
    ([STOPPED, STOPPED, RUN], 2),              # rig_hardware: running again after a stop
    ([STOPPING, HOLD, RUN], 2),
    ([RUN, STOPPED, RECOVERING], 2),
])
def test_the_status_that_shows_a_recovery(states, index):
    assert recovery_index(_statuses(states)) == index


class World:
    """A scripted future and recovery flag: ``events[k]`` happens at spin ``k`` ('answer',
    'refusal', 'recovering' or None); each spin reports its predicate after the event.
    """

    def __init__(self, events):
        self.events = list(events)
        self.future = Future()
        self.recovering = False
        self.spins = []

    def spin_until(self, predicate, seconds):
        event = self.events.pop(0) if self.events else None
        if event == 'recovering':
            self.recovering = True
        elif event in ('answer', 'refusal'):
            self.future.set_result(Trigger.Response(success=event == 'answer', message=event))
        self.spins.append(seconds)
        return bool(predicate())

    def take(self):
        return take_answer(self.spin_until, self.future, lambda: self.recovering, 30.0, 2.0)


def test_an_answer_is_taken_as_it_comes():
    world = World(['answer'])
    assert world.take().message == 'answer'
    assert world.spins == [30.0]


def test_a_recovery_without_an_answer_within_the_wait_is_a_lost_answer():
    world = World(['recovering', None])
    assert world.take() is None
    assert world.spins == [30.0, 2.0]


def test_an_answer_after_the_recovery_shows_is_still_the_answer():
    world = World(['recovering', 'refusal'])
    answer = world.take()
    assert answer is not None and not answer.success and answer.message == 'refusal'


def test_neither_an_answer_nor_a_recovery_fails_in_one_line():
    world = World([None])
    with pytest.raises(RunFailed, match=r'^recover: rig/recover did not answer within 30 s$'):
        world.take()
