"""``live_view`` node: a running graph streamed to a rerun viewer (or an ``.rrd`` file).

It subscribes to the topics of :data:`irs_bag.rerun_entities.SPEC`, or the subset ``topics``
(relative names: the node's namespace is the graph's), and feeds
:class:`irs_bag.live_view.LiveFeed`, whose batches go to rerun every ``period`` s (one
``send_columns`` per entity). Start a viewer with ``rerun``, then
``./irs run irs_bag live_view`` (or ``experiment run <name> --view``); ``-p save:=x.rrd``
writes a file instead.

Cost to the graph: the subscriptions are BEST_EFFORT, KEEP_LAST ``qos_depth``, so a publisher
never waits for, nor resends to, the view. They are bare subscription handles (as the
``recorder``'s, :mod:`irs_bag.recorder_node`; rclpy 7.1.6's ``_rclpy.Subscription``) that no
executor wakes for: the ``period`` timer takes every waiting message as CDR bytes and decodes
one in ``decimation`` (1 kHz topics cost a raw take per message, not an executor wake and a
decode). The node adds no work to the graph's processes beyond DDS delivering to one more
reader; docs/plots.md gives the measured cost to the 1 kHz loop.
"""
from __future__ import annotations

import json
import time

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.type_support import check_is_valid_msg_type

from irs_common.node_main import run_node
from irs_common.params import declare_table

from .live_view import LiveFeed, open_stream
from .live_view_params import NODE_PARAMS
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


class _Feed:
    """One subscribed topic: its handle, type and the count of messages taken."""

    def __init__(self, suffix, msg_type, handle):
        self.suffix, self.msg_type, self.handle = suffix, msg_type, handle
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
        self.feed = LiveFeed(info, view_rate=self.p['view_rate'])
        try:
            self.rec = open_stream(info, url=self.p['url'], save=self.p['save'])
        except (OSError, RuntimeError, ValueError) as exc:
            where = self.p['save'] or self.p['url']
            raise ValueError(f'cannot open the rerun stream {where} ({exc})') from None
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(self.p['qos_depth']),
                         reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.VOLATILE)
        self.feeds = []
        for suffix, msg_type in _types().items():
            if suffix not in self.p['topics']:
                continue
            check_is_valid_msg_type(msg_type)
            with self.handle:
                handle = _rclpy.Subscription(self.handle, msg_type, suffix,
                                             qos.get_c_qos_profile())
            self.feeds.append(_Feed(suffix, msg_type, handle))
        self.rows = {}                       # rows sent per entity so far
        self.create_timer(self.p['period'], self.tick)
        where = self.p['save'] or self.p['url']
        self.get_logger().info(f'streaming {len(self.feeds)} topics to {where}')

    def take(self) -> int:
        """Take every waiting message; feed one in ``decimation`` per topic. Returns taken."""
        n_all, k = 0, int(self.p['decimation'])
        for f in self.feeds:
            while True:
                got = f.handle.take_message(f.msg_type, True)
                if got is None:
                    break
                if f.taken % k == 0:
                    data, info = got
                    self.feed.add(f.suffix, deserialize_message(data, f.msg_type),
                                  info.get('received_timestamp') or time.time_ns())
                f.taken += 1
                n_all += 1
        return n_all

    def tick(self) -> None:
        """Take the messages and send the batch to rerun."""
        self.take()
        for ent, n in self.feed.flush(self.rec).items():
            self.rows[ent] = self.rows.get(ent, 0) + n

    def destroy_node(self):
        try:
            self.tick()
            self.rec.flush(timeout_sec=FLUSH_TIMEOUT)
        except RuntimeError as exc:         # no viewer at 'url': what was not sent is dropped
            self.get_logger().warning(f'rerun: {" ".join(str(exc).split())}')
        finally:
            self.rec.disconnect()
            for f in self.feeds:
                f.handle.destroy_when_not_in_use()
            self.feeds = []
            total = ', '.join(f'{k} ({v})' for k, v in sorted(self.rows.items()))
            print(f'[live_view] sent rows: {total or "none"}', flush=True)
            super().destroy_node()


def main(args=None) -> int:
    return run_node(LiveViewNode, args)
