"""``live_view`` node: a running graph streamed to a rerun viewer (or an ``.rrd`` file), to
the Foxglove app, or both.

It subscribes to the topics of :data:`irs_bag.rerun_entities.SPEC`, or the subset ``topics``
(relative names: the node's namespace is the graph's). For rerun (``url`` or ``save``) it feeds
:class:`irs_bag.live_view.LiveFeed`, whose batches go to rerun every ``period`` s (one
``send_columns`` per entity). For Foxglove (``foxglove``: ``ws://host:port``) every message
taken goes, as its CDR bytes, to the channel of its topic on a Foxglove WebSocket server
(:class:`irs_bag.foxglove_bridge.FoxgloveBridge`). ``experiment run <name> --view`` starts it
(``--view ws://...``: Foxglove only), or ``./irs run irs_bag live_view`` by hand.

The runner passes the run's ``metadata`` (node parameters: the arm's geometry, the car's size,
the controller). Started by hand, with ``node_parameters`` (default), the view asks the graph's
nodes for their parameters as the recorder does (:mod:`irs_bag.node_parameters`) and, once
``vehicle_sim`` answers, logs the static entities again with its arm and car.

Cost to the graph: the subscriptions are BEST_EFFORT, KEEP_LAST ``qos_depth``, so a publisher
never waits for, nor resends to, the view. They are bare subscription handles (as the
``recorder``'s, :mod:`irs_bag.recorder_node`; rclpy 7.1.6's ``_rclpy.Subscription``) that no
executor wakes for: the ``period`` timer takes every waiting message as CDR bytes, forwards it
to Foxglove (no decode) and decodes one in ``decimation`` for rerun. The node adds no work to
the graph's processes beyond DDS delivering to one more reader; docs/plots.md gives the
measured cost to the 1 kHz loop.
"""
from __future__ import annotations

import json
import time

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.type_support import check_is_valid_msg_type

from irs_common.node_main import run_node
from irs_common.params import declare_table

from .live_view import LiveFeed, open_stream, viewer_problem
from .live_view_params import NODE_PARAMS
from .node_parameters import POLL_PERIOD, ParameterAsker
from .rerun_entities import log_static
from .run_info import run_info_from_metadata

__all__ = ['LiveViewNode', 'main']

#: Seconds the node waits at shutdown for its last batches to reach the viewer or the file.
FLUSH_TIMEOUT = 2.0


def _types() -> dict:
    from geometry_msgs.msg import PointStamped, PoseStamped
    from irs_msgs.msg import (BeltSpeed, LateralReference, SteeringActuatorState,
                              SteeringCommand, TreadmillState)
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import JointState
    return {'ground_truth/odom': Odometry, 'pose': PoseStamped, 'arm/joint_states': JointState,
            'ground_truth/sensor_point': PointStamped, 'lateral_position': PointStamped,
            'lateral/reference': LateralReference, 'steering/command': SteeringCommand,
            'steering/state': SteeringActuatorState, 'belt/speed': BeltSpeed,
            'treadmill/state': TreadmillState}


def _type_name(msg_type) -> str:
    """``pkg/msg/Type`` of a generated ROS message class."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


class _Feed:
    """One subscribed topic: its handle, type, full name and the count of messages taken."""

    def __init__(self, suffix, msg_type, handle):
        self.suffix, self.msg_type, self.handle = suffix, msg_type, handle
        self.topic = handle.get_topic_name()
        self.taken = 0


class LiveViewNode(Node):
    """Subscribes to the entities' topics and streams them to rerun (module docstring)."""

    def __init__(self, **node_options):
        super().__init__('live_view', **node_options)
        self.p = declare_table(self, NODE_PARAMS)
        try:
            meta = json.loads(self.p['metadata'])
        except json.JSONDecodeError as exc:
            raise ValueError(f"parameter 'metadata' is not JSON ({exc})") from None
        if not isinstance(meta, dict):
            raise ValueError("parameter 'metadata' must be a JSON object")
        info = run_info_from_metadata(self.p['run_name'],
                                      {str(k): str(v) for k, v in meta.items()} or None)
        rerun_to = self.p['save'] or self.p['url']
        if not rerun_to and not self.p['foxglove']:
            raise ValueError("nothing to stream to: 'url', 'save' and 'foxglove' are all ''")
        self.feed = LiveFeed(info, view_rate=self.p['view_rate'])
        self.rec = self.bridge = None
        if rerun_to:
            problem = None if self.p['save'] else viewer_problem(self.p['url'])
            if problem:     # (said first: rerun's connect then takes 5 s)
                self.get_logger().warning(
                    f"{problem}: rerun keeps the view in memory until one starts ('./irs exec "
                    "rerun' on this machine); or write it to a file: -p save:=live.rrd")
            try:
                self.rec = open_stream(info, url=self.p['url'], save=self.p['save'])
            except (OSError, RuntimeError, ValueError) as exc:
                raise ValueError(f'cannot open the rerun stream {rerun_to} ({exc})') from None
        chosen = {suffix: msg_type for suffix, msg_type in _types().items()
                  if suffix in self.p['topics']}
        if self.p['foxglove']:      # before the subscriptions: up when the graph sees the view
            self.bridge = _open_bridge(
                self.p['foxglove'], self.p['run_name'],
                {self.resolve_topic_name(suffix): _type_name(msg_type)
                 for suffix, msg_type in chosen.items()})
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(self.p['qos_depth']),
                         reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.VOLATILE)
        self.feeds = []
        for suffix, msg_type in chosen.items():
            check_is_valid_msg_type(msg_type)
            with self.handle:
                handle = _rclpy.Subscription(self.handle, msg_type, suffix,
                                             qos.get_c_qos_profile())
            self.feeds.append(_Feed(suffix, msg_type, handle))
        self.rows = {}                       # rows sent per entity so far
        self.forwarded = 0                   # messages sent to Foxglove's channels
        self.create_timer(self.p['period'], self.tick)
        self.asker, self.graph_parameters = None, {}
        if not meta and self.p['node_parameters']:
            self.asker = ParameterAsker(self, self._on_node_parameters, parameter_value_to_python,
                                        missing='its parameters are not known to the view')
            self.create_timer(POLL_PERIOD, self.asker.poll)
        where = [rerun_to] if rerun_to else []
        if self.bridge is not None:
            where.append(f'Foxglove at ws://{_ws_host(self.p["foxglove"])}:{self.bridge.port}')
        self.get_logger().info(f'streaming {len(self.feeds)} topics to {" and ".join(where)}')

    def take(self) -> int:
        """Take every waiting message: forward it to Foxglove, feed one in ``decimation`` per
        topic to rerun. Returns the number taken.
        """
        n_all, k = 0, int(self.p['decimation'])
        bridge, rerun = self.bridge, self.rec is not None
        for f in self.feeds:
            while True:
                got = f.handle.take_message(f.msg_type, True)
                if got is None:
                    break
                data, info = got
                recv_ns = info.get('received_timestamp') or time.time_ns()
                if bridge is not None:
                    bridge.forward(f.topic, data, recv_ns)
                    self.forwarded += 1
                if rerun and f.taken % k == 0:
                    self.feed.add(f.suffix, deserialize_message(data, f.msg_type), recv_ns)
                f.taken += 1
                n_all += 1
        return n_all

    def tick(self) -> None:
        """Take the messages and send the batch to rerun."""
        self.take()
        if self.rec is not None:
            for ent, n in self.feed.flush(self.rec).items():
                self.rows[ent] = self.rows.get(ent, 0) + n

    def _on_node_parameters(self, node: str, params: dict) -> None:
        """A node answered: the run's info again from every answer so far; if it changed, the
        feed draws with it and the static entities are logged again (static data replaces).
        """
        self.graph_parameters[node.rsplit('/', 1)[-1]] = params
        info = run_info_from_metadata(self.p['run_name'], None, self.graph_parameters)
        if info == self.feed.info:
            return
        self.feed.info = info
        if self.rec is not None:
            log_static(self.rec, info)
        self.get_logger().info(
            f'{node} answered: {info.controller}; car {info.car_length:g} x {info.car_width:g} m')

    def destroy_node(self):
        if self.asker is not None:
            self.asker.close()
        try:
            self.tick()
            if self.rec is not None:
                self.rec.flush(timeout_sec=FLUSH_TIMEOUT)
        except RuntimeError as exc:         # no viewer at 'url': what was not sent is dropped
            self.get_logger().warning(f'rerun: {" ".join(str(exc).split())}')
        finally:
            if self.rec is not None:
                self.rec.disconnect()
            if self.bridge is not None:
                self.bridge.close()
            for f in self.feeds:
                f.handle.destroy_when_not_in_use()
            self.feeds = []
            total = ', '.join(f'{k} ({v})' for k, v in sorted(self.rows.items()))
            print(f'[live_view] sent rows: {total or "none"}'
                  + (f'; Foxglove: {self.forwarded} messages' if self.bridge else ''),
                  flush=True)
            super().destroy_node()


def _ws_host(url: str) -> str:
    from .foxglove_bridge import parse_ws_url
    return parse_ws_url(url)[0]


def _open_bridge(url: str, name: str, topics: dict):
    """The Foxglove server at ``url`` with a channel per topic (full name -> ``pkg/msg/Type``);
    a one-line ValueError if it cannot be had.
    """
    try:
        from .foxglove_bridge import FoxgloveBridge
        return FoxgloveBridge(url, topics, name=name)
    except ImportError as exc:
        raise ValueError(f'foxglove-sdk is not installed ({exc}); see env/requirements.txt') \
            from None
    except (OSError, RuntimeError, ValueError, LookupError) as exc:
        raise ValueError(f'cannot start the Foxglove server at {url} '
                         f'({" ".join(str(exc).split())})') from None


def main(args=None) -> int:
    return run_node(LiveViewNode, args)
