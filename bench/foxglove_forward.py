"""CPU per message of the live view's Foxglove bridge (``FoxgloveBridge.forward``).

    flock /tmp/irs_bench.lock ./irs exec python bench/foxglove_forward.py [--messages 20000]

Forwards the CDR bytes of one ``nav_msgs/Odometry`` (the largest default topic of the view,
about 0.7 kB) ``--messages`` times back to back, with no client, then with a client subscribed
to the channel (:class:`irs_system_tests.foxglove_client.Client`, in this process: its
receiving costs are counted too). Prints the process CPU time per forwarded message [us] and
how many the client received (the server drops what a client's queue cannot hold rather than
wait); results go to ``bench/results/foxglove_forward-<time>.json``.
"""
import argparse
import socket
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import write_results   # noqa: E402 (bench/ is on sys.path)


def _forward(bridge, data: bytes, n: int) -> float:
    """Process CPU per message [us] of ``n`` forwards."""
    c0 = time.process_time()
    for k in range(n):
        bridge.forward('/ground_truth/odom', data, 1_000_000_000 + k)
    return 1e6 * (time.process_time() - c0) / n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--messages', type=int, default=20000)
    args = ap.parse_args()
    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message

    from irs_bag.foxglove_bridge import FoxgloveBridge
    from irs_system_tests.foxglove_client import Client
    data = serialize_message(Odometry())
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    bridge = FoxgloveBridge(f'ws://127.0.0.1:{port}',
                            {'/ground_truth/odom': 'nav_msgs/msg/Odometry'})
    rows = {'bytes': len(data), 'no_client_us': _forward(bridge, data, args.messages)}
    client = Client(f'ws://127.0.0.1:{port}')
    client.wait(lambda: bool(client.channels), 'advertisement')
    deadline = time.monotonic() + 60.0
    while not client.messages:          # until the subscription is in place
        assert time.monotonic() < deadline, 'the client got no message'
        bridge.forward('/ground_truth/odom', data, 1)
        with client.changed:
            client.changed.wait(0.05)
    n0 = len(client.messages)
    rows['client_us'] = _forward(bridge, data, args.messages)
    while True:                         # until no frame came for 1 s
        with client.changed:
            if not client.changed.wait(1.0):
                break
    rows['client_received'] = len(client.messages) - n0
    client.stop()
    bridge.close()
    print(f"Odometry ({rows['bytes']} B): {rows['no_client_us']:.1f} us/message with no client, "
          f"{rows['client_us']:.1f} us/message with one subscribed client "
          f"({rows['client_received']} of {args.messages} received)", flush=True)
    write_results({'messages': args.messages, **rows}, HERE / 'results', 'foxglove_forward-')
    return 0


if __name__ == '__main__':
    sys.exit(main())
