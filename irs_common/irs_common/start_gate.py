"""Lock-step start: a node answers its first step only once its publishers have matched.

A reliable, volatile DDS writer delivers a sample to the readers it has matched when it writes,
and to no later one. In a lock-step run each step is published once (again only when the rig
sees no progress for ``lockstep_resend_period``), so a reader outside the lock-step chain -- the
recorder, the live view -- that the writer matches after step 0 never receives step 0, and its
bag starts one step late. The reader's own view does not settle it: discovery is per side, and
a reader can list a writer that has not yet listed the reader.

The experiment runner knows how many subscriptions each topic of the run has
(``irs_bringup.experiment.expected_endpoints``) and gives every lock-step node
``start_subscribers`` = ``'topic=count,...'`` over the node's own published topics. The node's
:class:`StartGate` (held by its :class:`~irs_common.ticker.Ticker` or
:class:`~irs_common.node_edge.EdgeGate`) leaves a step unanswered until each of those
publishers reports at least that many matched subscriptions (``Publisher.get_subscription_count``:
the writer's view, the one that decides delivery). The step is not lost: the rig, missing the
node's answer, publishes it again after ``lockstep_resend_period``, and the node answers the
repeat. After ``timeout`` (10 s) from the first held step the node warns once and answers
anyway. Once open, the gate costs one attribute test per step. The rigs (``vehicle_sim``,
``rig_hardware``) hold their step 0 on the same gate after ``rig/start``.
"""
import time

from .params import Param

__all__ = ['ALREADY_RUNNING', 'START_SUBSCRIBERS', 'StartGate', 'parse_start_subscribers',
           'start_subscribers_problem']

#: The message of a rig's ``rig/start`` answer when the rig already runs (success false). A
#: caller whose earlier call went unanswered reads it as "started" (``irs_bringup.graph``).
ALREADY_RUNNING = 'already running'


def start_subscribers_problem(text: str):
    """``None``, or what is wrong with a ``start_subscribers`` value (a ``Param`` validator)."""
    try:
        parse_start_subscribers(text)
    except ValueError as exc:
        return str(exc)
    return None


#: The parameter row every lock-step node declares (its table appends it).
START_SUBSCRIBERS = Param(
    'start_subscribers', '',
    "lock-step: answer the first step only once these of the node's published topics have "
    "matched this many subscriptions ('/topic=count,...'; at most 10 s; the experiment runner "
    'sets it), so that no consumer misses the first step', '-', node_only=True,
    validator=start_subscribers_problem)


def parse_start_subscribers(text: str) -> dict:
    """``{'/topic': count}`` of ``'topic=count,...'`` (topics made absolute); ``ValueError``."""
    waits = {}
    for item in filter(None, (part.strip() for part in text.split(','))):
        topic, sep, count = item.partition('=')
        topic, count = topic.strip(), count.strip()
        if not sep or not topic or not count.isdigit():
            raise ValueError(f"'{item}' is not '<topic>=<count>'")
        waits[topic if topic.startswith('/') else '/' + topic] = int(count)
    return waits


class StartGate:
    """Whether ``node`` may answer a step yet (module docstring).

    ``open`` is True once every ``start_subscribers`` count is reached (or the node has no such
    parameter, or it is empty), or ``timeout`` s after the first held step (one warning then).
    :meth:`ready` checks the publishers while closed. The publishers are looked up at the first
    check, when the node has made them all; a topic the node does not publish is named in one
    warning and not waited for.
    """

    __slots__ = ('node', 'open', 'timeout', 'waits', 'first_held', 'clock')

    def __init__(self, node, timeout: float = 10.0, clock=time.monotonic):
        self.node = node
        self.timeout = timeout
        self.clock = clock
        self.first_held = None
        self.waits = None
        spec = (node.get_parameter('start_subscribers').value
                if node.has_parameter('start_subscribers') else '')
        self.open = not parse_start_subscribers(spec)

    def _publishers(self) -> dict:
        waits = parse_start_subscribers(self.node.get_parameter('start_subscribers').value)
        publishers = {pub.topic_name: pub for pub in self.node.publishers}
        unknown = sorted(set(waits) - set(publishers))
        if unknown:
            self.node.get_logger().warning(
                f'start_subscribers: not waiting for {unknown}: the node does not publish them')
        return {t: (publishers[t], n) for t, n in waits.items() if t in publishers}

    def lacking(self) -> list:
        """The topics still short of their count."""
        if self.waits is None:
            self.waits = self._publishers()
        return [t for t, (pub, n) in self.waits.items() if pub.get_subscription_count() < n]

    def ready(self) -> bool:
        """True when the node may answer: open, or just opened by this check."""
        if self.open:
            return True
        lacking = self.lacking()
        now = self.clock()
        if lacking and self.first_held is None:
            self.first_held = now
        if lacking and now - self.first_held < self.timeout:
            return False
        if lacking:
            self.node.get_logger().warning(
                f'going on although {lacking} have fewer subscriptions than expected ('
                + ', '.join(f'{t}={self.waits[t][1]}' for t in lacking)
                + f') {self.timeout:g} s after the first held step')
        self.open = True
        return True
