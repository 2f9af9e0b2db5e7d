"""``set_realtime_priority``: IRS_RT_PRIORITY read, checked and applied, and a note to log."""
import errno
import os
import subprocess
import sys

import pytest

from irs_common import node_main
from irs_common.node_main import set_realtime_priority


def test_unset_or_blank_asks_nothing(monkeypatch):
    calls = []
    monkeypatch.setattr(node_main.os, 'sched_setscheduler', lambda *a: calls.append(a))
    assert set_realtime_priority({}) == ''
    assert set_realtime_priority({'IRS_RT_PRIORITY': '  '}) == ''
    assert calls == []


@pytest.mark.parametrize('text', ['abc', '0', '100', '-5', '50.5', '1e3'])
def test_a_bad_value_is_ignored_and_said(monkeypatch, text):
    calls = []
    monkeypatch.setattr(node_main.os, 'sched_setscheduler', lambda *a: calls.append(a))
    note = set_realtime_priority({'IRS_RT_PRIORITY': text})
    assert note == f'IRS_RT_PRIORITY={text!r} ignored: expected an integer 1..99'
    assert calls == []


def test_refused_is_said_and_the_process_runs_on(monkeypatch):
    def refuse(pid, policy, param):
        assert (pid, policy, param.sched_priority) == (0, os.SCHED_FIFO, 50)
        raise PermissionError(errno.EPERM, os.strerror(errno.EPERM))
    monkeypatch.setattr(node_main.os, 'sched_setscheduler', refuse)
    assert set_realtime_priority({'IRS_RT_PRIORITY': ' 50 '}) == (
        'SCHED_FIFO 50 refused (Operation not permitted); running at normal priority')


def test_granted_or_refused_as_the_machine_allows():
    """In a child process (its policy changes for good): the note says what it got."""
    code = ('import os\nfrom irs_common.node_main import set_realtime_priority\n'
            "print(set_realtime_priority({'IRS_RT_PRIORITY': '10'}))\n"
            'print(os.sched_getscheduler(0) == os.SCHED_FIFO,'
            ' os.sched_getparam(0).sched_priority)')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, timeout=60).stdout.splitlines()
    if out[0] == 'SCHED_FIFO priority 10':
        assert out[1] == 'True 10'
    else:
        assert out[0].startswith('SCHED_FIFO 10 refused') and out[1] == 'False 0', out
        assert os.geteuid() != 0, 'refused to root'
