"""The runner stops a lock-step run's nodes only once the recorder has the whole run.

A recorder in its own process can be seconds behind a rig that a loaded machine still steps
quickly (the deployment test saw a recorder with 171 of 1201 ``/clock`` messages when the
nodes were stopped 0.5 s after the run). Here the recorder is frozen (SIGSTOP) for 4 s while
the rig runs to its end: the bag must still hold every step.
"""
import os
import signal
import threading
import time

from irs_bag.reader import BagReader
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import ExperimentRunner
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
