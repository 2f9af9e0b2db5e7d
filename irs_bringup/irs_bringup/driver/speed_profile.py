"""Driver speed profiles: the car's commanded forward speed over time (no rclpy).

A profile is a list of breakpoints ``(t_i, v_i)`` [s, m/s] with ``t_i`` increasing. Between
breakpoints the speed is held (``'step'``) or interpolated linearly (``'linear'``); before the
first breakpoint it is ``v_0``, after the last ``v_n``.
"""
import bisect
import math

from irs_common.params import Param, core_values, node_only
from irs_common.start_gate import START_SUBSCRIBERS


class SpeedProfile:
    """Piecewise speed command ``v(t)`` [m/s]."""

    def __init__(self, times, speeds, interpolation: str = 'step'):
        times, speeds = [float(t) for t in times], [float(v) for v in speeds]
        if not times or len(times) != len(speeds):
            raise ValueError(f'speed profile needs as many times as speeds (at least one), got '
                             f'{len(times)} times and {len(speeds)} speeds')
        if any(b <= a for a, b in zip(times, times[1:])):
            raise ValueError(f'speed profile times must increase strictly, got {times}')
        if any(not math.isfinite(v) or v < 0.0 for v in speeds):
            raise ValueError(f'speed profile speeds must be finite and >= 0 m/s, got {speeds}')
        if interpolation not in ('step', 'linear'):
            raise ValueError(f"interpolation must be 'step' or 'linear', got {interpolation!r}")
        self.times, self.speeds, self.interpolation = times, speeds, interpolation

    def __call__(self, t: float) -> float:
        i = bisect.bisect_right(self.times, t) - 1
        if i < 0:
            return self.speeds[0]
        if i >= len(self.times) - 1 or self.interpolation == 'step':
            return self.speeds[i]
        t0, t1 = self.times[i], self.times[i + 1]
        v0, v1 = self.speeds[i], self.speeds[i + 1]
        return v0 + (v1 - v0) * (t - t0) / (t1 - t0)


#: Parameters of the ``driver`` node (shared with the offline closed loop).
DRIVER_PARAMS = [
    Param('profile.times', [0.0], 'breakpoint times of the speed profile', 's', read_only=True),
    Param('profile.speeds', [1.2], 'car speed over the belt at each breakpoint', 'm/s',
          read_only=True),
    Param('profile.interpolation', 'step', "'step' (hold) or 'linear' between breakpoints", '-',
          read_only=True),
    *node_only([Param('rate', 1000.0, 'publication rate without sim time', 'Hz', 0.1, 10000.0,
                      read_only=True)]),
    START_SUBSCRIBERS,
]


def speed_profile(values: dict) -> SpeedProfile:
    """The driver's profile from its flat parameters (the node's, or an experiment's for the
    offline twin), missing ones at their defaults.
    """
    p = core_values(DRIVER_PARAMS, values, nested=False)
    return SpeedProfile(p['profile.times'], p['profile.speeds'], p['profile.interpolation'])
