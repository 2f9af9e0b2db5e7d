"""The rig's safe actions when its graph stalls: hold, controlled stop, recover (no rclpy).

One :class:`SafeStop` per rig decides, at every real-time step, what the rig applies when the
nodes that command it fall silent (CPU starvation, a stopped process) or the treadmill reports a
fault: ``RUNNING``, ``HOLDING`` (late commands held for ``stall_grace`` [s]), ``STOPPING``,
``STOPPED`` and ``RECOVERING`` (``irs_msgs/RigStatus``'s ``SAFE_*``). In the controlled stop the
drive is 0 V (the belt coasts down by friction), the car's speed command follows the belt,
``u_cmd = max(0, V_b - hold_gain (x - x_stop))`` [m/s], and the rig steers the car back to the
belt's centre line itself (:meth:`SafeStop.lane_steer`), so that car and belt come to rest
together with the car on the belt. It exists because a real car on a real belt cannot simply
freeze: a car stopping with a heading error ``psi`` drifts sideways by about ``psi`` times the
distance it covers over the belt (6-7 m while the belt coasts down from 1.2 m/s: 0.5 m at
4 deg) unless it is steered. The states in detail are in :class:`SafeStop`, the operator's view
in docs/safety.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from irs_common.field_checks import check_numbers
from irs_models.constants import STEER_LIMIT

__all__ = ['SafeStopParams', 'SafeStop', 'RUNNING', 'HOLDING', 'STOPPING', 'STOPPED',
           'RECOVERING', 'STATE_NAMES']

RUNNING, HOLDING, STOPPING, STOPPED, RECOVERING = range(5)
STATE_NAMES = ('running', 'holding', 'stopping', 'stopped', 'recovering')
#: The inputs whose silence stops the rig (the driver's speed is held: it is no loop's output).
WATCHED = ('steering', 'drive')


@dataclass(frozen=True)
class SafeStopParams:
    """command_timeout, stall_grace [s]; belt_gain [m/s/V]; u_max [V]; spin_up_gain [V s/m];
    release_tolerance, stopped_speed, u0 [m/s]; hold_gain [1/s] (module docstring; with the
    car's 0.3 s speed lag ``tau_u`` the position loop ``tau_u s^2 + s + hold_gain`` has damping
    0.65 at 2 1/s); the lane hold of the stop (:meth:`SafeStop.lane_steer`): curvature_gain
    [1/(m rad)], the car's steady path curvature per unit steer (the rig's plant:
    ``RigSimulation.curvature_gain``; a kinematic bicycle's ``1 / L``), lane_omega [rad/m] and
    lane_damping [-], its natural frequency over the distance covered and damping, steer_limit
    [rad] at the wheel; the torque car's speed loop in the stop (:meth:`SafeStop.stop_torque`):
    wheel_speed_gain [N m s/m] per wheel (0 for a car whose speed follows a speed command) and
    torque_limit [N m].
    """

    command_timeout: float = 0.1
    stall_grace: float = 0.5
    belt_gain: float = 2.38 / 4.5
    u_max: float = 12.7
    spin_up_gain: float = 5.0
    release_tolerance: float = 0.05
    stopped_speed: float = 0.01
    u0: float = 1.2
    hold_gain: float = 2.0
    curvature_gain: float = 1.0 / 0.26
    lane_omega: float = 1.5
    lane_damping: float = 0.8
    steer_limit: float = STEER_LIMIT
    wheel_speed_gain: float = 0.0
    torque_limit: float = 0.3

    def __post_init__(self):
        check_numbers(self, ('command_timeout', 'stall_grace', 'belt_gain', 'u_max',
                             'release_tolerance', 'stopped_speed', 'curvature_gain',
                             'lane_omega', 'lane_damping', 'steer_limit'), above=0.0)
        check_numbers(self, ('spin_up_gain', 'u0', 'hold_gain', 'wheel_speed_gain',
                             'torque_limit'), at_least=0.0)
        if self.stall_grace < self.command_timeout:
            raise ValueError(f'stall_grace ({self.stall_grace} s) must be at least '
                             f'command_timeout ({self.command_timeout} s)')


class SafeStop:
    """The rig's safe-action state machine.

    One :class:`SafeStop` per rig decides, at every real-time step, what the rig applies when the
    nodes that command it fall silent (CPU starvation, a stopped process) or the treadmill reports
    a fault. States (the numbers of ``irs_msgs/RigStatus``'s ``SAFE_*``):

    * ``RUNNING``: every command is fresh (younger than ``command_timeout`` [s]);
    * ``HOLDING``: a steering or drive command is late (older than ``command_timeout``): its last
      value is held, as the real servos and drive hold theirs, for up to ``stall_grace`` [s];
    * ``STOPPING``: a command older than ``stall_grace`` (silent, or answering old samples: its
      age counts from the sample it answers, the caller's ``received_at``), the rig itself more
      than ``stall_grace`` behind real time (it is starved: its steps and the graph's answers do
      not meet), or a treadmill fault: the controlled stop. Drive 0 V (the belt coasts down by
      friction), the rig's own lane hold on the front steer (:meth:`lane_steer`; 0 rad at the
      rear), and the car's own speed command follows the measured belt speed and holds
      the position the stop began at, ``u_cmd = max(0, V_b - hold_gain (x - x_stop))``, so that the
      car's speed over the belt and the belt's speed fall together and ``dx/dt = u cos(psi) - V_b``
      stays near 0: the car is neither carried off the rear nor drives off the front. The lateral
      plant advances on the car's path, at ``u / U`` of real time (:attr:`path_rate`): a car at
      rest drifts nowhere;
    * ``STOPPED``: belt and car below ``stopped_speed`` [m/s]: at rest, latched until recover;
    * ``RECOVERING`` (:meth:`recover`): the car is held at its start pose while the rig brings the
      belt up to the start speed ``u0`` itself (feed-forward ``u0 / belt_gain`` plus ``spin_up_gain
      (u0 - V_b)``, clipped to ``[0, u_max]`` V); once ``|V_b - u0| <= release_tolerance`` and both
      commands are fresh, the car is released (``RUNNING``).

    The cause of a stop is kept once (:attr:`cause`), for ``rig/status`` and one log line.
    """

    __slots__ = ('params', 'state', 'cause', 'late', 'stops', 'recoveries', 'x_stop')

    def __init__(self, params: SafeStopParams | None = None):
        self.params = params or SafeStopParams()
        self.state = RUNNING
        self.cause = ''
        self.late = ''           # the late inputs while HOLDING, e.g. 'drive'
        self.stops = 0
        self.recoveries = 0
        self.x_stop = None       # [m] where the car was when the stop began

    @property
    def overriding(self) -> bool:
        """True while the rig's own commands replace the graph's (stop or recovery)."""
        return self.state >= STOPPING

    def watch(self, now: float, received_at: dict, lag: float = 0.0) -> str:
        """Update from the times [s] the inputs' newest commands count from (``received_at``:
        name -> time; the time of the sample a command answers, or its arrival; the watched
        inputs never received are not late: the start-up hold covers them) at ``now``
        [s] and the rig's own lag behind real time ``lag`` [s]; returns the cause when a stop
        begins here, else ``''``.
        """
        if self.state >= STOPPING:
            return ''
        p = self.params
        if lag > p.stall_grace:
            return self.stop(f'the rig is {lag:.3f} s behind real time (> stall_grace '
                             f'{p.stall_grace:g} s)')
        late = ''
        oldest = 0.0
        for name in WATCHED:
            seen = received_at.get(name)
            if seen is not None and now - seen > p.command_timeout:
                late = name if not late else f'{late}, {name}'
                oldest = max(oldest, now - seen)
        self.late = late
        if not late:
            self.state = RUNNING
            return ''
        if oldest <= p.stall_grace:
            self.state = HOLDING
            return ''
        return self.stop(f'{late} command late: the newest answers a sample {oldest:.3f} s old '
                         f'(> stall_grace {p.stall_grace:g} s)')

    def stop(self, cause: str) -> str:
        """Begin the controlled stop for ``cause`` (unless one is on); returns ``cause`` when it
        began here, else ``''``.
        """
        if self.state >= STOPPING:
            return ''
        self.state = STOPPING
        self.x_stop = None
        self.cause = cause
        self.stops += 1
        return cause

    def stop_speed(self, belt_speed: float, car_speed: float, x: float) -> float:
        """The car's speed command [m/s] during the stop (module docstring) from the measured
        belt speed, the car's speed and its position ``x`` [m]; latches ``STOPPED`` once belt
        and car are at rest.
        """
        v = belt_speed if math.isfinite(belt_speed) and belt_speed > 0.0 else 0.0
        if self.state == STOPPING and v < self.params.stopped_speed \
                and abs(car_speed) < self.params.stopped_speed:
            self.state = STOPPED
        if not math.isfinite(x):
            return v
        if self.x_stop is None:
            self.x_stop = x
        return max(0.0, v - self.params.hold_gain * (x - self.x_stop))

    def path_rate(self, car_speed: float, plant_speed: float) -> float:
        """Fraction of real time the lateral plant advances during a stop: ``u / U`` in [0, 1]."""
        if plant_speed <= 0.0 or not math.isfinite(car_speed):
            return 0.0
        return min(1.0, max(0.0, car_speed / plant_speed))

    def lane_steer(self, y_s: float, psi: float) -> float:
        """The rig's front steer [rad] during the stop: back to the belt's centre line,
        ``delta = -(lane_omega^2 y_s + 2 lane_damping lane_omega psi) / curvature_gain``, within
        ``+-steer_limit``; 0 rad for a non-finite pose.

        Over the distance ``s`` the car covers, ``dy_s/ds = psi`` and ``dpsi/ds = kappa delta``
        (``kappa`` the curvature gain), so the sensor point obeys ``y_s'' + 2 zeta omega y_s' +
        omega^2 y_s = 0`` in ``s``: a second-order return over about ``4 / (zeta omega)`` = 3.3 m
        of path, whatever the speed (at 1.2 m/s its 2.4 rad/s lie well inside the servo's 28
        rad/s). A law in distance rather than time stays right as the car slows with the belt.
        """
        p = self.params
        if not (math.isfinite(y_s) and math.isfinite(psi)):
            return 0.0
        w = p.lane_omega
        delta = -(w * w * y_s + 2.0 * p.lane_damping * w * psi) / p.curvature_gain
        return min(p.steer_limit, max(-p.steer_limit, delta))

    def stop_torque(self, speed_cmd: float, car_speed: float) -> tuple:
        """The torque car's four wheel torques [N m] during the stop: ``wheel_speed_gain
        (u_cmd - u)`` on every wheel, within ``+-torque_limit``, from the stop's speed command
        ``u_cmd`` and the car's speed ``u`` [m/s] over the belt (0 N m for a non-finite speed).

        With zero torque the free-rolling car is dragged off the rear by its rolling resistance
        (1 m in 3.4 s offline); the gain ``m R k / 4`` gives the speed loop a rate ``k`` [1/s]
        (10 1/s for the irs_iwt car: 0.236 N m s/m).
        """
        p = self.params
        if not (math.isfinite(speed_cmd) and math.isfinite(car_speed)):
            return (0.0,) * 4
        torque = min(p.torque_limit, max(-p.torque_limit,
                                         p.wheel_speed_gain * (speed_cmd - car_speed)))
        return (torque,) * 4

    def commands(self, outputs, plant_speed: float):
        """``(front steer [rad], drive [V], speed command [m/s], path_rate)`` the rig applies in
        place of the graph's while :attr:`overriding` (the rear steer is 0 rad), from the rig's
        ``outputs`` (``belt_speed_measured``, ``u``, ``x``, ``y_s``, ``psi``) and the lateral
        plant's speed ``U`` [m/s]. Recovering: steer 0 with the car held at its start pose.
        """
        if self.state == RECOVERING:
            return 0.0, self.spin_up_voltage(outputs.belt_speed_measured), self.params.u0, 1.0
        speed = self.stop_speed(outputs.belt_speed_measured, outputs.u, outputs.x)
        steer = self.lane_steer(outputs.y_s, outputs.psi)
        return steer, 0.0, speed, self.path_rate(outputs.u, plant_speed)

    def recover(self) -> None:
        """Start the recovery (module docstring), from any state."""
        self.state = RECOVERING
        self.cause = ''
        self.late = ''
        self.recoveries += 1

    def spin_up_voltage(self, belt_speed: float) -> float:
        """The rig's drive voltage [V] while recovering: feed-forward plus proportional."""
        p = self.params
        v = belt_speed if math.isfinite(belt_speed) else 0.0
        u = p.u0 / p.belt_gain + p.spin_up_gain * (p.u0 - v)
        return min(p.u_max, max(0.0, u))

    def ready(self, belt_speed: float, now: float, received_at: dict) -> bool:
        """While recovering: whether the belt is at the start speed and both commands are fresh;
        then the car is released (``RUNNING``) and True is returned.
        """
        if self.state != RECOVERING or not math.isfinite(belt_speed) \
                or abs(belt_speed - self.params.u0) > self.params.release_tolerance:
            return False
        for name in WATCHED:
            seen = received_at.get(name)
            if seen is None or now - seen > self.params.command_timeout:
                return False
        self.state = RUNNING
        return True
