"""Safety monitor for the treadmill drive: latched position faults, transient input faults.

A fault cuts the drive (0 V; the belt then coasts down by friction, it cannot brake). Two kinds:

* *latched* (the car is somewhere dangerous): the car's c.g. within ``end_margin`` [m] of the
  front (+x) or rear (-x) belt end, or within ``edge_margin`` [m] of the left (+y) or right (-y)
  belt edge. With the car's speed over the ground ``xdot`` [m/s] the end check uses where the
  car would come to rest, ``x + sign(xdot) (|xdot| stop_delay + xdot^2 / (2 stop_decel))``: a
  car moving fast towards an end is stopped while the stop still has room. It stays until
  :meth:`SafetyMonitor.reset` is called;
* *transient* (the input is missing or bad, not the car): no valid position for longer than
  ``stale_timeout`` [s] (checked in :meth:`check`), or a non-finite position / time stamp. The
  drive stays cut while it lasts and the fault clears by itself with the next valid position
  (counted in ``recoveries``): a start-up transient, a scheduling stall or one rejected arm
  reading must not latch the belt off and lose the car.

It exists because the belt can only coast: the drive must be cut before the car reaches an end
or edge. Stamps and start-up: :class:`SafetyMonitor`; belt geometry: ``docs/conventions.md``.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Optional

from irs_common.field_checks import check_numbers
from irs_common.input_checks import StampVerdict
from irs_models.constants import BELT_HALF_LENGTH, BELT_HALF_WIDTH

from .regulator import dataclass_from_mapping

__all__ = ['FaultCode', 'SafetyParams', 'SafetyMonitor', 'DEFAULT_FUTURE_TOLERANCE']


def _finite(v) -> bool:
    if type(v) is float:   # the common case, answered first
        return math.isfinite(v)
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class FaultCode(enum.IntEnum):
    """Fault codes; ``FaultCode.X.text`` is a human-readable description."""

    NONE = 0
    NEAR_FRONT_END = 1
    NEAR_REAR_END = 2
    NEAR_LEFT_EDGE = 3
    NEAR_RIGHT_EDGE = 4
    STALE_POSITION = 5
    INVALID_INPUT = 6

    @property
    def text(self) -> str:
        return _FAULT_TEXT[self]


_FAULT_TEXT = {
    FaultCode.NONE: 'no fault',
    FaultCode.NEAR_FRONT_END: 'car too close to the front (+x) end of the belt',
    FaultCode.NEAR_REAR_END: 'car too close to the rear (-x) end of the belt',
    FaultCode.NEAR_LEFT_EDGE: 'car too close to the left (+y) edge of the belt',
    FaultCode.NEAR_RIGHT_EDGE: 'car too close to the right (-y) edge of the belt',
    FaultCode.STALE_POSITION: 'car position input stale (timeout)',
    FaultCode.INVALID_INPUT: 'car position input not finite',
}


@dataclass(frozen=True)
class SafetyParams:
    """belt_half_length, belt_half_width [m]; end_margin, edge_margin [m] (distance from the
    end/edge at which the fault trips); stale_timeout [s]; stop_decel [m/s^2] and stop_delay [s]:
    how fast, and after how long, the rig's controlled stop brings the car to rest over the
    ground (module docstring). 2 m/s^2 is what the torque car's stop transmits on a wet belt
    (0.7 of mu 0.3 times g, ``irs_vehicle_sim.rig.STOP_TRACTION``); 0.1 s is the rig's
    ``command_timeout``.
    """

    belt_half_length: float = BELT_HALF_LENGTH
    belt_half_width: float = BELT_HALF_WIDTH
    end_margin: float = 0.15
    edge_margin: float = 0.10
    stale_timeout: float = 0.5
    stop_decel: float = 2.0
    stop_delay: float = 0.1

    def __post_init__(self) -> None:
        check_numbers(self, ('belt_half_length', 'belt_half_width', 'end_margin', 'edge_margin',
                             'stale_timeout', 'stop_delay'), at_least=0.0)
        check_numbers(self, ('stop_decel',), above=0.0)
        if self.end_margin >= self.belt_half_length or self.edge_margin >= self.belt_half_width:
            raise ValueError(
                'SafetyParams margins must be smaller than the belt half length/width.'
            )
        if self.stale_timeout <= 0:
            raise ValueError('SafetyParams.stale_timeout must be > 0 s.')

    @classmethod
    def from_dict(cls, d):
        """Build from a parameter mapping (e.g. the YAML ``ros__parameters`` sub-tree); unknown
        keys raise ``ValueError``.
        """
        return dataclass_from_mapping(cls, d)


#: Default ``future_tolerance`` [s]: how far ahead of the node's clock a stamp may be.
DEFAULT_FUTURE_TOLERANCE = 0.5


#: Input faults that clear with the next valid position (module docstring).
TRANSIENT = frozenset({FaultCode.STALE_POSITION, FaultCode.INVALID_INPUT})


class SafetyMonitor:
    """Latched drive-cut logic (the two kinds of fault in the module docstring).

    ``future_tolerance`` [s] (>= 0): stamps further ahead of the clock are rejected for timing.

    Stamps (:meth:`SafetyMonitor.update_position` with the node's clock ``now``): a position whose
    stamp is more than ``future_tolerance`` [s] ahead of ``now`` (``FUTURE``), or older than the
    last stored one (``OLD``), or equal to it (``REPEAT``) is *rejected for timing*: its stamp is
    never stored as the last position time and it does not refresh the stale timer (so a reading
    stamped a day ahead, or at the largest time, can neither make later readings look old nor hide
    a stale input); the rejection is counted in ``rejected_stamps`` and described in
    ``last_rejection``. Its x, y are still checked against the belt ends and edges (a car near an
    edge is a fault whatever its stamp). Without ``now`` (offline use) only OLD/REPEAT are
    rejected.

    Before the first valid position the drive is inhibited (``drive_permitted`` False) without a
    latched fault.  After ``reset()`` the conditions are re-evaluated on the next call, so a
    persisting condition re-latches immediately.  Belt geometry: ``docs/conventions.md``.
    """

    def __init__(self, params: Optional[SafetyParams] = None,
                 future_tolerance: float = DEFAULT_FUTURE_TOLERANCE) -> None:
        self.params = params if params is not None else SafetyParams()
        if isinstance(future_tolerance, bool) or not isinstance(future_tolerance, (int, float)) \
                or not (math.isfinite(future_tolerance) and future_tolerance >= 0):
            raise ValueError(f'future_tolerance must be a finite time >= 0 s, got '
                             f'{future_tolerance!r}.')
        self.future_tolerance = float(future_tolerance)
        self.fault = FaultCode.NONE
        self.fault_detail = ''
        self._last_stamp: Optional[float] = None
        self.rejected_stamps = 0
        self.last_rejection = ''
        self.recoveries = 0

    # ------------------------------------------------------------------ inputs
    def _latch(self, code: FaultCode, detail: str) -> None:
        if self.fault == FaultCode.NONE or (self.fault in TRANSIENT and code not in TRANSIENT):
            self.fault = code
            self.fault_detail = detail

    def update_position(self, x: float, y: float, stamp: float,
                        now: Optional[float] = None, xdot: Optional[float] = None) -> FaultCode:
        """Register a car c.g. position [m] measured at ``stamp`` [s]; return the fault state.

        ``now`` [s] is the node's clock (sim time in lock-step): a stamp more than
        ``future_tolerance`` ahead of it, or not newer than the last stored stamp, is rejected
        for timing (class docstring); the belt limits are checked either way. Non-finite x, y
        or stamp latch ``INVALID_INPUT``. ``xdot`` [m/s], the car's speed over the ground along
        the belt, moves the end check to where a stop would bring the car to rest (module
        docstring); None or non-finite: the position alone.
        """
        p = self.params
        if not (_finite(x) and _finite(y) and _finite(stamp)):
            self._latch(FaultCode.INVALID_INPUT, f'x={x!r}, y={y!r}, stamp={stamp!r}')
            return self.fault
        verdict, why = self.stamp_verdict(stamp, now)
        if verdict is StampVerdict.OK:
            if self.fault in TRANSIENT:          # valid input again: the input fault is over
                self.fault, self.fault_detail = FaultCode.NONE, ''
                self.recoveries += 1
            self.check(stamp)
            self._last_stamp = float(stamp)
        else:
            self.rejected_stamps += 1
            self.last_rejection = f'position {verdict.value}: {why}'
        rest = x              # [m] where a stop begun now brings the car to rest
        if xdot is not None and _finite(xdot) and xdot != 0.0:
            reach = abs(xdot) * p.stop_delay + xdot * xdot / (2.0 * p.stop_decel)
            rest = x + reach if xdot > 0.0 else x - reach
        if rest > p.belt_half_length - p.end_margin:
            self._latch(FaultCode.NEAR_FRONT_END, self._end_detail(x, xdot, rest))
        elif rest < -p.belt_half_length + p.end_margin:
            self._latch(FaultCode.NEAR_REAR_END, self._end_detail(x, xdot, rest))
        if y > p.belt_half_width - p.edge_margin:
            self._latch(FaultCode.NEAR_LEFT_EDGE, f'y = {y:.3f} m')
        elif y < -p.belt_half_width + p.edge_margin:
            self._latch(FaultCode.NEAR_RIGHT_EDGE, f'y = {y:.3f} m')
        return self.fault

    @staticmethod
    def _end_detail(x: float, xdot, rest: float) -> str:
        if rest == x:
            return f'x = {x:.3f} m'
        return f'x = {x:.3f} m moving at {xdot:+.2f} m/s: a stop ends at {rest:.3f} m'

    def stamp_verdict(self, stamp: float, now: Optional[float] = None):
        """``(StampVerdict, reason or None)`` of a finite position stamp [s] against ``now`` [s]
        and the last stored stamp: the rule of :func:`irs_common.input_checks.stamp_problem`,
        evaluated in float seconds (a stamp of 1e308 s has no integer nanoseconds).
        """
        if now is not None and _finite(now) and stamp - now > self.future_tolerance:
            return StampVerdict.FUTURE, (
                f'stamp {stamp:.9g} s is {stamp - now:.3g} s ahead of the clock ({now:.9g} s; '
                f'tolerance {self.future_tolerance:.3g} s)')
        last = self._last_stamp
        if last is not None and stamp == last:
            return StampVerdict.REPEAT, f'stamp {stamp:.9g} s repeats the last one'
        if last is not None and stamp < last:
            return StampVerdict.OLD, (f'stamp {stamp:.9g} s is older than the last accepted one '
                                      f'({last:.9g} s)')
        return StampVerdict.OK, None

    def check(self, now: float) -> FaultCode:
        """Check the position age at time ``now`` [s]; call every control period."""
        if not math.isfinite(now):
            self._latch(FaultCode.INVALID_INPUT, f'now={now!r}')
        elif self._last_stamp is not None:
            self.check_age(now - self._last_stamp)
        return self.fault

    def check_age(self, age: float) -> FaultCode:
        """Check a position age [s] measured by the caller (a node measures the wall time since
        the last valid position *arrived*: a source whose stamps lag the clock, such as a rig
        catching up after a stall, is not stale).
        """
        if self._last_stamp is not None and age > self.params.stale_timeout:
            self._latch(FaultCode.STALE_POSITION, f'last position {age:.3f} s old')
        return self.fault

    # ------------------------------------------------------------------ outputs
    @property
    def faulted(self) -> bool:
        return self.fault != FaultCode.NONE

    @property
    def drive_permitted(self) -> bool:
        """True when no fault is latched and a valid position has been received."""
        return not self.faulted and self._last_stamp is not None

    def gate(self, voltage: float) -> float:
        """Return ``voltage`` [V] if the drive is permitted, else 0 V (drive cut)."""
        if not self.drive_permitted or not math.isfinite(voltage):
            return 0.0
        return voltage

    def status_text(self) -> str:
        """Fault text plus detail, e.g. for a diagnostics message."""
        if not self.faulted:
            return FaultCode.NONE.text if self._last_stamp is not None else \
                'drive inhibited: no position received yet'
        return f'{self.fault.text} ({self.fault_detail})'

    def forget_time(self) -> None:
        """Forget the last position stamp (time went back: a replay loop, a restarted rig); the
        next valid position is accepted whatever its stamp. Latched faults stay latched.
        """
        self._last_stamp = None

    def reset(self) -> None:
        """Clear the latched fault and the position history (drive inhibited until the next
        valid position arrives; a persisting condition re-latches on that update).
        """
        self.fault = FaultCode.NONE
        self.fault_detail = ''
        self._last_stamp = None
        self.last_rejection = ''
