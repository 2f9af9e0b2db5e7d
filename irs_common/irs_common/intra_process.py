"""Intra-process delivery for nodes composed in one process: a message handed over, not sent.

rclpy (Jazzy) has no intra-process communication: between two nodes of one process a message is
converted to C, serialised, written to Fast DDS, taken, deserialised and converted back to
Python -- about 50-70 us of CPU per hop here, most of a composed step's cost (without the
handover, ``publish`` and ``take_message`` are the two largest entries of an ``IRS_PROFILE``
profile of the composed lock-step Figure 10). rclcpp's answer is intra-process comms; this is
the same idea for rclpy, confined to :class:`~irs_common.executor.LeanExecutor`.

A publisher's messages to subscriptions of the same executor are queued and delivered in FIFO
order within the same ``spin_once`` while no subscriber outside the process listens (lock-step
stays reproducible to the bit); with an outside subscriber the topic goes through DDS for good.
Routing rule and the recorder's background lane: :class:`IntraProcessBus`.

Contract (all IRS nodes keep it; documented in docs/architecture.md): a subscription callback
does not modify the message it receives, and a publisher does not modify a message after
publishing it -- with a handover, publisher and subscribers share the object.

``IRS_INTRA_PROCESS=0`` in the environment switches the handover off (every message through DDS),
for comparison.
"""
from __future__ import annotations

import os
import time
from collections import defaultdict, deque

from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.subscription import Subscription

from .cdr import cdr_serializer

__all__ = ['HANDOVER_SINK', 'IntraProcessBus', 'enabled_by_env']

#: The attribute of a raw subscription that, when set, receives its handovers instead of its
#: callback: ``sink(data, time_ns)`` with the CDR bytes and the handover's time [ns]
#: (:class:`IntraProcessBus`).
HANDOVER_SINK = 'irs_handover_sink'

_WITH_INFO = Subscription.CallbackType.WithMessageInfo
_DEBUG = os.environ.get('IRS_INTRA_PROCESS_DEBUG', '') not in ('', '0')


def _serializer(msg_class):
    """The CDR serialiser of a raw subscription's handovers: our generated one
    (:mod:`irs_common.cdr`, 5-10x faster), or rclpy's for a type it does not cover or with
    ``IRS_FAST_CDR=0`` in the environment.
    """
    if os.environ.get('IRS_FAST_CDR', '1').strip().lower() not in ('0', 'false', 'off', 'no'):
        fast = cdr_serializer(msg_class)
        if fast is not None:
            return fast
    return serialize_message


def enabled_by_env(env=os.environ) -> bool:
    """False when ``IRS_INTRA_PROCESS`` is ``0``/``false``/``off``; True otherwise."""
    return env.get('IRS_INTRA_PROCESS', '1').strip().lower() not in ('0', 'false', 'off', 'no')


def _matches(pub, sub) -> bool:
    """Would DDS deliver from ``pub`` to ``sub``? Same class and compatible reliability."""
    if sub.msg_type is not pub.msg_type:
        return False
    return not (sub.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                and pub.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT)


class _Route:
    """One routed publisher: its local subscriptions and whether it must also use DDS."""

    __slots__ = ('bus', 'pub', 'node', 'topic', 'targets', 'n_local', 'remote', 'dds_publish')

    def __init__(self, bus, pub, node, topic, subs, n_local):
        self.bus, self.pub, self.node, self.topic = bus, pub, node, topic
        # (subscription, serialiser for a raw one or None, with message info?, handover sink)
        self.targets = [(s, _serializer(pub.msg_type) if s.raw else None,
                         s._callback_type is _WITH_INFO,
                         getattr(s, HANDOVER_SINK, None) if s.raw else None) for s in subs]
        self.n_local = n_local
        self.remote = topic in bus.remote_topics
        self.dds_publish = type(pub).publish.__get__(pub)

    def publish(self, msg) -> None:
        if self.remote or not isinstance(msg, self.pub.msg_type):
            self.dds_publish(msg)   # also raises rclpy's TypeError for a wrong type
            return
        queue, background = self.bus.queue, self.bus.background
        for target in self.targets:
            (background if target[1] else queue).append((target, msg))

    def refresh(self) -> bool:
        """Look up the graph; True when the route has just switched to DDS."""
        if self.remote:
            return False
        count = self.node.count_subscribers(self.topic)
        if count > self.n_local:
            if _DEBUG:
                print(f'[intra_process] {self.topic}: {count} subscriptions, {self.n_local} '
                      'local: through DDS from now on', flush=True)
            self.remote = True
            self.bus.remote_topics.add(self.topic)
            return True
        return False


class IntraProcessBus:
    """The routes of one executor's nodes and the queue of handed-over messages.

    Routing rule. For every publisher of the executor's nodes, the *local* subscriptions are those
    of the same executor on the same resolved topic with the same message class whose QoS DDS would
    match (a reliable subscription does not match a best-effort publisher). A publisher with local
    subscriptions is routed:

    * **no subscriber outside the process** (the graph's subscription count on the topic equals the
      local count): ``publish(msg)`` only queues ``(subscription, msg)`` for each local
      subscription. Nothing goes to DDS. The executor delivers the queue in FIFO order, in the same
      ``spin_once``, before it waits again, so the order of callbacks is a function of the messages
      alone (lock-step stays reproducible to the bit);
    * **a subscriber outside the process** (``ros2 topic echo``, the experiment runner, a recorder
      in another process): ``publish`` goes to DDS, and the local subscriptions receive their copy
      from DDS too. Each local subscription gets every message exactly once either way.

    The outside count is refreshed from the ROS graph by the executor every ``graph_period`` (0.1
    s), so a subscriber that joins from outside starts receiving within about 0.1 s of its
    discovery, as any late-joining volatile subscriber would. The switch is one way: once a topic
    has had an outside subscriber it stays on DDS, and the queued handovers are delivered before
    its first DDS message. Switching back could let an older message, still in flight through DDS,
    reach a local subscription after a newer handover. Transient-local publishers are never routed
    (a late local subscriber must get the stored sample from DDS).

    A raw subscription (``raw=True``: the composed recorder) receives the message's CDR bytes
    (:mod:`irs_common.cdr`: the message of ``serialize_message(msg)``, with zero padding) with
    ``received_timestamp``/``source_timestamp`` of the handover and no publication sequence number
    (a handover cannot lose a message, so there is no gap to detect).

    Raw subscriptions are served in a **background lane**: their handovers wait in a second queue,
    delivered only when the first is empty, and serialised only then. A recorder composed with a 1
    kHz loop thus serialises and writes in the time the loop leaves idle, after the step's control
    chain (rig -> estimator -> controller -> rig), not in the middle of it: 25-35 us per recorded
    message, 4-13 messages per step, which would otherwise sit between the arm sample and the
    steering command. The lane keeps each raw subscription's messages in order; its callbacks
    publish nothing, so the control callbacks' order, and a lock-step bag's content, do not change.
    The receive time a raw subscription sees is the time of its (later) delivery.

    A raw subscription may name a **handover sink**: a function set as its ``irs_handover_sink``
    attribute (:data:`HANDOVER_SINK`) before the executor next gathers its entities. Its handovers
    then go to ``sink(data, time_ns)``, the CDR bytes and the time of the delivery [ns], instead
    of its callback with a message-info dict: the composed recorder appends each message to its
    bag with one call (12 of a lock-step Figure 10 step's 13 deliveries are the recorder's). The
    subscription's callback still takes what comes through DDS.
    """

    def __init__(self) -> None:
        self.queue: deque = deque()
        self.background: deque = deque()  # handovers to raw subscriptions (recorders)
        self.routes: list = []
        self.remote_topics: set = set()   # topics that had an outside subscriber: DDS for good

    def rebuild(self, nodes) -> None:
        """Route every publisher of ``nodes`` anew (their entities changed)."""
        for route in self.routes:
            route.pub.__dict__.pop('publish', None)
        self.routes = []
        subs_by_topic = defaultdict(list)
        for node in nodes:
            for sub in node.subscriptions:
                subs_by_topic[sub.topic_name].append(sub)
        for node in nodes:
            for pub in node.publishers:
                if pub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL:
                    continue
                topic = pub.topic_name
                subs = [s for s in subs_by_topic.get(topic, ()) if _matches(pub, s)]
                if not subs:
                    continue
                route = _Route(self, pub, node, topic, subs, len(subs_by_topic[topic]))
                route.refresh()
                pub.publish = route.publish
                self.routes.append(route)

    def refresh(self) -> None:
        """Look up, for every route, whether a subscriber outside the process appeared.

        A route that switches to DDS first has every queued handover delivered: a local
        subscription must not take a newer message from DDS before an older handover.
        """
        switched = False
        for route in self.routes:
            switched |= route.refresh()
        if switched:
            self.deliver()

    def deliver(self, budget_ns: int | None = None, background_ns: int | None = None) -> int:
        """Call the callbacks of the queued handovers, oldest first; callbacks may queue more,
        and those are delivered too, until the queue is empty or ``budget_ns`` [ns] of wall time
        has passed (None: no limit). Then the background lane: for at most ``background_ns`` [ns]
        (None: until empty) when the first queue is empty -- a real-time loop idles until its
        next tick, and the executor polls between slices --, and until empty when the budget ran
        out first -- a lock-step chain never leaves the first queue empty, and the lane must not
        starve. Returns how many were delivered.
        """
        n = self._drain(self.queue, budget_ns)
        if self.background:
            n += self._drain(self.background, None if self.queue else background_ns)
        return n

    def deliver_background(self) -> int:
        """Deliver the whole background lane now (the executor stops: the recorders' last
        copies must reach their bags before the nodes are destroyed).
        """
        return self._drain(self.background, None)

    @staticmethod
    def _drain(queue, budget_ns) -> int:
        deadline = None if budget_ns is None else time.monotonic_ns() + budget_ns
        n = 0
        while queue:
            (sub, raw, with_info, sink), msg = queue.popleft()
            n += 1
            if sink is not None:
                sink(raw(msg), time.time_ns())
            elif with_info:
                now = time.time_ns()
                sub._callback(raw(msg) if raw else msg,
                              {'source_timestamp': now, 'received_timestamp': now,
                               'publication_sequence_number': None,
                               'reception_sequence_number': None})
            else:
                # rclpy 7.1.6: the callback property's attribute, read at each call
                sub._callback(raw(msg) if raw else msg)
            if deadline is not None and time.monotonic_ns() >= deadline:
                break
        return n

    def clear(self) -> None:
        """Unroute every publisher (the executor shuts down)."""
        for route in self.routes:
            route.pub.__dict__.pop('publish', None)
        self.routes = []
        self.queue.clear()
        self.background.clear()
