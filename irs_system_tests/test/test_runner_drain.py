"""The runner stops a lock-step run's nodes only once the recorder has the whole run.

A recorder in its own process can be seconds behind a rig that a loaded machine still steps
quickly (the deployment test saw a recorder with 171 of 1201 ``/clock`` messages when the
nodes were stopped 0.5 s after the run). Here the recorder is frozen (SIGSTOP) for 4 s while
the rig runs to its end: the bag must still hold every step.

Each recorded topic is its own DDS stream: with ``/clock`` complete, another topic may still wait
for the writer's next heartbeat to get what its reader missed (a make test beside a CPU hog saw
the last 79 of 1001 ``/arm/joint_states`` missing from a process-per-node bag). So a recorder
that any node reaches through DDS is waited for until its counts stand still for the runner's
``drain_quiet_behind`` (the writers' heartbeat period in the Fast DDS profile and
``DRAIN_HEARTBEAT_MARGIN``); one composed with every node, for ``DRAIN_QUIET``.
"""
import dataclasses
import os
from pathlib import Path
import signal
import threading
import time

import pytest

from irs_bag.reader import BagReader
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import DRAIN_HEARTBEAT_MARGIN, DRAIN_QUIET, ExperimentRunner
from irs_common.dds_profile import PROFILE_VARIABLES
from irs_bringup.processes import wait_until


def test_the_nodes_stop_after_a_recorder_behind_the_run_has_caught_up(tmp_path):
    exp = load_experiment('sysid_actuator_steps').with_duration(1.2).deployed('process_per_node')
    runner = ExperimentRunner(exp, runs_dir=tmp_path, progress=False)
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault('r', runner.run()))
    thread.start()
    try:
        assert wait_until(lambda: runner.phase == 'running' or not thread.is_alive(), 120.0)
        recorder = runner.procs['recorder']
        os.kill(recorder.pid, signal.SIGSTOP)
        try:
            time.sleep(4.0)        # the fault itself: the run (1.2 s, lock-step) ends meanwhile
        finally:
            os.kill(recorder.pid, signal.SIGCONT)
        thread.join(180)
        assert not thread.is_alive()
    finally:
        if thread.is_alive():
            runner.request_stop()
            thread.join(60)
    result = box['r']
    assert result.completed, result.message
    with BagReader(result.bag_dir) as reader:
        counts = {name: info.message_count for name, info in reader.topics.items()}
    assert counts['/clock'] >= 1201 and counts['/steering/state'] >= 1201, counts


def _caught_up_after(exp, tmp_path, still: float) -> bool:
    """``_recorder_caught_up`` when /clock was complete from the first status and every count,
    one topic short, has stood still for ``still`` s (statuses every 0.1 s).
    """
    runner = ExperimentRunner(exp, runs_dir=tmp_path, progress=False)
    runner.drain_quiet_behind = 3.0 + DRAIN_HEARTBEAT_MARGIN      # Fast DDS's default period
    steps = int(round(exp.duration / runner.dt))
    counts = {'/clock': steps + 1, '/arm/joint_states': steps - 78}
    n = int(round(still / 0.1))
    runner.recorder_status = [(100.0 + 0.1 * i, dict(counts)) for i in range(n + 1)]
    return runner._recorder_caught_up(steps, since=100.0)


def test_a_recorder_apart_from_a_node_is_waited_for_past_the_heartbeat(tmp_path):
    exp = load_experiment('figure10_mrc_with_actuator').with_duration(1.0)
    nodes_composed_recorder_apart = dataclasses.replace(exp.composed(), record_process=None)
    for apart in (exp.deployed('process_per_node'), nodes_composed_recorder_apart):
        assert not _caught_up_after(apart, tmp_path, DRAIN_QUIET + 0.2)
        assert not _caught_up_after(apart, tmp_path, 3.0 + DRAIN_HEARTBEAT_MARGIN - 0.2)
        assert _caught_up_after(apart, tmp_path, 3.0 + DRAIN_HEARTBEAT_MARGIN + 0.1)
    together = exp.deployed()
    assert _caught_up_after(together, tmp_path, DRAIN_QUIET + 0.1)
    assert not _caught_up_after(together, tmp_path, DRAIN_QUIET - 0.2)


def test_the_wait_past_the_heartbeat_follows_the_fast_dds_profile_in_use(tmp_path, monkeypatch):
    """50 ms heartbeats in the environment's profile: 1.05 s; no profile (Fast DDS's 3 s): 4 s."""
    exp = load_experiment('figure10_pi').with_duration(1.0)
    profile = Path(__file__).resolve().parents[2] / 'env' / 'fastdds_profiles.xml'
    for variable in PROFILE_VARIABLES:
        monkeypatch.delenv(variable, raising=False)
    monkeypatch.setenv(PROFILE_VARIABLES[0], str(profile))
    assert ExperimentRunner(exp, runs_dir=tmp_path, progress=False).drain_quiet_behind \
        == pytest.approx(0.05 + DRAIN_HEARTBEAT_MARGIN)
    monkeypatch.delenv(PROFILE_VARIABLES[0])
    assert ExperimentRunner(exp, runs_dir=tmp_path, progress=False).drain_quiet_behind \
        == pytest.approx(3.0 + DRAIN_HEARTBEAT_MARGIN)
