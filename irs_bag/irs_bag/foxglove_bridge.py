"""The live view's Foxglove bridge: ROS messages as raw CDR on a Foxglove WebSocket server.

A :class:`FoxgloveBridge` runs the WebSocket server of ``foxglove-sdk`` (0.30; the Foxglove
WebSocket protocol, that the Foxglove app connects to with "Open connection",
``ws://host:8765``) and gives, per ROS topic, a channel with message encoding ``cdr`` and a
``ros2msg`` schema: the type's full definition as rosbag2 stores it in a bag
(:func:`irs_bag.msg_definitions.get_message_definition`). Foxglove decodes these messages as
it decodes a ROS 2 bag. A message is forwarded as the bytes the subscription took, never
decoded here; the server sends it only to the clients subscribed to its channel, and logging
to a channel nobody subscribes to costs a few microseconds. No rclpy here:
:mod:`irs_bag.live_view_node` feeds it.
"""
from __future__ import annotations

from typing import Dict, Mapping, Tuple
from urllib.parse import urlsplit

from .msg_definitions import get_message_definition

__all__ = ['FoxgloveBridge', 'parse_ws_url']


def parse_ws_url(url: str) -> Tuple[str, int]:
    """``(host, port)`` of ``ws://host:port`` (port 0: any free port).

    Raises
    ------
    ValueError
        Not a ``ws://host:port`` URL (one line naming it).
    """
    try:
        parts = urlsplit(url)
        port = parts.port
    except ValueError as exc:
        raise ValueError(f'{url!r} is not ws://host:port ({exc})') from None
    if parts.scheme != 'ws' or not parts.hostname or port is None or parts.path not in ('', '/'):
        raise ValueError(f'{url!r} is not ws://host:port (e.g. ws://127.0.0.1:8765)')
    return parts.hostname, port


class FoxgloveBridge:
    """A Foxglove WebSocket server with one ``cdr`` channel per forwarded ROS topic.

    The channels are made before the server starts and stay for its life: a client that
    connects gets them all in its first ``advertise``. (foxglove-sdk 0.30 races a channel added
    while a client connects: the client may get the channel advertised but have its
    ``subscribe`` refused as "unknown channel", and then receives nothing on it.)

    Parameters
    ----------
    url
        ``ws://host:port`` to listen on (port 0: any free port, see :attr:`port`).
    topics
        ROS topic -> its type, ``pkg/msg/Type``.
    name
        The server's name in ``serverInfo``.

    Raises
    ------
    ValueError
        ``url`` is not ``ws://host:port``.
    irs_bag.msg_definitions.MessageDefinitionError
        A type's ``.msg`` definition is not installed.
    """

    def __init__(self, url: str, topics: Mapping[str, str], name: str = 'irs'):
        import foxglove
        host, port = parse_ws_url(url)
        self.context = foxglove.Context()      # its own channels, not the global context's
        self.channels: Dict[str, object] = {}
        for topic, type_name in topics.items():
            schema = foxglove.Schema(name=type_name, encoding='ros2msg',
                                     data=get_message_definition(type_name).encode())
            self.channels[topic] = foxglove.Channel(topic, message_encoding='cdr',
                                                    schema=schema, context=self.context)
        self.server = foxglove.start_server(name=name, host=host, port=port,
                                            context=self.context)

    @property
    def port(self) -> int:
        """The port the server listens on (the one asked for, or the free one it took)."""
        return int(self.server.port)

    def forward(self, topic: str, data: bytes, log_time_ns: int) -> None:
        """Send one serialized message of ``topic`` (CDR as taken) stamped ``log_time_ns``."""
        self.channels[topic].log(data, log_time=int(log_time_ns))

    def close(self) -> None:
        """Close the channels (clients see them unadvertised) and stop the server."""
        for channel in self.channels.values():
            channel.close()
        self.channels = {}
        self.server.stop()
