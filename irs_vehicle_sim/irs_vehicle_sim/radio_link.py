"""The steer command's way from the controller to the servo: radio frame, hold and latency.

The paper's rig writes the steer command to a hobby transmitter (Sec. 2); the transmitter
encodes its channels into a pulse frame, one frame every ``T_f`` (about 20 ms for the radios of
the time), and the servo amplifier acts on the pulse of the last frame until the next one.  So
the command reaches the servo *sampled* at the frame instants ``t_j = phi + j T_f`` (a phase
``phi`` in ``[0, T_f)``, unrelated to the controller's 1 kHz clock) and *held*, after a fixed
latency ``L`` (receiver, pulse decoding, amplifier).  A command change waits ``U(0, T_f)`` for
the next frame, so the delay is ``L + U(0, T_f)``: mean ``L + T_f / 2``, standard deviation
``T_f / sqrt(12)`` -- the paper's 17 +- 5 ms (Sec. 3.3) with ``T_f = 20 ms`` and ``L = 7 ms``.

:class:`RadioLink` realises this in the rig's fixed step ``dt``: a frame instant inside step
``k`` (``t_k <= t_j < t_k + dt``) samples the command held over that step, which the servo uses
from step ``round((t_j + L) / dt)`` on.  Without the frame it is the exact FIFO of
``round(delay / dt)`` samples (the delay quantised to the step).

Units: s.  No rclpy.
"""
from __future__ import annotations

import math
from collections import deque

__all__ = ['RadioLink']


class RadioLink:
    """Transport delay of one steer channel, with or without the radio frame.

    Parameters
    ----------
    delay : float
        Mean delay [s] from a command change to the servo (the paper's 0.017 s).
    dt : float
        The rig's step [s].
    frame : float
        Frame period ``T_f`` [s]; 0 = no frame (a FIFO of ``round(delay / dt)`` samples).
    phase : float
        First frame instant ``phi`` [s] in ``[0, frame)``.
    initial : float
        Value held before the first sample arrives.
    """

    def __init__(self, delay: float, dt: float, frame: float = 0.0, phase: float = 0.0,
                 initial: float = 0.0):
        if frame > 0.0:
            if not 0.0 <= phase < frame:
                raise ValueError(f'phase must lie in [0, frame) = [0, {frame!r}) s, got {phase!r}')
            if delay < 0.5 * frame:
                raise ValueError(f'delay must be at least half the radio frame ({0.5 * frame!r} s)'
                                 f' with the frame on, got {delay!r} s')
        self.delay, self.dt, self.frame, self.phase = delay, dt, frame, phase
        #: Fixed latency L = delay - T_f / 2 [s] (frame on; the mean wait for a frame is T_f/2).
        self.latency = delay - 0.5 * frame if frame > 0.0 else delay
        self._k = 0
        self._j = 0
        self.reset(initial)

    def reset(self, initial: float, keep_clock: bool = False) -> None:
        """Forget the commands in flight and hold ``initial``; ``keep_clock`` keeps the frame
        schedule running on (a rig reset in mid-run does not stop the transmitter).
        """
        self.held = float(initial)
        if self.frame > 0.0:
            self._pending: deque = deque()
            if not keep_clock:
                self._k, self._j = 0, 0
        else:
            self._fifo = deque([self.held] * int(round(self.delay / self.dt)))

    @property
    def samples(self) -> int:
        """Length of the FIFO in samples (frame off), 0 with the frame on."""
        return 0 if self.frame > 0.0 else len(self._fifo)

    def next_frame_time(self) -> float:
        """Time of the next frame instant [s] on the link's clock (frame on)."""
        return self.phase + self._j * self.frame

    def step(self, u: float) -> float:
        """The value the servo uses over this step, given the command ``u`` held over it."""
        if self.frame <= 0.0:
            fifo = self._fifo
            if fifo:
                fifo.append(u)
                return fifo.popleft()
            return u
        k, dt = self._k, self.dt
        t_next = self.phase + self._j * self.frame
        while t_next < (k + 1) * dt:           # a frame instant inside this step samples u
            self._pending.append((math.floor((t_next + self.latency) / dt + 0.5), u))
            self._j += 1
            t_next = self.phase + self._j * self.frame
        pending = self._pending
        while pending and pending[0][0] <= k:
            self.held = pending.popleft()[1]
        self._k = k + 1
        return self.held
