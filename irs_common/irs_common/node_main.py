"""Run one node, or several composed in one process, on the lean executor; exit cleanly.

``run_node(NodeClass)`` is every IRS executable's ``main``: ``rclpy.init``, build the node, spin it
on :class:`~irs_common.executor.LeanExecutor` until SIGINT/SIGTERM (exit code 0), clean up.
``run_nodes([...])`` does the same for several nodes in one process (composition, see
``irs_bringup``'s ``container``): they stay separate nodes on topics, sharing one executor, and
hand messages to each other in-process while nobody outside listens
(:mod:`irs_common.intra_process`; ``IRS_INTRA_PROCESS=0`` sends everything through DDS).

Start-up failures are one line on stderr and exit code 2, never a traceback: a configuration
error raised by a node's constructor (``ValueError``), an rclpy parameter exception (wrong type,
out of range), and an ``RCLError`` from a bad ``--ros-args`` or ``--params-file``; a
``--params-file`` with no section for the node (a misspelt node name) and a later file that
gives a parameter another type are start-up errors too
(:func:`irs_common.params.params_file_problems`).

Signals end the process with exit code 0. SIGUSR1 prints the Python stack of every thread to
stderr (:mod:`faulthandler`, which works while the main thread is blocked in C) and the node
goes on: ``kill -USR1 <pid>`` shows where a node that does not stop is waiting, and the
experiment runner sends it before escalating to SIGTERM. The environment switches on real-time
priority (``IRS_RT_PRIORITY``), allocation tracing (``IRS_MEMTRACE``) and profiling
(``IRS_PROFILE``): :func:`run_nodes`. It exists so that every executable starts, fails and
stops the same way.
"""
import faulthandler
import gc
import os
import signal
import sys

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.signals import SignalHandlerOptions

from . import cli, loop_trace, node_help
from .cli import SignalGuard
from .executor import LeanExecutor, TracedLeanExecutor
from .intra_process import enabled_by_env as intra_process_enabled
from .params import (check_pending_params_files, expect_params_files, parameter_table,
                     ros_args_params_files)
from .sim_time import guard_clock

#: Exceptions that mean "the command line or the parameters are wrong", reported in one line.
START_ERRORS = (ValueError, ParameterException, _rclpy.RCLError, _rclpy.RCLInvalidROSArgsError,
                 _rclpy.UnknownROSArgsError)


def set_realtime_priority(env=os.environ) -> str:
    """Apply ``IRS_RT_PRIORITY`` (SCHED_FIFO) if set; return a note for the log ('' if unset)."""
    text = env.get('IRS_RT_PRIORITY', '').strip()
    if not text:
        return ''
    try:
        prio = int(text)
        if not 1 <= prio <= 99:
            raise ValueError
    except ValueError:
        return f'IRS_RT_PRIORITY={text!r} ignored: expected an integer 1..99'
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(prio))
    except OSError as exc:
        return f'SCHED_FIFO {prio} refused ({exc.strerror}); running at normal priority'
    return f'SCHED_FIFO priority {prio}'


def _fail(text: str) -> int:
    print(f'[FATAL] {text}', file=sys.stderr, flush=True)
    return 2


def run_nodes(factories, args=None, guard=None) -> int:
    """Build every node of ``factories`` (callables, in order), spin them on one executor.

    Returns the process exit code: 0 after SIGINT/SIGTERM/SIGHUP, 2 after a start-up error.
    ``guard``: a :class:`~irs_common.cli.SignalGuard` the caller installed before its own
    start-up work (the ``container``); one is installed here otherwise, and kept to the end of
    the process unless ``args`` are given (a signal after the stop leaves at once).

    Signals (SIGINT, SIGTERM, SIGHUP; :class:`irs_common.cli.SignalGuard`): while the nodes are
    built a signal abandons the start-up at once; while they spin it asks the executor to stop
    after the callback in progress (within its 10 ms wait); both end with exit code 0. A second
    signal while the nodes are destroyed (the recorder closing its bag) leaves at once with 128 +
    the signal.

    Real-time priority: with ``IRS_RT_PRIORITY=<1..99>`` in the environment the process switches to
    ``SCHED_FIFO`` at that priority before rclpy starts its DDS threads (which inherit it), as
    ros2_control's real-time loops do. It needs root or ``CAP_SYS_NICE`` (``ulimit -r``); if the
    switch is refused, a warning says so and the node runs at normal priority.

    Garbage collection: the objects built before spinning are frozen (``gc.freeze``), so the rare
    full collection does not scan them (scanning them pauses the composed 1 kHz loop for up to 79
    ms).

    Memory: with ``IRS_MEMTRACE=<prefix>`` the spin runs under ``tracemalloc`` and every
    ``IRS_MEMTRACE_PERIOD`` s (default 300) the 25 allocation sites that grew most since the first
    minute are written to ``<prefix>.<pid>.txt`` (a soak finds a leak's line this way).

    Timeline: with ``IRS_TRACE=<prefix>`` the executor records when each wait was due and
    when it woke, the long timer callbacks, the bag's chunks and the garbage collections, into
    ``<prefix>.<pid>.npz`` at exit (:mod:`irs_common.loop_trace`, which also reads them).

    Profiling: with ``IRS_PROFILE=<prefix>`` the spin runs under ``cProfile`` and the statistics
    are written to ``<prefix>.<pid>.prof`` at exit (read them with ``python -m pstats``); an
    experiment's processes inherit the variable, so ``IRS_PROFILE=/tmp/p ./irs run irs_bringup
    experiment run X`` profiles every node of a run.
    """
    own_guard = guard is None
    nodes = []
    executor = None
    given, guard = guard, None
    try:
        # a first signal raises Interrupted (a KeyboardInterrupt) from the moment the guard's
        # handler is installed, even inside _take_guard: caught below, exit 0
        guard = _take_guard(given)
        register_stack_dump()
        rt_note = set_realtime_priority()
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except START_ERRORS as exc:
            return _fail(init_error_text(exc))
        _build_nodes(factories, nodes, sys.argv if args is None else args)
        if rt_note:
            nodes[0].get_logger().info(rt_note)
        # Composed nodes hand their messages over in-process (irs_common.intra_process).
        executor = _make_executor(nodes, len(nodes) > 1 and intra_process_enabled())
        for node in nodes:
            executor.add_node(node)
        # Every object built so far (modules, nodes, the cores' tables: ~140,000 objects) goes
        # to the collector's permanent generation. Otherwise a full (generation 2) collection
        # scans them all, and it comes once in a while, unannounced: 79 ms measured in the
        # composed real-time loop, 79 deadlines at 1 kHz. Start-up garbage is not collected
        # (a few kB); everything made while spinning is collected as before.
        gc.freeze()
        # From here a signal only stops the executor after the callback in progress: rclpy's
        # own handlers (disabled above) raise at an arbitrary bytecode, seen to cut the
        # composed recorder's bag writer between a chunk and its message indexes.
        guard.on_first = lambda _signum: executor.request_stop()
        if guard.signum is None:
            _spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except START_ERRORS as exc:
        if executor is not None:
            raise   # a failure while running is a bug: keep its traceback
        if guard.signum is not None or not rclpy.ok():
            return 0    # shut down by a signal while starting up
        return _fail(f'configuration error: {_one_line(exc)}')
    except Exception:
        if rclpy.ok() and guard.signum is None:
            raise
        return 0  # a signal shut the context down while a node was being built
    finally:
        _tear_down(guard, executor, nodes, release=own_guard and args is not None)
    return 0


def _make_executor(nodes, intra_process: bool) -> LeanExecutor:
    """The executor of the process: traced with ``IRS_TRACE=<prefix>`` (:mod:`loop_trace`;
    ``ValueError`` for a prefix in a folder that does not exist).
    """
    prefix = os.environ.get('IRS_TRACE', '').strip()
    if not prefix:
        return LeanExecutor(intra_process=intra_process)
    trace = loop_trace.start(prefix)
    trace.nodes = [node.get_fully_qualified_name() for node in nodes]
    trace.sim_time = any(node.get_clock().ros_time_is_active for node in nodes)
    return TracedLeanExecutor(trace, intra_process=intra_process)


def _tear_down(guard, executor, nodes, release: bool) -> None:
    """The end of :func:`run_nodes`: executor, nodes and context down; the guard released
    if ``release`` (called in-process; as the process's main the guard stays).
    """
    if guard is not None:
        guard.on_first = None
        guard.ending = True      # a signal from here on leaves at once
    if executor is not None:
        executor.shutdown(timeout_sec=0)
    for node in nodes:
        node.destroy_node()
    rclpy.try_shutdown()
    trace = loop_trace.stop()     # after the nodes: a recorder's last chunk is in it
    if trace is not None:
        try:
            print(f'[irs] loop trace: {trace.save()}', file=sys.stderr, flush=True)
        except OSError as exc:
            print(f'[irs] loop trace not written: {cli.os_error_text(exc)}', file=sys.stderr,
                  flush=True)
    if release and guard is not None:
        _release_guard(guard)


def register_stack_dump(sig: int = signal.SIGUSR1) -> None:
    """On ``sig``, print the Python stack of every thread to stderr and go on (module docstring).
    The dump is written from the C signal handler, so it shows a main thread stuck in a C call
    (rcl, DDS) too, where a Python handler would never run.
    """
    try:
        faulthandler.register(sig, file=sys.stderr, all_threads=True, chain=False)
    except (AttributeError, ValueError, RuntimeError, OSError):
        pass    # no usable stderr (closed, or not a file): no dump, the node runs as before


def _take_guard(guard: SignalGuard | None) -> SignalGuard:
    """The caller's guard, or a new one installed; the running command's guard
    (:func:`irs_common.cli.held_signals` in the nodes' start-up) unless one is set.
    """
    guard = guard or SignalGuard().install()
    if cli.GUARD is None:
        cli.GUARD = guard
    return guard


def _release_guard(guard: SignalGuard) -> None:
    guard.restore()
    if cli.GUARD is guard:
        cli.GUARD = None


def _build_nodes(factories, nodes: list, args) -> None:
    """Build the nodes in order into ``nodes``; ``ValueError`` for a ``--params-file`` that does
    not fit a node (no section for it, a parameter re-typed by a later file): checked by the
    node's first ``declare_table``, before it logs anything, or here after a node that has none.
    """
    global_files = ros_args_params_files(args)[0]
    for factory in factories:
        own_files = ros_args_params_files(getattr(factory, 'ros_args', ()))[0]
        expect_params_files(global_files + own_files)
        try:
            nodes.append(factory())
            check_pending_params_files(nodes[-1].get_fully_qualified_name())
        finally:
            expect_params_files(None)
        guard_clock(nodes[-1])   # a bad /clock message is dropped, not fatal


def _spin(executor) -> None:
    memtrace = os.environ.get('IRS_MEMTRACE', '').strip()
    if memtrace:
        _start_memtrace(memtrace, float(os.environ.get('IRS_MEMTRACE_PERIOD', '300')))
    prefix = os.environ.get('IRS_PROFILE', '').strip()
    if not prefix:
        executor.spin()
        return
    import cProfile
    profile = cProfile.Profile()
    try:
        profile.runcall(executor.spin)
    finally:
        profile.dump_stats(f'{prefix}.{os.getpid()}.prof')


def _start_memtrace(prefix: str, period: float) -> None:
    """A daemon thread: the allocation sites that grew since the first minute, every period."""
    import threading
    import time
    import tracemalloc
    tracemalloc.start(6)
    path = f'{prefix}.{os.getpid()}.txt'

    def watch():
        time.sleep(60.0)
        base = tracemalloc.take_snapshot()
        t0 = time.monotonic()
        while True:
            time.sleep(period)
            stats = tracemalloc.take_snapshot().compare_to(base, 'traceback')[:25]
            with open(path, 'a') as out:
                out.write(f'== {time.monotonic() - t0:.0f} s after the first minute\n')
                for stat in stats:
                    out.write(f'{stat.size_diff / 1024:+10.1f} KiB {stat.count_diff:+8d} '
                              f'blocks\n    ' + '\n    '.join(stat.traceback.format()) + '\n')
    threading.Thread(target=watch, daemon=True, name='irs-memtrace').start()


def run_node(node_factory, args=None) -> int:
    """``run_nodes([node_factory], args)``: the ``main`` of a single-node executable.

    ``args`` (default ``sys.argv``) outside ``--ros-args ... [--]``: ``-h``/``--help`` prints
    the node's usage and parameters and returns 0; anything else is refused in one line (exit
    code 2) before rclpy starts (:mod:`irs_common.node_help`).
    """
    answered = answer_own_arguments(node_factory, sys.argv if args is None else args)
    if answered is not None:
        return answered
    return run_nodes([node_factory], args)


def answer_own_arguments(node_factory, argv) -> int | None:
    """The exit code for a command line with arguments outside ``--ros-args``; None if it has
    none (then ``rclpy.init`` parses the ROS arguments and reports a malformed one).
    """
    own = node_help.own_arguments(argv)
    if not own:
        return None
    module = getattr(node_factory, '__module__', '') or ''
    package, executable = node_help.executable_of(module) or (
        module.split('.')[0], os.path.basename(argv[0] if argv else '') or module)
    if node_help.wants_help(own):
        text = node_help.help_text(package, executable, node_help.summary(module),
                                   parameter_table(package, executable))
        sys.stdout.write(text)
        sys.stdout.flush()
        return 0
    return _fail(node_help.refusal(own, executable))


def init_error_text(exc) -> str:
    """The one line for ``rclpy.init`` refusing the command line with ``exc`` (one of
    ``START_ERRORS``): ROS arguments rcl does not know, or ones it cannot parse.
    """
    if isinstance(exc, _rclpy.UnknownROSArgsError):
        text = _one_line(exc)
        hint = (' (--help goes before --ros-args, or after a closing --)'
                if "'--help'" in text or "'-h'" in text else '')
        return f'unknown ROS arguments after --ros-args: {text}{hint}'
    return f'bad command line: {_one_line(exc)}'


def _one_line(exc) -> str:
    """The exception's message on one line (rcl errors carry a trailing ', at file:line')."""
    text = ' '.join(str(exc).split())
    return text.split(', at /')[0] or type(exc).__name__
