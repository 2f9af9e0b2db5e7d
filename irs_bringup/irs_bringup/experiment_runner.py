"""Run an experiment: start its nodes in their processes, wait for the graph, run, shut down.

The runner makes a run directory (node logs, bag), starts the recorder and every node (a shared
``process:`` group in one ``container``), waits until every node and topic endpoint is in the
graph, calls ``rig/start``, follows the run with a progress line and stops it when a process
dies or the car leaves the belt, then stops every process, the recorder last, leaving none
behind. A signal only sets a flag that every wait checks within 50 ms. It exists so that an
experiment file is one command with a clean end; the order of events and the stop rules:
:class:`ExperimentRunner`.
"""
from dataclasses import dataclass, field
import datetime
import json
import os
from pathlib import Path
import platform
import signal
import socket
import subprocess
import threading
import sys
import time

import rclpy
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger
import yaml

from irs_common import qos
from irs_common.cli import SignalGuard, current_guard
from irs_common.dds_profile import writer_heartbeat_period
from irs_common.loop_timing import format_ms
from irs_common.stamps import to_sec
from irs_msgs.msg import RigStatus

from .experiment import (Experiment, absolute, clock_overrides, expected_endpoints,
                         make_run_dir, new_run_dir, node_parameters, resolve_params_file)
from .graph import call_rig_start, make_watcher
from .processes import NodeProcess, NodeSpec, kill_processes, stop_processes

#: Seconds a node has to stop after SIGINT (then SIGTERM, 2 s later SIGKILL).
NODE_GRACE = 5.0
#: Seconds the recorder has to stop after SIGINT: it writes its bag's summary and index.
RECORDER_GRACE = 15.0
#: The drain after a run (``_drain``): the recorder's status period [s], the wall time given
#: to the last messages [s], and the most a recorder behind the run is waited for [s].
DRAIN_STATUS_PERIOD = 0.1
DRAIN_QUIET = 0.5
#: ... and how long its counts must stand still when it was behind the run, or when any recorded
#: topic reaches it through DDS from another process: the nodes' longest writer heartbeat period
#: (after which a writer resends what a slow reader missed: 50 ms with the environment's Fast
#: DDS profile, 3 s with Fast DDS's defaults; ``irs_common.dds_profile``) and this margin [s].
DRAIN_HEARTBEAT_MARGIN = 1.0
DRAIN_TIMEOUT = 60.0
#: The recorder's ``chunk_messages`` when it runs in the loop's process: its writer thread ends a
#: chunk in one call of mcap's writer that holds the interpreter lock, about 0.6 us a message.
#: 512 keeps that call near 0.3 ms; with chunks cut only by the 1 s flush (4,000 messages of
#: Figure 10) the composed real-time loop missed 0.43-0.45 % of its deadlines, with 256 or 512
#: per chunk 0.11-0.28 % (docs/performance.md). Each chunk keeps about 1.4 kB in the writer's
#: memory until the bag closes: 40 MB an hour at 512.
COMPOSED_CHUNK_MESSAGES = 512


def _number(text: str):
    try:
        return int(text)
    except ValueError:
        return float(text)


class ExperimentFailed(RuntimeError):
    """A node died, the graph did not come up, or the run did not progress. ``detail`` (a dead
    node's last output) is logged once with the message, and is not part of it.
    """

    def __init__(self, message, detail=''):
        super().__init__(message)
        self.detail = detail


class _StopRequested(Exception):
    """A signal or :meth:`ExperimentRunner.request_stop` asked the run to stop."""


@dataclass
class RunResult:
    """What one run left: its directories, whether it completed, times and exit codes."""

    run_dir: Path
    bag_dir: Path | None
    completed: bool
    sim_time: float
    wall_time: float
    exit_codes: dict = field(default_factory=dict)
    message: str = ''
    timing: dict = field(default_factory=dict)   # real time: the rig's loop figures (rig/timing)
    cpu: dict = field(default_factory=dict)      # process label -> CPU seconds used in the run
    running_time: float = float('nan')           # wall time from rig/start to the end [s]
    interrupted: int | None = None               # the signal that stopped the run, if any
    safe_stop: str = ''                          # real time: the rig's controlled stop, if any


#: Written into every run folder at the end of the run, completed or not (:func:`write_result`).
RESULT_FILE = 'result.json'


def write_result(result: RunResult, exp: Experiment) -> None:
    """``<run>/result.json``: whether the run completed and why not, its duration (the file's,
    or ``--duration``'s), simulated and wall time, exit codes, a controlled stop; so a failed
    run's folder says so. A folder that cannot be written to is left as it is.
    """
    doc = {'experiment': exp.name, 'completed': result.completed, 'message': result.message,
           'duration': exp.duration, 'sim_time': result.sim_time,
           'wall_time': result.wall_time, 'exit_codes': result.exit_codes,
           'interrupted': result.interrupted, 'safe_stop': result.safe_stop}
    try:
        (result.run_dir / RESULT_FILE).write_text(json.dumps(doc, indent=1, default=str) + '\n')
    except OSError:
        pass


def _git_commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', 'HEAD'], capture_output=True, text=True,
                              cwd=Path(__file__).resolve().parent, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ''


def experiment_metadata(exp: Experiment) -> dict:
    """String metadata for the bag: the experiment file, resolved parameters, versions, commit."""
    import numpy
    import scipy
    params = {n.name: node_parameters(n) for n in exp.nodes}
    return {'experiment_name': exp.name, 'experiment_file': str(exp.path or ''),
            'experiment_yaml': exp.text, 'duration': repr(exp.duration),
            'node_parameters': json.dumps(params, default=str),
            'processes': json.dumps(exp.processes()),
            'clock': exp.clock, 'python': platform.python_version(), 'numpy': numpy.__version__,
            'scipy': scipy.__version__, 'ros_distro': os.environ.get('ROS_DISTRO', 'jazzy'),
            'rmw': os.environ.get('RMW_IMPLEMENTATION', ''), 'git_commit': _git_commit(),
            'started': datetime.datetime.now().isoformat(timespec='seconds')}


def _rig_dt(exp: Experiment) -> float:
    rig = exp.rig()
    return float(node_parameters(rig).get('dt', 0.001)) if rig else 0.001


class ExperimentRunner:
    """Runs one :class:`~irs_bringup.experiment.Experiment`.

    Order of events:

    1. a run directory ``<runs>/<name>-<time>/`` with ``logs/`` (one log per node) and ``bag/``;
    2. the recorder (if the experiment records), the ``live_view`` (with ``view``: a rerun URL,
       an ``.rrd`` path or a Foxglove ``ws://`` URL, :mod:`irs_bag.live_view_node`) and every
       node start through their
       ament-resolved executables, with the experiment's parameter files and overrides plus the
       clock parameters; nodes that share a ``process:`` name start together in one
       ``container`` process (composition: one executor, the nodes still separate on topics);
    3. the runner waits until every node is in the graph and every topic has its expected
       publishers and subscriptions (``experiment.expected_endpoints``; with a live view, its
       subscriptions too), then calls ``rig/start``;
    4. it follows the run (the rig's ``rig/status``, 10 Hz of simulated time, in lock-step; wall
       time in real time) with a progress line, checking every process: if one dies the run stops,
       naming the node and its last output; if the rig reports that the car left the belt, the run
       stops too; a controlled stop of the rig (real time, ``rig/status``) is logged when it
       begins, with its time and cause, and named in the result (``RunResult.safe_stop``): the
       run goes on to its end, car and belt at rest;
    5. on completion or a stop request every node is stopped with SIGINT (then SIGTERM/SIGKILL per
       process group, all at once: :func:`~.processes.stop_processes`), the recorder last so it
       writes everything it received; no process is left behind.

    Stopping: SIGINT, SIGTERM or SIGHUP (or :meth:`ExperimentRunner.request_stop` from another
    thread) only sets a flag; every wait of the runner (graph, ``rig/start``, the run, the drain)
    spins in steps of 50 ms and checks it, so a stop starts within one step wherever the run is,
    start-up included. The nodes then get :data:`NODE_GRACE` s to stop, the recorder
    :data:`RECORDER_GRACE` s (it writes its bag's index), each SIGTERM then SIGKILL after that. A
    second signal kills every process group at once and ends the runner's process (exit 128 +
    signal). The result says which signal stopped the run (``RunResult.interrupted``).
    """

    def __init__(self, exp: Experiment, runs_dir='runs', log=print, graph_timeout=60.0,
                 stall_timeout=30.0, progress=True, rt_priority=0, view=None,
                 view_topics=None):
        self.exp = exp
        self.run_dir = new_run_dir(runs_dir, exp.name)
        self.log = log
        self.graph_timeout = graph_timeout
        self.stall_timeout = stall_timeout
        self.progress = progress
        self.procs = {}
        self.devices = {}    # device processes (emulators): started first, stopped last
        self.members = {}    # container process label -> its node names
        self.recorder_status = []    # (monotonic time, {topic: messages}) of recorder/status
        self.rt_priority = int(rt_priority)
        self.view = view         # live view: rerun URL, .rrd path, ws:// URL (None = no view)
        self.view_topics = view_topics   # its topics (None = the node's default: all)
        self.dt = _rig_dt(exp)
        self.drain_quiet_behind = writer_heartbeat_period() + DRAIN_HEARTBEAT_MARGIN
        self.phase = 'created'   # -> starting -> running -> stopping -> done (for observers)
        self.stop_signal = None  # set by request_stop: the signal number (0: asked, no signal)
        self.safe_stop = ''      # the rig's controlled stop: 't = <s> s (<cause>)'

    # ------------------------------------------------------------------ processes
    def _placeholders(self, value):
        """``{run_dir}`` and ``{free_port}`` of a device argument or a string parameter."""
        if not isinstance(value, str):
            return value
        if '{free_port}' in value and not hasattr(self, 'free_port'):
            with socket.socket() as sock:
                sock.bind(('127.0.0.1', 0))
                self.free_port = sock.getsockname()[1]
        if value == '{free_port}':
            return self.free_port            # an integer parameter
        return value.replace('{run_dir}', str(self.run_dir)).replace(
            '{free_port}', str(getattr(self, 'free_port', '')))

    def _start_devices(self, logs: Path):
        """The experiment's device processes (emulators), before any node."""
        for name, (package, executable, args) in self.exp.devices.items():
            spec = NodeSpec(package, executable, args=[self._placeholders(a) for a in args])
            self.devices[name] = NodeProcess(spec, logs, label=name)

    def _specs(self):
        specs = []
        for entry in self.exp.nodes:
            for ref in entry.params_files:
                resolve_params_file(ref)  # fail early with a clear message
            # the lock-step rig's first step waits for the live view's subscriptions too
            params = {**{k: self._placeholders(v) for k, v in entry.params.items()},
                      **clock_overrides(self.exp, entry, self.dt, self._expected())}
            specs.append((getattr(entry, 'process', None),
                          NodeSpec(entry.package, entry.executable, entry.name,
                                   [str(resolve_params_file(r)) for r in entry.params_files],
                                   params, entry.remaps)))
        return specs

    def _start_nodes(self, logs: Path, env, extra=()):
        """One process per node, or one ``container`` per ``process:`` group."""
        groups = {}
        for process, spec in [*self._specs(), *extra]:
            if process is None:
                self.procs[spec.name] = NodeProcess(spec, logs, env=env)
            else:
                groups.setdefault(process, []).append(spec)
        for process, specs in groups.items():
            spec_file = logs / f'{process}.container.yaml'
            spec_file.write_text(yaml.safe_dump({'nodes': [
                {'package': s.package, 'executable': s.executable,
                 'ros_args': s.ros_args(logs / f'{s.name}.params.yaml')} for s in specs]},
                sort_keys=False))
            container = NodeSpec('irs_bringup', 'container', args=[str(spec_file)])
            self.procs[process] = NodeProcess(container, logs, env=env, label=process)
            self.members[process] = [s.name for s in specs]

    def _recorder_spec(self, bag_dir):
        # No use_sim_time: the recorder logs receive times on the system clock either way, and
        # without it it does not take /clock every step (unless /clock is recorded).
        # status every 0.1 s: the runner's drain reads the counts (_drain)
        # the experiment's node parameters are in 'metadata': the recorder asks for none
        params = {'topics': list(self.exp.record_topics), 'output': str(bag_dir),
                  'metadata': json.dumps(experiment_metadata(self.exp)),
                  'status_period': DRAIN_STATUS_PERIOD, 'node_parameters': False}
        if self.exp.record_process is not None:
            params['chunk_messages'] = COMPOSED_CHUNK_MESSAGES
        return NodeSpec('irs_bag', 'recorder', 'recorder', params=params)

    def _view_spec(self):
        """The ``live_view`` node (:mod:`irs_bag.live_view_node`): ``view`` ending in ``.rrd``
        is a file to write, ``ws://host:port`` a Foxglove WebSocket server to serve, anything
        else the URL of a rerun viewer.
        """
        target = str(self.view)
        if target.endswith('.rrd'):
            where = {'save': str(Path(target).resolve())}
        elif target.startswith('ws://'):
            where = {'foxglove': target, 'url': ''}
        else:
            where = {'url': target}
        params = {'metadata': json.dumps(experiment_metadata(self.exp)),
                  'run_name': self.run_dir.name, **where}
        if self.view_topics is not None:
            params['topics'] = list(self.view_topics)
        return NodeSpec('irs_bag', 'live_view', 'live_view', params=params)

    def _check_alive(self):
        for name, proc in [*self.procs.items(), *self.devices.items()]:
            code = proc.poll()
            if code is not None:
                what = (f"process '{name}' (nodes {', '.join(self.members[name])})"
                        if name in self.members else f"node '{name}'")
                hint = ''
                bag = self.run_dir / 'bag'
                if 'recorder' in self.members.get(name, [name]) and any(bag.glob('*.mcap')):
                    hint = (f'; the bag is unfinished: `bag recover {bag}` writes a closed '
                            f'copy of what it recorded')
                raise ExperimentFailed(f'{what} died (exit code {code}){hint}',
                                       f'its last output:\n{proc.tail(15)}')

    def _holds_recorder(self, label: str) -> bool:
        """Whether the process ``label`` is the recorder or a container holding it."""
        return label == 'recorder' or 'recorder' in self.members.get(label, ())

    def _stop_all(self) -> dict:
        """Every node at once, then the recorder (class docstring), then the devices (the
        emulators outlive the nodes that talk to them); ``{label: exit code}``.
        """
        holds = {label: self._holds_recorder(label) for label in self.procs}
        codes = stop_processes([p for label, p in self.procs.items() if not holds[label]],
                               NODE_GRACE)
        recording = [p for label, p in self.procs.items() if holds[label]]
        if recording:     # the recorder alone, or a container with it: it closes the bag
            codes.update(stop_processes(recording, RECORDER_GRACE))
        if self.devices:
            codes.update(stop_processes(list(self.devices.values()), NODE_GRACE))
        for label, proc in [*self.procs.items(), *self.devices.items()]:
            if proc.escalated_to:
                grace = RECORDER_GRACE if self._holds_recorder(label) else NODE_GRACE
                where = (f'; it was asked for its Python stacks (SIGUSR1) before that, see '
                         f'the end of {proc.log_path}' if proc.stacks_dumped else
                         f'; its log: {proc.log_path}')
                if proc.native_stacks:
                    where += f'; its native stacks: {proc.native_stacks}'
                self.log(f'[experiment] {label} did not stop within {grace:g} s of SIGINT: '
                         f'ended by {proc.escalated_to} (exit code {codes.get(label)}){where}')
        return codes

    def scheduling_report(self) -> str:
        """Which node processes got SCHED_FIFO (``--rt-priority``): it needs root or
        CAP_SYS_NICE, and a process that is refused runs at normal priority.
        """
        fifo = []
        for label, proc in self.procs.items():
            try:
                if os.sched_getscheduler(proc.pid) == os.SCHED_FIFO:
                    fifo.append(label)
            except OSError:
                pass
        return (f'SCHED_FIFO priority {self.rt_priority} granted to {len(fifo)} of '
                f'{len(self.procs)} processes' + (f' ({", ".join(sorted(fifo))})' if fifo else
                                                  ' (needs root or CAP_SYS_NICE)'))

    def _check_stop(self):
        if self.stop_signal is not None:
            raise _StopRequested()

    def request_stop(self, signum: int = 0):
        """Stop the run at its next check (within 50 ms of spinning); safe in a signal handler."""
        if self.stop_signal is None:
            self.stop_signal = int(signum)

    def kill(self):
        """SIGKILL to every node's process group (a second signal: no waiting)."""
        kill_processes([*self.procs.values(), *self.devices.values()])

    # ------------------------------------------------------------------ run
    def run(self) -> RunResult:
        """Run the experiment. In the main thread SIGINT, SIGTERM and SIGHUP stop it (module
        docstring); elsewhere :meth:`request_stop` does.
        """
        if threading.current_thread() is not threading.main_thread():
            return self._run()
        outer = current_guard()
        guard = SignalGuard()
        guard.on_first = self.request_stop
        guard.force_hooks.append(self.kill)
        if outer is not None and outer.signum is not None:
            self.request_stop(outer.signum)      # stopped before the run began
        guard.install()
        try:
            return self._run()
        finally:
            guard.restore()
            if outer is not None and self.stop_signal:
                outer.signum = outer.signum or self.stop_signal

    def _run(self) -> RunResult:
        exp = self.exp
        self.run_dir = make_run_dir(self.run_dir)      # another run may have taken the name
        logs = self.run_dir / 'logs'
        logs.mkdir()
        bag_dir = self.run_dir / 'bag' if exp.record_topics else None
        context = Context()
        # The runner's own signal handling (run): rclpy's handlers would shut the context down
        # under the waits instead.
        rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
        watcher = make_watcher('irs_experiment_runner', context=context)
        t_wall0 = time.monotonic()
        clock = {'t': 0.0}
        cpu0 = {}
        running = float('nan')
        t_start = None
        completed = False
        message = ''
        self.phase = 'starting'
        try:
            env = None
            if self.rt_priority:
                env = dict(os.environ, IRS_RT_PRIORITY=str(self.rt_priority))
            extra = []
            if bag_dir is not None and exp.record_process is not None:
                extra.append((exp.record_process, self._recorder_spec(bag_dir)))
            elif bag_dir is not None:
                self.procs['recorder'] = NodeProcess(self._recorder_spec(bag_dir), logs)
            if self.view is not None:      # its own process: never in the loop's executor
                self.procs['live_view'] = NodeProcess(self._view_spec(), logs)
            self._check_stop()
            self._start_devices(logs)
            self._start_nodes(logs, env, extra)
            n = len(self.procs)
            self.log(f'[experiment] {exp.name}: {exp.deployment_line()}; started {n} '
                     f"process{'es' if n != 1 else ''}, logs in {logs}")
            self._wait_for_graph(watcher)
            if self.rt_priority:
                self.log(f'[experiment] {self.scheduling_report()}')
            node = watcher.node
            node.create_subscription(
                RigStatus, 'rig/status', lambda m: clock.update(
                    t=to_sec(m.header.stamp), complete=m.run_complete, rig=m), qos.STATUS)
            node.create_subscription(
                DiagnosticArray, 'rig/timing', lambda m: clock.update(
                    timing={kv.key: _number(kv.value) for kv in m.status[0].values}), qos.STATUS)
            if bag_dir is not None:
                node.create_subscription(
                    String, 'recorder/status', lambda m: self.recorder_status.append(
                        (time.monotonic(), json.loads(m.data).get('messages', {}))),
                    QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                               durability=DurabilityPolicy.TRANSIENT_LOCAL))
            self._start_rig(watcher)
            cpu0 = {label: proc.cpu_seconds() for label, proc in self.procs.items()}
            self.phase = 'running'
            self.log(f'[experiment] running: {self.exp.duration:g} s '
                     + ('in lock-step on /clock' if self.exp.clock == 'lockstep'
                        else 'in real time'))
            t_start = time.monotonic()
            completed = self._follow(watcher, clock, t_start)
            running = clock.get('done_at', time.monotonic()) - t_start
            message = 'completed' if completed else 'stopped'
            if self.safe_stop:
                message += f', the rig in its controlled stop since {self.safe_stop}'
        except (KeyboardInterrupt, _StopRequested):
            if self.stop_signal is None:
                self.stop_signal = signal.SIGINT     # a KeyboardInterrupt of the caller's own
            how = signal.Signals(self.stop_signal).name if self.stop_signal else 'a stop request'
            message = f'interrupted ({how})'
            self.log(f'\n[experiment] {message}: shutting down')
        except ExperimentFailed as exc:
            message = str(exc)
            self.log(f'\n[experiment] FAILED: {message}'
                     + (f'\n{exc.detail}' if exc.detail else ''))
        finally:
            self.phase = 'stopping'
            codes = self._stop_all()
            watcher.node.destroy_node()
            rclpy.try_shutdown(context=context)
            self.phase = 'done'
        if t_start is not None and running != running:     # stopped while running
            running = time.monotonic() - t_start
        sim_time = clock['t'] if exp.clock == 'lockstep' else (
            running if running == running else 0.0)
        timing = clock.get('timing', {})
        if timing:
            (self.run_dir / 'timing.json').write_text(json.dumps(timing, indent=1))
            self.log(
                '[experiment] real-time loop: {steps} steps, {miss_pct:.3f} % deadline misses, '
                'latency p50 {p50} / p99 {p99} / max {latency_max_ms:.3f} ms, {late_ticks} late '
                'ticks'.format(p50=format_ms(timing['latency_p50_ms']),
                               p99=format_ms(timing['latency_p99_ms']), **timing)
            )
        cpu = {label: getattr(proc, 'cpu_at_stop', float('nan')) - cpu0.get(label, float('nan'))
               for label, proc in self.procs.items()}   # CPU of the run itself, start-up excluded
        result = RunResult(self.run_dir, bag_dir, completed, sim_time, time.monotonic() - t_wall0,
                           codes, message, timing, cpu, running,
                           None if completed else self.stop_signal, self.safe_stop)
        write_result(result, exp)
        return result

    def _recorder_caught_up(self, steps: int, since: float) -> bool:
        """The recorder's status counts every step's ``/clock``, and its counts of every topic
        have stood still over the statuses of the last ``DRAIN_QUIET`` s, or
        ``drain_quiet_behind`` s if a status since ``since`` lacked some of ``/clock`` or if
        the recorder and some node run in different processes (each topic is its own DDS
        stream: ``/clock`` complete does not mean the others are, and what a reader missed comes
        again only at the writer's next heartbeat; in one process every message is handed over).
        """
        if not self.recorder_status:
            return False
        t_last, last = self.recorder_status[-1]
        if last.get('/clock', 0) < steps + 1:
            return False
        groups = self.exp.processes()
        recorder_group = groups.pop('recorder', None)
        behind = (recorder_group is None or any(g != recorder_group for g in groups.values())
                  or any(t >= since and c.get('/clock', 0) < steps + 1
                         for t, c in self.recorder_status))
        still_since = t_last
        for t_st, counts in reversed(self.recorder_status):
            if counts != last:
                break
            still_since = t_st
        return t_last - still_since >= (self.drain_quiet_behind if behind else DRAIN_QUIET)

    def _expected(self) -> dict:
        """``{topic: (publishers, subscribers)}`` to wait for: the experiment's, and the live
        view's subscription on each of its topics the graph carries (so that the view sees the
        run from its first step).
        """
        expected = dict(expected_endpoints(self.exp))
        if self.view is not None:
            from irs_bag.live_view_params import OUTSIDE_THE_LOOP
            for suffix in (OUTSIDE_THE_LOOP if self.view_topics is None else self.view_topics):
                topic = '/' + suffix
                if topic in expected:
                    pubs, subs = expected[topic]
                    expected[topic] = (pubs, subs + 1)
        return expected

    def _wait_for_graph(self, watcher):
        names = [n for label in self.procs for n in self.members.get(label, [label])]
        expected = self._expected()
        deadline = time.monotonic() + self.graph_timeout

        def ready():
            self._check_stop()
            self._check_alive()
            if not {'/' + n for n in names} <= watcher.node_names():
                return False
            node = watcher.node
            for topic, (pubs, subs) in expected.items():
                if node.count_publishers(topic) < pubs or node.count_subscribers(topic) < subs:
                    return False
            return True

        if not watcher.spin_until(ready, max(0.0, deadline - time.monotonic())):
            missing = sorted({'/' + n for n in names} - watcher.node_names())
            node = watcher.node
            lacking = [
                f'{t} ({node.count_publishers(t)}/{p} pub, {node.count_subscribers(t)}/{s} sub)'
                for t, (p, s) in expected.items()
                if node.count_publishers(t) < p or node.count_subscribers(t) < s
            ]
            raise ExperimentFailed(f'graph not up after {self.graph_timeout:.0f} s; missing nodes '
                                   f'{missing}, unmatched topics {lacking}')
        self.log(f'[experiment] graph up: {len(names)} nodes, {len(expected)} topics connected')

    def _start_rig(self, watcher):
        if self.exp.rig() is None:
            return
        client = watcher.node.create_client(Trigger, 'rig/start')
        if not watcher.spin_until(lambda: self._check_stop() or client.service_is_ready(), 20.0):
            raise ExperimentFailed('rig/start service not available')
        ok, message = call_rig_start(watcher, client, check=self._check_stop)
        if not ok:
            raise ExperimentFailed(f'rig/start failed: {message}')

    def _follow(self, watcher, clock, t_start) -> bool:
        exp = self.exp
        last_t, last_change = -1.0, time.monotonic()
        # a terminal gets a bar at once, redrawn every 0.5 s; a log a line every 10 s from
        # 10 s on (a bar at 0 s in a log says nothing)
        last_print = 0.0 if sys.stdout.isatty() else last_change
        end = exp.duration - 0.5 * self.dt
        while True:
            watcher.executor.spin_once(timeout_sec=0.05)
            self._check_stop()
            self._check_alive()
            now = time.monotonic()
            t = clock['t'] if exp.clock == 'lockstep' else now - t_start
            if t != last_t:
                last_t, last_change = t, now
            elif exp.clock == 'lockstep' and now - last_change > self.stall_timeout:
                raise ExperimentFailed(f'no progress for {self.stall_timeout:.0f} s at '
                                       f't = {t:.3f} s (a lock-step input is missing)')
            tty = sys.stdout.isatty()
            if self.progress and now - last_print > (0.5 if tty else 10.0):
                last_print = now
                frac = min(1.0, t / exp.duration)
                line = (f'[experiment] {exp.name} [{"#" * int(30 * frac):<30}] '
                        f'{t:6.2f}/{exp.duration:.2f} s (wall {now - t_start:5.1f} s)')
                sys.stdout.write('\r' + line if tty else line + '\n')
                sys.stdout.flush()
            rig = clock.get('rig')
            if rig is not None and not rig.car_on_belt:
                raise ExperimentFailed(f'the car left the belt ({rig.fault_text}) at '
                                       f't = {t:.3f} s; the run is stopped')
            if rig is not None and rig.safe_state >= RigStatus.SAFE_STOPPING \
                    and not self.safe_stop:
                self.safe_stop = f't = {t:.2f} s ({rig.stop_cause})'
                self.log(('\n' if self.progress and tty else '')
                         + f'[experiment] the rig stops car and belt under control at '
                         f'{self.safe_stop}')
            rig_done = clock.get('complete') or (self.exp.rig() is None and t >= end)
            if rig_done or (exp.clock == 'realtime' and t >= end + 5.0):
                if self.progress and tty:
                    sys.stdout.write('\n')
                clock['done_at'] = time.monotonic()
                self._drain(watcher)
                return True

    def _drain(self, watcher, seconds: float = DRAIN_QUIET):
        """Every node has published all of the run (the rig saw the last step's answers); wait
        until the recorder has what is still on its way, then the nodes may stop (a publisher
        stopped earlier takes its unsent messages with it).

        A lock-step run that records ``/clock``: until the recorder's status
        (``recorder/status``, every ``DRAIN_STATUS_PERIOD`` s) counts every step's ``/clock``
        and its counts have stood still (:meth:`_recorder_caught_up`: a recorder in its own
        process can be seconds behind a loaded rig), at most ``DRAIN_TIMEOUT`` s, then a
        warning line and ``seconds`` more. Other runs: ``seconds`` of wall time for the last
        messages.
        """
        steps = int(round(self.exp.duration / self.dt))
        need_clock = (self.exp.clock == 'lockstep'
                      and '/clock' in {absolute(t) for t in self.exp.record_topics})
        start = time.monotonic()
        while need_clock:
            watcher.executor.spin_once(timeout_sec=0.05)
            self._check_stop()
            self._check_alive()
            if self._recorder_caught_up(steps, start):
                return
            if time.monotonic() - start > DRAIN_TIMEOUT:
                got = self.recorder_status[-1][1].get('/clock', 0) if self.recorder_status else 0
                self.log(f'[experiment] warning: the recorder was still receiving '
                         f'{DRAIN_TIMEOUT:.0f} s after the run ({got} of the {steps + 1} /clock '
                         'messages); stopping')
                break
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            watcher.executor.spin_once(timeout_sec=0.05)
            self._check_stop()
            self._check_alive()
