"""Node processes: start through the ament-resolved executable, stop cleanly, never leak.

Each node runs as its own process in its own session (process group), with its output going to a
log file (a pipe could fill up and block a 1 kHz node), and is set to receive SIGTERM should the
starting process die without stopping it. Stopping sends SIGINT (what Ctrl-C in
``ros2 run`` sends), then SIGTERM, then SIGKILL to the whole group, each after a timeout, so no
child survives; :func:`stop_processes` does it for many at once, with one deadline for all.
Before the SIGTERM a process that catches SIGUSR1 (every IRS node: ``run_node`` prints the Python
stack of each thread on it) gets SIGUSR1, so its log shows where it was waiting. A
process that does not handle SIGTERM yet (still starting: the interpreter and its imports, before
``run_node`` installs its handlers; read from ``/proc/<pid>/status``) gets SIGTERM instead of
SIGINT: the default action ends it at once and silently, where SIGINT would print Python's
``KeyboardInterrupt`` report. No rclpy here.

The SIGUSR1 dump (``faulthandler``) reads the other threads' frames while they run, and CPython
3.11 can crash doing so (python/cpython#116008): a composed graph whose recorder thread is busy
has been seen to end in SIGSEGV there. With ``IRS_NATIVE_STACKS`` set (the test suite sets it)
and ``gdb`` on the PATH, a process that has not stopped by the SIGTERM is therefore not sent
SIGUSR1; ``gdb -batch`` writes every thread's Python stack (``py-bt``, where the interpreter's
gdb extension is installed) and native stack (``bt``) to ``<label>.native_stacks.txt`` beside
its log, the process paused meanwhile (at most :data:`NATIVE_STACKS_TIMEOUT` s; what gdb
wrote by then is kept, and a last line says it did not finish).
"""
from dataclasses import dataclass, field
import os
from pathlib import Path
import shutil
import signal
import subprocess
import time

from irs_common.params import unflatten

from .executables import resolve_executable

_PR_SET_PDEATHSIG = 1


def _die_with_parent():
    """In the child before exec: get SIGTERM when the parent dies (Linux prctl), so even a
    SIGKILLed runner leaves no node behind.
    """
    try:
        import ctypes
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except OSError:
        pass


@dataclass
class NodeSpec:
    """How to start one node, as ``ros2 run <package> <executable> --ros-args ...`` would."""

    package: str
    executable: str
    name: str = ''                                        # node name remap ('' = the node's own)
    params_files: list = field(default_factory=list)      # --params-file paths, in order
    params: dict = field(default_factory=dict)            # -p name:=value overrides
    remaps: dict = field(default_factory=dict)            # -r from:=to
    args: list = field(default_factory=list)              # plain arguments before --ros-args

    def command(self, overrides_file=None) -> list:
        """The full argument vector, executable resolved through the ament index.

        ``params`` go into ``overrides_file`` (a parameter YAML, applied after ``params_files``)
        when given -- any value survives that, where ``-p`` cannot carry e.g. multi-line strings
        -- and are passed as ``-p name:=value`` otherwise.
        """
        cmd = [resolve_executable(self.package, self.executable), *map(str, self.args)]
        ros = self.ros_args(overrides_file)
        return cmd + (['--ros-args', *ros] if ros else [])

    def ros_args(self, overrides_file=None) -> list:
        """What follows ``--ros-args``: node name, parameter files, overrides, remaps."""
        ros = []
        if self.name:
            ros += ['-r', f'__node:={self.name}']
        for path in self.params_files:
            ros += ['--params-file', str(path)]
        if self.params and overrides_file is not None:
            import yaml
            Path(overrides_file).write_text(yaml.safe_dump(
                {'/**': {'ros__parameters': unflatten(self.params)}}, sort_keys=False))
            ros += ['--params-file', str(overrides_file)]
        else:
            for key, value in self.params.items():
                ros += ['-p', f'{key}:={_param_text(value)}']
        for src, dst in self.remaps.items():
            ros += ['-r', f'{src}:={dst}']
        return ros


def _param_text(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, (list, tuple)):
        return '[' + ','.join(_param_text(v) for v in value) + ']'
    if isinstance(value, str):
        return value if value else "''"
    return repr(value)


class NodeProcess:
    """A running node process (see module docstring)."""

    def __init__(self, spec: NodeSpec, log_dir, env=None, label=None):
        self.spec = spec
        self.label = label or spec.name or spec.executable
        self.log_path = Path(log_dir) / f'{self.label}.log'
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        self.cmd = spec.command(overrides_file=Path(log_dir) / f'{self.label}.params.yaml')
        self.escalated_to = None    # 'SIGTERM' or 'SIGKILL' if the last stop needed it
        self.stacks_dumped = False  # the process printed its stacks before that (SIGUSR1)
        self.native_stacks = None   # the file of its native stacks, if written (module docstring)
        self._log = open(self.log_path, 'wb')
        self.popen = subprocess.Popen(self.cmd, stdout=self._log, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL, env=env, start_new_session=True,
                                      preexec_fn=_die_with_parent)

    @property
    def pid(self) -> int:
        return self.popen.pid

    def poll(self):
        """Exit code, or None while running."""
        return self.popen.poll()

    def output(self) -> str:
        """Everything the process has printed so far."""
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors='replace')

    def tail(self, lines: int = 20) -> str:
        return '\n'.join(self.output().splitlines()[-lines:])

    def write_native_stacks(self) -> str:
        """Where the running process waits, for a failure's report: ``gdb``'s Python and native
        stacks of its threads (as at a stop, module docstring), or a line saying why there are
        none.
        """
        if self.poll() is not None:
            return f'{self.label}: no stacks, it has exited ({self.poll()})'
        if not _write_native_stacks([self]) or self.native_stacks is None:
            return f'{self.label}: no stacks (IRS_NATIVE_STACKS unset or no gdb)'
        return self.native_stacks.read_text(errors='replace')

    def cpu_seconds(self) -> float:
        """User + system CPU time [s] the process has used so far (Linux /proc), NaN if gone."""
        return cpu_seconds(self.popen.pid)

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT, then SIGTERM after ``timeout`` s, then SIGKILL after ``timeout / 2`` s more
        (process group); the exit code.
        """
        return stop_processes([self], timeout, timeout / 2)[self.label]

    def interrupt(self):
        """The first stop signal: SIGINT, or SIGTERM while the process does not handle it yet."""
        self.cpu_at_stop = self.cpu_seconds()
        self.signal_group(signal.SIGINT if handles_sigterm(self.popen.pid) else signal.SIGTERM)

    def finish(self) -> int:
        """After the process ended: kill what is left of its group, close the log."""
        self.signal_group(signal.SIGKILL)  # leftovers of the group, if any
        if not self._log.closed:
            self._log.close()
        return self.popen.returncode

    def signal_group(self, sig):
        try:
            os.killpg(self.popen.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass


def cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] process ``pid`` has used so far (Linux /proc), NaN if gone."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    except OSError:
        return float('nan')
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def handles_sigterm(pid: int) -> bool:
    """Whether ``pid`` has a handler for SIGTERM: an IRS process installs one (``run_node``,
    ``irs_common.cli``) once it is past its imports.
    """
    return catches_signal(pid, signal.SIGTERM)


def catches_signal(pid: int, sig: int) -> bool:
    """Whether ``pid`` has a handler for ``sig`` (``SigCgt`` of ``/proc/<pid>/status``)."""
    try:
        for line in Path(f'/proc/{pid}/status').read_text().splitlines():
            if line.startswith('SigCgt:'):
                return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    except (OSError, ValueError):
        pass
    return False


def stop_processes(procs, grace: float = 5.0, term_grace: float = 2.0) -> dict:
    """Stop every process of ``procs`` at once: the first stop signal to all
    (:meth:`NodeProcess.interrupt`), SIGTERM to those still running after ``grace`` s, SIGKILL
    after ``term_grace`` s more; ``{label: exit code}``. Takes at most ``grace + term_grace``
    s plus the kill.
    """
    procs = list(procs)
    for p in procs:
        p.escalated_to, p.stacks_dumped, p.native_stacks = None, False, None
        if p.popen.poll() is None:
            p.interrupt()
        else:
            p.cpu_at_stop = float('nan')
    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, term_grace), (None, 5.0)):
        deadline = time.monotonic() + wait
        for p in procs:
            try:
                p.popen.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        left = [p for p in procs if p.popen.poll() is None]
        if not left or sig is None:
            break
        if sig == signal.SIGTERM and not _write_native_stacks(left) and _dump_stacks(left):
            time.sleep(STACK_DUMP_WAIT)
        for p in left:
            p.escalated_to = signal.Signals(sig).name
            p.signal_group(sig)
    return {p.label: p.finish() for p in procs}


#: Seconds given to the processes' stack dumps (SIGUSR1) before the SIGTERM.
STACK_DUMP_WAIT = 0.2


def _dump_stacks(procs) -> bool:
    """SIGUSR1 to each process of ``procs`` that catches it (module docstring); whether any did."""
    sent = False
    for p in procs:
        if catches_signal(p.popen.pid, signal.SIGUSR1):
            try:
                os.kill(p.popen.pid, signal.SIGUSR1)
                sent = p.stacks_dumped = True
            except (ProcessLookupError, PermissionError):
                pass
    return sent


#: The most [s] ``gdb`` may take for one process's native stacks.
NATIVE_STACKS_TIMEOUT = 10.0


def _write_native_stacks(procs) -> bool:
    """``gdb``'s Python and native stacks of every thread of each process of ``procs`` into
    ``<label>.native_stacks.txt`` beside its log, with ``IRS_NATIVE_STACKS`` set and ``gdb``
    found (module docstring); sets ``native_stacks`` to the file written. Whether it ran.
    """
    gdb = shutil.which('gdb')
    if not os.environ.get('IRS_NATIVE_STACKS') or gdb is None:
        return False
    for p in procs:
        out = p.log_path.with_name(f'{p.label}.native_stacks.txt')
        try:
            with open(out, 'w') as f:
                # the interpreter's gdb extension (py-bt) sits beside its binary
                subprocess.run([gdb, '-p', str(p.popen.pid), '-batch', '-nx',
                                '-iex', 'set auto-load safe-path /',
                                '-ex', 'thread apply all py-bt', '-ex', 'thread apply all bt'],
                               stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                               timeout=NATIVE_STACKS_TIMEOUT)
        except subprocess.TimeoutExpired:     # what gdb wrote before it hung is kept
            try:
                with open(out, 'a') as f:
                    f.write(f'\n[gdb did not finish within {NATIVE_STACKS_TIMEOUT:g} s]\n')
            except OSError:
                continue
        except OSError:
            continue
        p.native_stacks = out
    return True


def kill_processes(procs) -> None:
    """SIGKILL to the group of every process (a second Ctrl-C: no waiting)."""
    for p in procs:
        p.signal_group(signal.SIGKILL)


def wait_until(predicate, timeout: float, interval: float = 0.02) -> bool:
    """Poll ``predicate`` until it is true or ``timeout`` s have passed; return its last value."""
    deadline = time.monotonic() + timeout
    while True:
        if predicate():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(interval)
