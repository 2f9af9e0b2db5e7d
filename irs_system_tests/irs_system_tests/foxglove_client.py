"""A Foxglove WebSocket client for tests and benchmarks (tornado's WebSocket client).

It does what the Foxglove app does with a server of the Foxglove WebSocket protocol: connects
offering the subprotocols :data:`SUBPROTOCOLS` (foxglove-sdk 0.30's server accepts only
``foxglove.sdk.v1``; its frames are those of the ``foxglove.websocket.v1`` spec), reads
``serverInfo`` and ``advertise`` (JSON), sends ``subscribe`` for every advertised channel, and
reads the binary message-data frames (opcode 0x01, uint32 subscription id, uint64 receive time
[ns], payload; little endian). It runs in a thread of its own and keeps ``(topic, time_ns,
payload)``; :meth:`Client.wait` waits for a condition on what it got, with a deadline.
"""
import asyncio
import json
import struct
import threading
import time

__all__ = ['Client', 'SUBPROTOCOLS']

SUBPROTOCOLS = ['foxglove.sdk.v1', 'foxglove.websocket.v1']
DEADLINE = 60.0          # [s] longest wait for a connection or for messages


class Client:
    """A Foxglove WebSocket client in a thread of its own: connects (retrying until the server
    is up), subscribes to every advertised channel, keeps ``(topic, time_ns, payload)``.
    """

    def __init__(self, url: str):
        self.url = url
        self.channels = {}            # channel id -> advertised channel (JSON object)
        self.advertised = []          # the channel ids of each 'advertise', in order
        self.server_info = None
        self.subprotocol = None
        self.messages = []            # (topic, receive time [ns], payload bytes)
        self.error = None
        self.changed = threading.Condition()   # notified on every frame the client reads
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def stop(self):
        self._stop.set()
        self._thread.join(timeout=DEADLINE)

    def wait(self, condition, what: str, timeout: float = DEADLINE):
        """Until ``condition()`` holds (checked on every frame read), at most ``timeout`` s."""
        with self.changed:
            ok = self.changed.wait_for(lambda: condition() or self.error is not None, timeout)
        assert self.error is None, f'client failed: {self.error!r}'
        assert ok, f'no {what} within {timeout} s'

    def _notify(self):
        with self.changed:
            self.changed.notify_all()

    def _run(self):
        try:
            asyncio.run(self._session())
        except Exception as exc:       # reported by wait()
            self.error = exc
            self._notify()

    async def _connect(self):
        from tornado.websocket import websocket_connect
        deadline = time.monotonic() + DEADLINE
        while True:
            try:
                return await websocket_connect(self.url, subprotocols=SUBPROTOCOLS)
            except OSError:
                if time.monotonic() > deadline or self._stop.is_set():
                    raise
                await asyncio.sleep(0.1)   # the server is not up yet: try again

    async def _session(self):
        conn = await self._connect()
        self.subprotocol = conn.selected_subprotocol
        subs = {}                       # subscription id -> topic
        while not self._stop.is_set():
            try:
                frame = await asyncio.wait_for(conn.read_message(), 0.1)
            except asyncio.TimeoutError:
                continue
            if frame is None:           # the server closed the connection
                break
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg['op'] == 'serverInfo':
                    self.server_info = msg
                elif msg['op'] == 'advertise':
                    new = []
                    self.advertised.append([ch['id'] for ch in msg['channels']])
                    for ch in msg['channels']:
                        self.channels[ch['id']] = ch
                        subs[len(subs) + 1] = ch['topic']
                        new.append({'id': len(subs), 'channelId': ch['id']})
                    await conn.write_message(json.dumps({'op': 'subscribe',
                                                         'subscriptions': new}))
            elif frame[0] == 0x01:
                sub_id, t_ns = struct.unpack_from('<IQ', frame, 1)
                self.messages.append((subs[sub_id], t_ns, bytes(frame[13:])))
            self._notify()
        conn.close()

    def of(self, topic):
        return [(t, data) for name, t, data in list(self.messages) if name == topic]
