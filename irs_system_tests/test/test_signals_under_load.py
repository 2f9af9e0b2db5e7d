"""SIGINT and SIGTERM stop every long-running command within its bound under a CPU hog.

The hog (:func:`irs_system_tests.cpu_hog.cpu_hog`: one busy loop per core at nice -10) leaves a
command about a tenth of a core. It runs from the command's start, except beside the runner's
graph signalled while running: it starts once the graph runs. Each test starts the command in
its own session, signals it at a moment found by a condition (its signal handler installed =
start-up; a log line = running), and checks: it ends within the bound of docs/cli.md, with the
exit code of that table, without a traceback, and leaves no process behind. A second signal
while the command stops ends it at once. The measured times are printed (``pytest -s``).
"""
from contextlib import ExitStack
import os
from pathlib import Path
import signal
import subprocess
import time

import pytest
import yaml

from irs_bringup.executables import resolve_executable
from irs_bag import validate
from irs_bringup.processes import wait_until
from irs_system_tests.cpu_hog import alive, cpu_hog, descendants, wait_handling_signals

pytestmark = pytest.mark.exclusive   # the hog would measure the other worker's tests too

#: Bounds under the hog [s] (docs/cli.md): the first signal to the end of the process.
NODE_BOUND = 15.0          # a node or a container: destroy the nodes, shut rclpy down
RUNNER_BOUND = 45.0        # the runner: every node (5 s grace), the recorder (15 s), itself
PLAY_BOUND = 15.0          # bag play: the schedule's wait (<= 50 ms), its node, rclpy shut down
SWEEP_BOUND = 20.0         # the sweep: its Dask cluster closed (5 s), workers killed after that
SECOND_BOUND = 5.0         # a second signal while stopping: leave at once
START_TIMEOUT = 240.0      # start-up under the hog (imports at a tenth of a core)


class Command:
    """A command started in its own session, its output in a log file."""

    def __init__(self, argv, tmp_path, name, env=None):
        self.log_path = tmp_path / f'{name}.log'
        self._log = open(self.log_path, 'w')
        self.proc = subprocess.Popen(argv, stdout=self._log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL, cwd=tmp_path,
                                     start_new_session=True, env=env)
        self.family = set()

    def log(self) -> str:
        return self.log_path.read_text(errors='replace')

    def wait_for(self, text, timeout=START_TIMEOUT) -> bool:
        return wait_until(lambda: text in self.log() or self.proc.poll() is not None, timeout) \
            and text in self.log()

    def signal(self, sig, again=None) -> float:
        """Send ``sig`` (and ``again`` 0.3 s later, if given); seconds until the process ended."""
        self.family |= set(descendants(self.proc.pid))
        t0 = time.monotonic()
        self.proc.send_signal(sig)
        if again is not None:
            try:
                self.proc.wait(0.3)
            except subprocess.TimeoutExpired:
                self.family |= set(descendants(self.proc.pid))
                t0 = time.monotonic()
                self.proc.send_signal(again)
        bound = SECOND_BOUND if again is not None else 120.0
        try:
            self.proc.wait(bound)
        except subprocess.TimeoutExpired:
            pass
        return time.monotonic() - t0

    def left_behind(self) -> list:
        wait_until(lambda: not any(alive(p) for p in self.family), 10.0)
        return [p for p in self.family if alive(p)]

    def kill(self):
        for pid in [self.proc.pid, *descendants(self.proc.pid), *self.family]:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        self.proc.wait(10)
        self._log.close()


@pytest.fixture
def hog():
    with cpu_hog() as pids:
        yield pids


@pytest.fixture
def start_hog():
    """Starts the hog when called (the test's chosen moment); it runs to the test's end."""
    with ExitStack() as stack:
        yield lambda: stack.enter_context(cpu_hog())


def _check(cmd, elapsed, bound, codes, what):
    out = cmd.log()
    print(f'\n{what}: ended {elapsed:.2f} s after the signal (bound {bound:g} s), exit code '
          f'{cmd.proc.returncode}')
    assert cmd.proc.returncode is not None, f'{what}: still running after {elapsed:.1f} s\n{out}'
    assert elapsed < bound, f'{what}: {elapsed:.1f} s > {bound} s\n{out[-3000:]}'
    assert cmd.proc.returncode in codes, f'{what}: exit code {cmd.proc.returncode}\n{out[-3000:]}'
    assert 'Traceback' not in out, out[-3000:]
    assert not cmd.left_behind(), f'{what}: left behind {cmd.left_behind()}'


# ------------------------------------------------------------------------------ the runner
RUNNER = ['run', 'figure10_pi', '--process-per-node', '--no-plots', '--duration', '60',
          '--runs-dir', 'runs']


@pytest.mark.parametrize('deployment,moment,sig,again,code', [
    ('--process-per-node', 'start-up', signal.SIGINT, None, 130),
    ('--process-per-node', 'running', signal.SIGTERM, None, 143),
    ('--process-per-node', 'running', signal.SIGINT, signal.SIGINT, 130),
    ('--composed', 'running', signal.SIGINT, None, 130),
], ids=['start-up-SIGINT', 'running-SIGTERM', 'running-SIGINT-twice', 'composed-running-SIGINT'])
def test_runner_stops_within_its_bound(start_hog, tmp_path, deployment, moment, sig, again,
                                       code):
    """The hog starts with the runner for a signal at start-up; for one while the graph runs,
    once it runs (a graph brought up at a tenth of a core takes 10-15 s and tests nothing more).
    """
    argv = [a if a != '--process-per-node' else deployment for a in RUNNER]
    if moment == 'start-up':
        start_hog()
    cmd = Command([resolve_executable('irs_bringup', 'experiment'), *argv], tmp_path, 'runner')
    try:
        if moment == 'start-up':
            assert wait_handling_signals(cmd.proc.pid, START_TIMEOUT), cmd.log()
        else:
            assert cmd.wait_for('graph up'), cmd.log()
            assert cmd.wait_for('[experiment] running: ', 60.0), cmd.log()   # rig started
            run_dirs = list((tmp_path / 'runs').iterdir())
            # a process per node (with the recorder), or the container
            assert run_dirs and len(descendants(cmd.proc.pid)) >= (
                6 if deployment == '--process-per-node' else 1)
            start_hog()
        elapsed = cmd.signal(sig, again)
        codes = {code} if again is None else {code, -again}    # -again: see the node test
        _check(cmd, elapsed, SECOND_BOUND if again else RUNNER_BOUND, codes,
               f'runner {deployment}, {moment}, {signal.Signals(sig).name}'
               + (' twice' if again else ''))
        if not again and moment == 'running':
            assert f'interrupted ({signal.Signals(sig).name})' in cmd.log()
    finally:
        cmd.kill()


# -------------------------------------------------------------------- a node, a container
def _container_spec(tmp_path):
    spec = tmp_path / 'spec.yaml'
    spec.write_text(yaml.safe_dump({'nodes': [
        {'package': 'irs_vehicle_sim', 'executable': 'vehicle_sim'},
        {'package': 'irs_sensing', 'executable': 'arm_pose_estimator'}]}))
    return spec


#: what is started, and the log line that says it is running
NODES = {
    'node': ('rig up', lambda tmp: [resolve_executable('irs_vehicle_sim', 'vehicle_sim')]),
    'container': ('rig up', lambda tmp: [resolve_executable('irs_bringup', 'container'),
                                         str(_container_spec(tmp))]),
    'recorder': ('recording', lambda tmp: [
        resolve_executable('irs_bag', 'recorder'), '--ros-args', '-p',
        f"output:={tmp / 'bag'}", '-p', "topics:=['/clock', '/arm/joint_states']"]),
}


@pytest.mark.parametrize('what', list(NODES))
@pytest.mark.parametrize('moment,sig,again,code', [
    ('start-up', signal.SIGINT, None, 0),
    ('running', signal.SIGTERM, None, 0),
    ('running', signal.SIGINT, signal.SIGINT, 0),
], ids=['start-up-SIGINT', 'running-SIGTERM', 'running-SIGINT-twice'])
def test_node_and_container_stop_within_their_bound(hog, tmp_path, what, moment, sig, again,
                                                    code):
    running, argv = NODES[what]
    cmd = Command(argv(tmp_path), tmp_path, what)
    try:
        if moment == 'start-up':
            assert wait_handling_signals(cmd.proc.pid, START_TIMEOUT), cmd.log()
        else:
            assert cmd.wait_for(running), cmd.log()
        elapsed = cmd.signal(sig, again)
        # a second signal may come after the clean stop is done (0), while the nodes are being
        # destroyed (128 + signal), or in the interpreter's own exit, after Python has put back
        # the default action (killed by the signal: -signal here, 128 + signal in a shell)
        codes = {code} if again is None else {code, 128 + again, -again}
        _check(cmd, elapsed, SECOND_BOUND if again else NODE_BOUND, codes,
               f'{what}, {moment}, {signal.Signals(sig).name}' + (' twice' if again else ''))
        if what == 'recorder' and moment == 'running' and again is None:
            assert validate(tmp_path / 'bag').ok, 'the recorder closes its bag on a signal'
    finally:
        cmd.kill()


# ------------------------------------------------------------------------------ bag play
def _small_bag(path):
    """0.5 s of std_msgs/Float64 on /a at 100 Hz (no header: paced by the log times)."""
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64

    from irs_bag.writer import BagWriter
    with BagWriter(path) as w:
        for k in range(50):
            w.write('/a', 'std_msgs/msg/Float64', serialize_message(Float64(data=float(k))),
                    10**18 + k * 10**7)
    return path


@pytest.mark.parametrize('moment,sig,again,code', [
    ('start-up', signal.SIGINT, None, 130),
    ('running', signal.SIGTERM, None, 143),
    ('running', signal.SIGINT, signal.SIGINT, 130),
], ids=['start-up-SIGINT', 'running-SIGTERM', 'running-SIGINT-twice'])
def test_bag_play_loop_stops_within_its_bound(hog, tmp_path, moment, sig, again, code):
    bag = _small_bag(tmp_path / 'bag')
    cmd = Command([resolve_executable('irs_bag', 'bag'), 'play', str(bag), '--loop'], tmp_path,
                  'play')
    try:
        if moment == 'start-up':
            assert wait_handling_signals(cmd.proc.pid, START_TIMEOUT), cmd.log()
        else:
            assert cmd.wait_for('loop 1 done'), cmd.log()     # playing, and again
        elapsed = cmd.signal(sig, again)
        codes = {code} if again is None else {code, -again}    # -again: see the node test
        _check(cmd, elapsed, SECOND_BOUND if again else PLAY_BOUND, codes,
               f'bag play --loop, {moment}, {signal.Signals(sig).name}'
               + (' twice' if again else ''))
        name = signal.Signals(sig).name
        if again is None:   # said by the player, or by run_cli before the player is set up
            assert (f'interrupted by {name} (exit code {code})' in cmd.log()
                    or f'bag: interrupted ({name})' in cmd.log()), cmd.log()
    finally:
        cmd.kill()


# ------------------------------------------------------------------------------ the sweep
SWEEP = """\
name: signals
scenario: figure10_mrc_with_actuator
duration: 0.4
fixed: {reference.signal.start_time: 0.1}
axes:
  - name: delay_ms
    range: {start: 0.0, stop: 40.0, num: 400}
    set: {rig.actuator_front.delay: 0.001}
metrics: [ise_norm]
"""


@pytest.mark.parametrize('moment,sig,again,code', [
    ('start-up', signal.SIGINT, None, 130),
    ('running', signal.SIGINT, None, 130),
    ('running', signal.SIGTERM, signal.SIGTERM, 143),
], ids=['start-up-SIGINT', 'running-SIGINT', 'running-SIGTERM-twice'])
def test_sweep_stops_within_its_bound(hog, tmp_path, moment, sig, again, code):
    (tmp_path / 'signals.yaml').write_text(SWEEP)
    cmd = Command([resolve_executable('irs_studies', 'sweep'), 'signals.yaml', '--workers', '1',
                   '--out', 'out', '--no-plots'], tmp_path, 'sweep')
    try:
        if moment == 'start-up':
            assert wait_handling_signals(cmd.proc.pid, START_TIMEOUT), cmd.log()
        else:
            assert cmd.wait_for('[sweep] Dask:'), cmd.log()
        elapsed = cmd.signal(sig, again)
        codes = {code} if again is None else {code, -again}    # -again: see the node test
        _check(cmd, elapsed, SECOND_BOUND if again else SWEEP_BOUND, codes,
               f'sweep, {moment}, {signal.Signals(sig).name}' + (' twice' if again else ''))
    finally:
        cmd.kill()


def test_runner_reports_interrupt_in_result_from_another_thread(tmp_path):
    """``request_stop`` (no signal: another thread) stops a run during start-up: no node left."""
    import threading

    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner
    runner = ExperimentRunner(load_experiment('figure10_pi').with_duration(30.0),
                              runs_dir=tmp_path, progress=False)
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault('r', runner.run()))
    thread.start()
    assert wait_until(lambda: len(runner.procs) >= 5 or not thread.is_alive(), 120.0)
    pids = [p.pid for p in runner.procs.values()]
    t0 = time.monotonic()
    runner.request_stop()
    thread.join(60)
    assert not thread.is_alive()
    print(f'\nstopped {time.monotonic() - t0:.2f} s after request_stop during start-up')
    result = box['r']
    assert not result.completed and result.interrupted == 0
    assert result.message == 'interrupted (a stop request)'
    assert not any(alive(p) for p in pids)
    assert Path(result.run_dir).is_dir()
