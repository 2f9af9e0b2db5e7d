"""The board keeper: a small process that bridges a short stall of the hardware node (no rclpy).

The board's watchdog (25 samples) guards against a dead host or a cut cable, and it must not be
fed by anything that stays alive when the host is dead. But the hardware node is a Python
process, and rclpy holds the interpreter lock in every call into rcl: a ``publish`` that waits
inside Fast DDS (measured: 316 ms on ``rig/status`` while another process's reader of that
latched topic was being matched) stops every thread of the node, the board reader included, and
the board trips although the host is alive. The keeper is a second process, with no lock shared
with the node:

- the node offers it a COMMAND frame it sends the board every ``OFFER_PERIOD`` (2 ms) and at
  once when the enable line changes (:meth:`BoardKeeper.offer`, a datagram with the frame and
  its ``time.monotonic()``), *before* writing it to the board: the keeper's frame is at most
  2 ms older than the board's, and never a live one behind a safe one;
- when the newest offer is older than ``after`` (5 ms: the node silent for 3 ms or more) and
  younger than ``grace`` (the node's ``stall_grace``), the keeper writes that frame to the board
  again, every ``period`` (2 ms): the board holds the host's last outputs, as it would for a
  command repeated late;
- past ``grace`` it stops, and the board's watchdog trips 25 samples later (the safe state);
- when the node exits (its end of the socket closes, also when it is killed) the keeper exits at
  once: a dead host is found by the board's watchdog as without the keeper.

So the safe action for a stalled host is written down in one place: hold the last outputs for
``stall_grace``, then the board's safe state. A COMMAND written twice is harmless: the board
takes its outputs and resets its watchdog, and ``seq`` answers a sample already answered. The
tty serialises whole ``write`` calls of two processes, so frames never interleave. A repeat that
meets the node's own write in progress fails with EAGAIN (the port is non-blocking) and is
skipped, the port kept (:func:`write_frame`). One order is possible when the node resumes at
the keeper's own write: the keeper's repeat of frame N-1 lands after the node's frame N, and
the board holds N-1's outputs until the node's next frame (one sample later).

Run by :class:`BoardKeeper` as ``python -I -S board_keeper.py SOCK_FD AFTER GRACE`` (the socket
inherited from the node; the board's port comes over it).
"""
from __future__ import annotations

import os
import select
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

AFTER = 0.005         # [s] the node's newest offer is this old: repeat it
PERIOD = 0.002        # [s] between repeats
OFFER_PERIOD = 0.002  # [s] the node offers a frame this often (and on an enable change)
_STAMP = struct.Struct('<d')      # a frame's offer: _FRAME, its time.monotonic(), the frame
_FRAME, _ATTACH, _DETACH = b'F', b'A', b'D'


class KeeperState:
    """The keeper's decision, apart from its I/O: the newest offer and when to repeat it."""

    def __init__(self, grace: float, after: float = AFTER, period: float = PERIOD):
        if not (0.0 < after < grace and period > 0.0):
            raise ValueError(f'board keeper: need 0 < after ({after}) < grace ({grace}) '
                             f'and period ({period}) > 0')
        self.grace, self.after, self.period = grace, after, period
        self.frame = None            # the newest frame offered
        self.offered = -float('inf')   # its time [s]
        self.repeated = -float('inf')  # the last repeat [s]
        self.repeats = 0

    def offer(self, frame: bytes, stamp: float) -> None:
        """The node sent ``frame`` at ``stamp`` [s]; an older offer than the newest is ignored."""
        if stamp >= self.offered:
            self.frame, self.offered = frame, stamp

    def wait(self, now: float) -> float:
        """How long [s] the keeper may sleep before a repeat can be due (at most ``after``, so
        that offers, the port's changes and the node's end are taken within that).
        """
        silent = now - self.offered
        if self.frame is None or silent > self.grace:
            return self.after
        if silent < self.after:
            return min(self.after, self.after - silent)
        return max(0.0, min(self.after, self.period - (now - self.repeated)))

    def due(self, now: float):
        """The frame to write to the board now, or None (module docstring)."""
        silent = now - self.offered
        if self.frame is None or not self.after <= silent <= self.grace:
            return None
        if now - self.repeated < self.period:
            return None
        self.repeated = now
        self.repeats += 1
        return self.frame


class BoardKeeper:
    """The node's handle on a keeper process (module docstring); ``grace`` [s].

    The process starts here, with the node, and lives as long as the node: its Python start-up
    (about 0.1 s of CPU, at the node's SCHED_FIFO priority) must not fall into the 1 kHz loop.
    :meth:`attach` hands it the board's port (the file descriptor, over the socket) when the
    board starts, :meth:`detach` takes it back before the port closes (a reset).
    """

    def __init__(self, grace: float):
        KeeperState(grace)            # the arguments checked here, not in the child
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        with theirs:
            # the file as a script, isolated (-I -S): the standard library only, a fast start
            self.process = subprocess.Popen(
                [sys.executable, '-I', '-S', str(Path(__file__).resolve()),
                 str(theirs.fileno()), repr(AFTER), repr(grace)],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        self.sock = ours
        self.dropped = 0

    def attach(self, tty_fd: int) -> None:
        """The board's port: repeats go there from now on (no frame yet to repeat)."""
        self.sock.setblocking(True)
        socket.send_fds(self.sock, [_ATTACH], [tty_fd])
        self.sock.setblocking(False)

    def detach(self, timeout: float = 0.1) -> None:
        """No more repeats: the keeper closes its copy of the port; waits for its answer (up to
        ``timeout`` [s]) so that nothing of this session follows the port's next start.
        """
        try:
            self.sock.setblocking(True)
            self.sock.settimeout(timeout)
            self.sock.send(_DETACH)
            while self.sock.recv(16) != _DETACH:
                pass
        except OSError:               # gone or late: nothing more to wait for
            pass
        finally:
            self.sock.settimeout(None)
            self.sock.setblocking(False)

    def offer(self, frame: bytes, now: float) -> None:
        """Hand the keeper the frame about to go to the board (never blocks)."""
        try:
            self.sock.send(_FRAME + _STAMP.pack(now) + frame)
        except BlockingIOError:
            self.dropped += 1         # the keeper is behind: it keeps an older frame
        except OSError:
            pass                      # the keeper is gone: the board's watchdog as without it

    def close(self) -> None:
        """End the keeper (it exits on the socket's end) and wait for it."""
        self.sock.close()
        try:
            self.process.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


def run(sock: socket.socket, state: KeeperState) -> int:
    """The keeper's loop: take the port and the offers, repeat the newest frame while the node
    is silent; 0 when the node's end closes.
    """
    tty_fd = None
    sock.setblocking(False)           # (recv_fds passes no flags to recvmsg: no MSG_DONTWAIT)
    while True:
        # sleep, then take everything queued: one wake-up per few offers, not one per offer
        time.sleep(state.wait(time.monotonic()))
        while True:
            try:
                data, fds, _flags, _addr = socket.recv_fds(sock, 256, 1)
            except BlockingIOError:
                break
            except OSError:
                return 0
            if not data:
                return 0              # the node closed its end (or died)
            kind = data[:1]
            if kind == _FRAME:
                state.offer(data[1 + _STAMP.size:], _STAMP.unpack_from(data, 1)[0])
                continue
            if tty_fd is not None:    # attach or detach: the old port goes, and its frame
                os.close(tty_fd)
            tty_fd, state.frame = (fds[0] if fds else None), None
            state.offered = -float('inf')
            if kind == _DETACH:
                sock.send(_DETACH)
        frame = state.due(time.monotonic())
        if frame is not None and tty_fd is not None and not write_frame(tty_fd, frame):
            os.close(tty_fd)          # the board is gone: nothing to keep until the next port
            tty_fd = None


def write_frame(fd: int, frame: bytes, finish: float = PERIOD) -> bool:
    """Write ``frame`` to the board's port ``fd``; False if the port is gone (a write error).

    The port is the node's own open file, non-blocking (pyserial). A write fails with EAGAIN,
    nothing written, while the node's own write holds the tty's write lock or while the port's
    buffer is full: the repeat is skipped then (the next one is due a ``PERIOD`` later) and the
    port kept. A frame begun is finished: the rest is written as the port takes it, for up to
    ``finish`` [s] (a frame cut short there is one garbled frame to the board, which the node
    sees and latches).
    """
    deadline = time.monotonic() + finish
    view = memoryview(frame)
    while view:
        try:
            view = view[os.write(fd, view):]
        except BlockingIOError:
            if len(view) == len(frame):
                return True           # busy: nothing written, this repeat skipped
        except OSError:
            return False
        left = deadline - time.monotonic()
        if view and left <= 0.0:
            return True
        if view:
            select.select([], [fd], [], left)
    return True


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    try:
        sock_fd, after, grace = int(args[0]), float(args[1]), float(args[2])
        state = KeeperState(grace, after)
    except (IndexError, ValueError) as exc:
        print(f'board_keeper: expected SOCK_FD AFTER GRACE ({exc})', file=sys.stderr)
        return 2
    sock = socket.socket(fileno=sock_fd)
    try:
        return run(sock, state)
    except KeyboardInterrupt:      # the node's process group got SIGINT: the node closes us
        return 0


if __name__ == '__main__':
    sys.exit(main())
