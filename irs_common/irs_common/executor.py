"""A lean single-threaded executor: one reused rcl wait set, callbacks called directly.

It exists because rclpy's ``SingleThreadedExecutor`` is too slow for a 1 kHz loop on this
2-core machine (``bench/``): rclpy 7.1.6's spends 250-300 us of CPU per message hop (publish +
take), 3x the 95-130 us of a loop over one raw ``WaitSet``, because per ``spin_once`` it rebuilds
the entity lists through generators, creates a new ``WaitSet``, wraps every ready entity in a
``Task`` (a coroutine plus a future) and takes *one* message per wait.
``rclpy.experimental.EventsExecutor`` is as cheap as the raw wait set, but in rclpy 7.1.6 its
``spin()`` dispatches nothing and it hangs on shutdown in some runs.

:class:`LeanExecutor` keeps rclpy's ``Executor`` base, gathers the entities only when they
change, reuses one wait set, serves slow chores (services, QoS events, graph lookups) in turns
and drains every ready subscription straight into its callback. With ``intra_process=True``
(``run_nodes`` with several nodes) messages between its own nodes are handed over instead of
sent through DDS while no subscriber outside the process listens (:mod:`irs_common.intra_process`).

Callbacks must be plain functions (no coroutines) -- all of ours are. Callback groups are
ignored: one thread runs every callback, so every group is effectively mutually exclusive.
An exception in a callback propagates out of ``spin_once``, as with rclpy's executors.
"""
import time

from rclpy.exceptions import InvalidHandle
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription
from rclpy.utilities import timeout_sec_to_nsec

from . import loop_trace
from .intra_process import IntraProcessBus

_MESSAGE_AND_INFO = Subscription.CallbackType.WithMessageInfo
#: Wall time one ``spin_once`` spends at most on in-process handovers [ns]: a whole lock-step
#: loop composed in one process is an endless chain of handovers, and timers, services and
#: SIGINT must still be served. 5 ms: half the slow period; a real-time step's chain is ~0.3 ms.
HANDOVER_BUDGET_NS = 5_000_000

#: Wall time one ``spin_once`` spends at most on the background lane of the handovers (the
#: composed recorder's copies, :mod:`irs_common.intra_process`) once the control chain is done
#: [ns]. The executor then polls (a zero-timeout wait) and takes another slice, so a timer tick
#: that falls due waits at most one slice: 0.2 ms, a fifth of a 1 kHz period.
BACKGROUND_SLICE_NS = 200_000

#: The slow chore of one ``spin_once`` (:class:`LeanExecutor`): none, services and clients, or the
#: QoS event handlers.
_NONE, _SLOW, _EVENTS = 0, 1, 2


class _Entities:
    """The waitable entities of a set of nodes, gathered once per change."""

    __slots__ = ('subs', 'timers', 'services', 'clients', 'guards', 'waitables', 'wait_set',
                 'sub_by_ptr', 'timer_by_ptr', 'service_by_ptr', 'client_by_ptr', 'sub_handles',
                 'timer_handles', 'guard_handles')

    def __init__(self, nodes, extra_guards, context):
        self.subs, self.timers, self.services, self.clients = [], [], [], []
        self.guards, self.waitables = [], []
        for node in nodes:
            self.subs.extend(node.subscriptions)
            self.timers.extend(node.timers)
            self.services.extend(node.services)
            self.clients.extend(node.clients)
            self.guards.extend(node.guards)
            self.waitables.extend(node.waitables)
        n_sub, n_gc, n_tmr = len(self.subs), len(self.guards) + len(extra_guards), len(self.timers)
        n_cli, n_srv, n_evt = len(self.clients), len(self.services), 0
        for wt in self.waitables:
            count = wt.get_num_entities()
            n_sub += count.num_subscriptions
            n_gc += count.num_guard_conditions
            n_tmr += count.num_timers
            n_cli += count.num_clients
            n_srv += count.num_services
            n_evt += count.num_events
        self.wait_set = _rclpy.WaitSet(n_sub, n_gc, n_tmr, n_cli, n_srv, n_evt, context.handle)
        self.sub_handles = [s.handle for s in self.subs]
        self.timer_handles = [t.handle for t in self.timers]
        self.guard_handles = [g.handle for g in self.guards] + [g.handle for g in extra_guards]
        self.sub_by_ptr = {s.handle.pointer: s for s in self.subs}
        self.timer_by_ptr = {t.handle.pointer: t for t in self.timers}
        self.service_by_ptr = {s.handle.pointer: s for s in self.services}
        self.client_by_ptr = {c.handle.pointer: c for c in self.clients}


class LeanExecutor(Executor):
    """Single-threaded executor with a reused wait set and direct callbacks.

    It keeps rclpy's ``Executor`` base (``add_node``, ``wake``, ``shutdown``, the guard condition
    that node entity creation triggers, the SIGINT guard condition), so nodes, timers, services,
    clients, parameter services, the sim-time ``/clock`` subscription and QoS event handlers work
    unchanged. Its ``spin_once``:

    1. gathers the entity lists of all nodes only when they change (a node created or destroyed
       an entity: rclpy triggers the executor's guard condition then);
    2. clears, refills and waits on one ``_rclpy.WaitSet`` (sized once per gather). The 1 kHz
       entities (subscriptions, timers, guard conditions) go in every time. Three slow chores
       take turns, at most one per ``spin_once`` (the most overdue), and the wait is capped so
       that none is left out longer than its period:

       - services (every node has six parameter services) and clients, every ``slow_period`` s
         (default 10 ms): a service call waits at most that much longer;
       - the QoS event handlers of every publisher and subscription (incompatible QoS, lost
         messages, matching), every ``event_period`` s (default 0.5 s);
       - the graph lookup of the in-process routes (:mod:`irs_common.intra_process`), every
         ``graph_period`` s (default 0.1 s).

       Five nodes and the composed recorder have about 45 services and 200 event handlers.
       Adding them on every wait costs more than all the messages of a step; adding them all,
       and asking the graph about 15 routes, in one ``spin_once`` every 10 ms costs 0.5 ms there
       and most of the composed real-time loop's overruns;
    3. drains every ready subscription: ``take_message`` until nothing is left, each message
       handed straight to its callback (no ``Task``); then calls the ready timers
       (``call_timer`` + callback), so a periodic step sees every message that had arrived when
       it woke; then services, clients, guard conditions and waitables.

    With ``intra_process=True`` the handovers are delivered, oldest first, at the end of the
    ``spin_once`` that produced them, the recorder's copies last, in slices of
    ``BACKGROUND_SLICE_NS`` while the loop is idle.
    """

    #: rclpy's ``Executor.__del__`` reads it; set here so that an executor whose ``__init__``
    #: failed (a signal shut the context down during start-up) is collected without a traceback
    _sigint_gc = None

    def __init__(self, *, context=None, slow_period: float = 0.01, event_period: float = 0.5,
                 graph_period: float = 0.1, intra_process: bool = False):
        super().__init__(context=context)
        self._entities = None
        self._slow_period_ns = int(slow_period * 1e9)
        self._event_period_ns = int(event_period * 1e9)
        self._graph_period_ns = int(graph_period * 1e9)
        self._next_slow_ns = self._next_event_ns = self._next_graph_ns = 0
        self._bus = IntraProcessBus() if intra_process else None
        self._stop_requested = False
        self._handover_budget_ns = HANDOVER_BUDGET_NS

    def wake(self):
        """Something changed (entity created/destroyed, node added): gather again."""
        self._entities = None
        super().wake()

    def add_node(self, node):
        self._entities = None
        return super().add_node(node)

    def remove_node(self, node):
        self._entities = None
        super().remove_node(node)

    def spin(self):
        """Execute callbacks until the context is shut down, the executor is, or a stop was
        requested (:meth:`request_stop`).
        """
        while self._context.ok() and not self._is_shutdown and not self._stop_requested:
            self.spin_once()
        if self._bus is not None and not self._is_shutdown:
            self._bus.deliver_background()   # the recorder's last copies reach the bag

    def request_stop(self):
        """Make :meth:`spin` return after the ``spin_once`` in progress (safe to call from a
        signal handler: it sets a flag and triggers the executor's guard condition).
        """
        self._stop_requested = True
        guard = self._guard
        if guard is not None:
            guard.trigger()

    def spin_once(self, timeout_sec=None):
        """Wait up to ``timeout_sec`` (None: forever) and run everything that is ready."""
        if self._is_shutdown:
            return
        if not self._context.ok():
            raise ExternalShutdownException()
        ents = self._entities
        if ents is None:
            ents = self._gather()
        ws = ents.wait_set
        timeout_ns = timeout_sec_to_nsec(timeout_sec)
        if self._bus is not None and (self._bus.queue or self._bus.background):
            timeout_ns = 0          # handovers are waiting: only poll for what else is ready
        now_ns = time.monotonic_ns()
        chore = self._pick_chore(now_ns)
        timeout_ns = self._capped_timeout(timeout_ns, now_ns)
        if not self._fill(ws, ents, chore):
            return
        ws.wait(timeout_ns)
        if self._is_shutdown:
            return
        if not self._context.ok():
            raise ExternalShutdownException()
        try:
            self._dispatch(ws, ents, chore == _EVENTS)
        except InvalidHandle:
            self._entities = None   # a callback destroyed an entity that was ready too

    def _gather(self):
        """Gather the entity lists of every node (and the in-process routes) again."""
        ents = self._entities = _Entities(self.get_nodes(), (self._guard, self._sigint_gc),
                                          self._context)
        if self._bus is not None:
            self._bus.rebuild(self.get_nodes())
        return ents

    def _pick_chore(self, now_ns: int) -> int:
        """At most one slow chore per spin_once (class docstring), the most overdue: services
        and clients (``_SLOW``), or the QoS event handlers (``_EVENTS``), or the graph lookup of
        the in-process routes (done here); ``_NONE`` when none is due.
        """
        late_slow = now_ns - self._next_slow_ns
        late_events = now_ns - self._next_event_ns
        late_graph = now_ns - self._next_graph_ns if self._bus is not None else -1
        if max(late_slow, late_events, late_graph) < 0:
            return _NONE
        if late_slow >= late_events and late_slow >= late_graph:
            self._next_slow_ns = now_ns + self._slow_period_ns
            return _SLOW
        if late_events >= late_graph:
            self._next_event_ns = now_ns + self._event_period_ns
            return _EVENTS
        self._next_graph_ns = now_ns + self._graph_period_ns
        self._bus.refresh()
        return _NONE

    def _capped_timeout(self, timeout_ns: int, now_ns: int) -> int:
        """Never wait longer than the next chore is due: the slow entities must get their turn,
        and a signal's stop flag (node_main) is only seen when the wait returns -- a Python
        signal handler cannot run while the main thread is inside rcl_wait.
        """
        due_ns = min(self._next_slow_ns, self._next_event_ns)
        if self._bus is not None:
            due_ns = min(due_ns, self._next_graph_ns)
        left = max(due_ns - now_ns, 0)   # never negative: rcl_wait takes that as "forever"
        return left if timeout_ns < 0 else min(timeout_ns, left)

    def _fill(self, ws, ents, chore: int) -> bool:
        """Refill the wait set: the 1 kHz entities always, the chore's entities when due.
        False if an entity was destroyed since the gather (gather again next time).
        """
        try:
            ws.clear_entities()
            for h in ents.sub_handles:
                ws.add_subscription(h)
            for h in ents.timer_handles:
                ws.add_timer(h)
            for h in ents.guard_handles:
                ws.add_guard_condition(h)
            if chore == _SLOW:
                for s in ents.services:
                    ws.add_service(s.handle)
                for c in ents.clients:
                    ws.add_client(c.handle)
            elif chore == _EVENTS:
                for wt in ents.waitables:
                    wt.add_to_wait_set(ws)
        except InvalidHandle:
            self._entities = None
            return False
        return True

    def _dispatch(self, ws, ents, events: bool) -> None:
        """Run what is ready. Messages before timers: a periodic step (the real-time rig's
        tick) then acts on every command that had arrived by the time it woke.
        """
        ready_timers = ws.get_ready_entities('timer')
        for ptr in ws.get_ready_entities('subscription'):
            sub = ents.sub_by_ptr.get(ptr)
            if sub is not None:
                self._drain(sub)
        for ptr in ready_timers:
            tmr = ents.timer_by_ptr.get(ptr)
            if tmr is not None and tmr.handle.is_timer_ready():
                tmr.handle.call_timer()
                tmr.callback()
        self._dispatch_slow(ws, ents, events)
        if self._bus is not None:
            self._bus.deliver(self._handover_budget_ns, BACKGROUND_SLICE_NS)

    def _dispatch_slow(self, ws, ents, events: bool) -> None:
        """Services, clients, guard conditions and (when their chore is due) waitables."""
        for ptr in ws.get_ready_entities('service'):
            srv = ents.service_by_ptr.get(ptr)
            if srv is not None:
                request, header = srv.handle.service_take_request(srv.srv_type.Request)
                if header is not None:
                    srv.send_response(srv.callback(request, srv.srv_type.Response()), header)
        for ptr in ws.get_ready_entities('client'):
            cli = ents.client_by_ptr.get(ptr)
            if cli is not None:
                self._take_response(cli)
        ready_gcs = ws.get_ready_entities('guard_condition')
        if ready_gcs:
            for gc in ents.guards:
                if gc.handle.pointer in ready_gcs and gc.callback is not None:
                    gc.callback()
        if events:
            for wt in [wt for wt in ents.waitables if wt.is_ready(ws)]:
                _run_coroutine(wt.execute(wt.take_data()))

    @staticmethod
    def _drain(sub):
        """Hand every message waiting on ``sub`` to its callback, oldest first."""
        handle, msg_type, raw, callback = sub.handle, sub.msg_type, sub.raw, sub.callback
        with_info = sub._callback_type is _MESSAGE_AND_INFO
        while True:
            taken = handle.take_message(msg_type, raw)
            if taken is None:
                return
            if with_info:
                callback(*taken)
            else:
                callback(taken[0])

    @staticmethod
    def _take_response(cli):
        header, response = cli.handle.take_response(cli.srv_type.Response)
        if header is None:
            return
        try:
            future = cli.get_pending_request(header.request_id.sequence_number)
        except KeyError:
            return   # the request was cancelled
        future.set_result(response)


def _run_coroutine(coro):
    """Run a coroutine that does not await anything pending (rclpy's QoS event handlers)."""
    try:
        coro.send(None)
    except StopIteration:
        return
    coro.close()


class TracedLeanExecutor(LeanExecutor):
    """A :class:`LeanExecutor` that records its timeline into a
    :class:`~irs_common.loop_trace.LoopTrace` (``IRS_TRACE``): per ``spin_once`` when its wait
    began, when it was due (its timeout or the next timer's ``time_until_next_call``, whichever
    is sooner), when it woke and when its callbacks were done; and every timer callback that
    took at least ``loop_trace.CALL_MIN_NS``. It dispatches exactly as the plain executor.
    """

    def __init__(self, trace, **kwargs):
        super().__init__(**kwargs)
        self._trace = trace
        self._timeout_ns = -1
        self._before_ns = self._due_ns = 0

    def _gather(self):
        ents = super()._gather()
        for tmr in ents.timers:
            if not getattr(tmr.callback, '_irs_traced', False):
                tmr.callback = self._timed(tmr.callback)
        return ents

    def _timed(self, callback):
        trace, name = self._trace, getattr(callback, '__qualname__', repr(callback))
        min_ns = loop_trace.CALL_MIN_NS

        def timed():
            start = time.monotonic_ns()
            try:
                return callback()
            finally:
                end = time.monotonic_ns()
                if end - start >= min_ns:
                    trace.call(start, end, name)
        timed._irs_traced = True
        return timed

    def _capped_timeout(self, timeout_ns: int, now_ns: int) -> int:
        self._timeout_ns = super()._capped_timeout(timeout_ns, now_ns)
        return self._timeout_ns

    def _fill(self, ws, ents, chore: int) -> bool:
        filled = super()._fill(ws, ents, chore)
        limit = self._timeout_ns
        for tmr in ents.timers:
            try:
                left = tmr.time_until_next_call()
            except InvalidHandle:
                continue
            if left is not None and (limit < 0 or left < limit):
                limit = max(left, 0)
        self._before_ns = now = time.monotonic_ns()
        self._due_ns = now + limit if limit >= 0 else -1
        return filled

    def _dispatch(self, ws, ents, events: bool) -> None:
        woke = time.monotonic_ns()
        try:
            super()._dispatch(ws, ents, events)
        finally:
            self._trace.spin(self._before_ns, self._due_ns, woke, time.monotonic_ns())
