"""The board keeper (``irs_hardware.board_keeper``): its decision alone, then its process on a
real pseudo-terminal: it repeats the node's newest frame while the node is silent, for
``grace`` and no longer, and exits when the node's end of the socket closes or its process dies.
"""
import os
import signal
import subprocess
import sys
import time
import tty

import pytest
from hypothesis import given, settings, strategies as st

from irs_hardware.board_keeper import AFTER, PERIOD, BoardKeeper, KeeperState


def test_nothing_before_an_offer_and_nothing_while_the_node_is_fresh():
    k = KeeperState(0.4)
    assert k.due(10.0) is None
    k.offer(b'F1', 10.0)
    assert k.due(10.0 + AFTER / 2) is None
    assert k.due(10.0 + AFTER * 1.001) == b'F1'


def test_repeats_every_period_until_the_grace_then_stops():
    k = KeeperState(0.1)
    k.offer(b'F1', 0.0)
    t = AFTER
    times = []
    while t < 0.2:
        if k.due(t) is not None:
            times.append(t)
        t += 0.0005
    assert times[0] == pytest.approx(AFTER, abs=0.0006)
    assert all(b - a >= PERIOD - 1e-12 for a, b in zip(times, times[1:]))
    assert times[-1] <= 0.1
    assert len(times) == pytest.approx((0.1 - AFTER) / PERIOD, abs=2)


def test_the_newest_offer_wins_and_an_older_one_is_ignored():
    k = KeeperState(0.4)
    k.offer(b'NEW', 5.0)
    k.offer(b'OLD', 4.0)
    assert k.due(5.0 + AFTER * 1.001) == b'NEW'


@pytest.mark.parametrize('grace', [0.0, AFTER, -1.0])
def test_a_grace_not_above_after_is_refused(grace):
    with pytest.raises(ValueError, match='grace'):
        KeeperState(grace)


@settings(max_examples=300, deadline=None)
@given(offers=st.lists(st.tuples(st.floats(0.0, 1.0), st.binary(min_size=1, max_size=8)),
                       min_size=1, max_size=20),
       now=st.floats(0.0, 2.0), grace=st.floats(0.01, 1.0))
def test_a_repeat_is_the_newest_frame_and_only_within_the_grace(offers, now, grace):
    k = KeeperState(grace)
    for stamp, frame in offers:
        k.offer(frame, stamp)
    newest = max(offers, key=lambda o: o[0])
    frame = k.due(now)
    silent = now - newest[0]
    if frame is not None:
        assert AFTER <= silent <= grace
        assert frame == [f for s, f in offers if s == newest[0]][-1]
    else:
        assert not AFTER <= silent <= grace


@settings(max_examples=300, deadline=None)
@given(offered=st.floats(0.0, 1.0), repeated=st.floats(-1.0, 2.0), now=st.floats(0.0, 2.0),
       grace=st.floats(0.01, 1.0))
def test_the_sleep_never_passes_a_due_repeat(offered, repeated, now, grace):
    """Nothing is due before ``now + wait(now)``, and the wait is at most ``after``."""
    k = KeeperState(grace)
    k.offer(b'F', offered)
    k.repeated = min(repeated, now)
    wait = k.wait(now)
    assert 0.0 <= wait <= AFTER
    for t in (now, now + wait / 2, now + wait * 0.999):
        probe = KeeperState(grace)
        probe.offer(b'F', offered)
        probe.repeated = k.repeated
        assert wait == 0.0 or probe.due(t) is None or t - now < 1e-12


def raw_pty():
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    os.set_blocking(master, False)
    return master, slave


def read_all(fd) -> bytes:
    out = b''
    while True:
        try:
            out += os.read(fd, 4096)
        except BlockingIOError:
            return out


def wait_for(predicate, timeout=10.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.005)
    return False


def test_the_process_repeats_the_last_frame_for_the_grace_then_falls_silent():
    master, slave = raw_pty()
    keeper = BoardKeeper(0.1)
    try:
        keeper.attach(slave)
        got = []
        # the keeper may still be starting: offer until its first repeat comes back
        assert wait_for(lambda: (keeper.offer(b'FRAME', time.monotonic() - 2 * AFTER),
                                 got.append(read_all(master)), b'FRAME' in got[-1])[-1])
        t0 = time.monotonic()
        keeper.offer(b'LAST!', t0)
        assert wait_for(lambda: time.monotonic() - t0 > 0.3)   # the grace and beyond
        data = read_all(master)
        repeats = data.count(b'LAST!')
        # 0.1 s of grace from 3 ms at one per 2 ms: about 48, fewer if the keeper was starved
        assert 1 <= repeats <= (0.1 - AFTER) / PERIOD + 2, repeats
        assert data.replace(b'LAST!', b'').replace(b'FRAME', b'') == b''
        assert read_all(master) == b'', 'nothing after the grace'
    finally:
        keeper.close()
        os.close(master)
        os.close(slave)
    assert keeper.process.returncode == 0


def test_after_a_detach_nothing_is_repeated_until_the_next_attach_and_offer():
    master, slave = raw_pty()
    keeper = BoardKeeper(1.0)
    try:
        keeper.attach(slave)
        assert wait_for(lambda: (keeper.offer(b'ONE', time.monotonic() - 2 * AFTER),
                                 b'ONE' in read_all(master))[-1])
        keeper.detach()            # answered: nothing of this session is written after it
        read_all(master)
        t0 = time.monotonic()
        assert wait_for(lambda: time.monotonic() - t0 > 0.05)
        assert read_all(master) == b''
        keeper.offer(b'TWO', time.monotonic() - 2 * AFTER)     # no port: still nothing
        t0 = time.monotonic()
        assert wait_for(lambda: time.monotonic() - t0 > 0.05)
        assert read_all(master) == b''
        keeper.attach(slave)       # the next session: its own frames only
        assert wait_for(lambda: (keeper.offer(b'THREE', time.monotonic() - 2 * AFTER),
                                 b'THREE' in read_all(master))[-1])
    finally:
        keeper.close()
        os.close(master)
        os.close(slave)


def test_a_port_busy_for_a_while_is_used_again_once_it_takes_frames():
    """The port is the node's non-blocking file: a repeat that finds it busy (EAGAIN: the
    node's own write in progress, or its buffer full) is skipped, and the next repeats go out.
    A pipe filled to the brim stands in for the port (the same EAGAIN), for 0.1 s: 50 periods.
    """
    r, w = os.pipe()
    os.set_blocking(r, False)
    os.set_blocking(w, False)
    try:
        while True:
            os.write(w, b'.' * 4096)
    except BlockingIOError:
        pass
    keeper = BoardKeeper(2.0)
    try:
        keeper.attach(w)
        t0 = time.monotonic()
        assert wait_for(lambda: (keeper.offer(b'KEEP', time.monotonic() - 2 * AFTER),
                                 time.monotonic() - t0 > 0.1)[-1])
        got = []
        # the pipe drained: the next repeats arrive, whole
        assert wait_for(lambda: (got.append(read_all(r)), b'KEEP' in b''.join(got))[-1], 1.0), \
            'no repeat after the port was busy'
        assert b''.join(got).replace(b'.', b'').replace(b'KEEP', b'') == b''
    finally:
        keeper.close()
        os.close(r)
        os.close(w)


HOLDER = """
import os, sys, time
from irs_hardware.board_keeper import BoardKeeper
k = BoardKeeper(5.0)
k.attach(int(sys.argv[1]))
print(k.process.pid, flush=True)
while True:
    k.offer(b'X', time.monotonic())
    time.sleep(0.001)
"""


def test_the_keeper_exits_when_its_node_is_killed():
    master, slave = raw_pty()
    node = subprocess.Popen([sys.executable, '-c', HOLDER, str(slave)], pass_fds=(slave,),
                            stdout=subprocess.PIPE, text=True)
    try:
        keeper_pid = int(node.stdout.readline())
        os.kill(node.pid, signal.SIGKILL)
        node.wait()

        def gone():
            try:
                os.kill(keeper_pid, 0)
            except ProcessLookupError:
                return True
            with open(f'/proc/{keeper_pid}/stat') as stat:      # exited, not yet reaped
                return stat.read().split(') ')[1].startswith('Z')
        assert wait_for(gone, 5.0), 'the keeper outlived its node'
    finally:
        node.kill()
        os.close(master)
        os.close(slave)
