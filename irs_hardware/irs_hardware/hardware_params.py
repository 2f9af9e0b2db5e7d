"""Parameter table of the ``rig_hardware`` node (ROS-free) and its core's configuration.

The core's parameters (:class:`~irs_hardware.hardware_rig.HardwareConfig`: timeouts, ranges,
the belt speed's window) come from the table through :func:`hardware_config`; the devices'
addresses, the clock mode and the publishing rates are the node's own (``node_only``).
"""
import math

from irs_common.params import Param, core_values, node_only
from irs_common.start_gate import start_subscribers_problem

from .board_keeper import AFTER as KEEPER_AFTER
from .hardware_rig import HardwareConfig

#: The core's parameters (HardwareConfig's fields).
CORE_PARAMS = [
    Param('dt', 0.001, "the board's sampling interval", 's', 1e-4, 0.05, read_only=True),
    Param('link_timeout', 0.02, 'real time: no board sample for this long latches the fault',
          's', 0.002, 10.0, writable=True),
    Param('command_timeout', 0.1, 'real time: a steering (or wheel torque) command older than '
          'this latches the fault', 's', 0.001, 3600.0, writable=True),
    Param('steer_reject', math.radians(30.0), 'a steer command beyond this latches the fault '
          '(between the 15 deg limit and this it is clipped)', 'rad', 0.0, 3.2, read_only=True),
    Param('u_max', 12.7, 'drive voltage range [0, u_max]; outside latches the fault', 'V', 0.1,
          100.0, read_only=True),
    Param('belt_window', 10, 'belt speed = encoder counts over this many samples', '1', 1,
          10000, read_only=True),
    Param('drive_keepalive', 0.1, "the drive's set-point is written again at least this often "
          "(its communication-loss stop)", 's', 0.001, 60.0, read_only=True),
    Param('wheels', False, "the torque car's wheels: publish wheels/encoders, take "
          'wheels/torque_command (the calibration needs a wheels section, the board 4 wheel '
          'counters)', '-', read_only=True),
    Param('wheel_window', 5, 'wheel speed = encoder counts over this many samples (as '
          "vehicle_sim's encoders.window)", '1', 1, 10000, read_only=True),
    Param('wheel_torque_limit', 0.3, "wheel torques are clipped to +-this (the motors' limit, "
          "as vehicle_sim's two_track.torque_limit)", 'N m', 0.0, 100.0, read_only=True),
    Param('wheel_torque_reject', 0.6, 'a wheel torque beyond this latches the fault', 'N m',
          0.0, 100.0, read_only=True),
]

NODE_PARAMS = CORE_PARAMS + node_only([
    Param('clock_mode', 'realtime', "'realtime' (the board samples by itself) or 'lockstep' "
          '(the board samples once per step: emulator only)', '-', read_only=True),
    Param('lockstep_inputs', ['steering'], "lock-step: inputs whose command for step k must "
          "arrive before step k+1: any of 'steering', 'drive', 'wheels' (with wheels)", '-',
          read_only=True),
    Param('lockstep_resend_period', 0.5, 'lock-step: publish the step again after this long '
          'without progress', 's', 0.01, 3600.0, read_only=True),
    Param('start_subscribers', '', "lock-step: publish step 0 once these of the rig's topics "
          "have this many subscriptions ('topic=count,...'; at most 10 s; the experiment runner "
          'sets it)', '-', read_only=True, validator=start_subscribers_problem),
    Param('autostart', True, 'start at once; false: wait for rig/start (std_srvs/Trigger)', '-',
          read_only=True),
    Param('max_steps', 0, 'stop after this many steps (0 = run until shut down)', '1', 0, 2**62),
    Param('port', '/dev/ttyACM0', "the board's serial port", '-', read_only=True),
    Param('baud', 1000000, "the board's baud rate (8N1)", '1/s', 9600, 12000000,
          read_only=True),
    Param('board_watchdog', 0.025, "the board's watchdog: this long of samples without a "
          'command -> servo centre, enable line low', 's', 0.002, 1.0, read_only=True),
    Param('stall_grace', 0.4, 'real time: a stall of the node this long is bridged by the board '
          'keeper, which repeats the last command to the board (0 = no keeper: the board trips '
          'after board_watchdog)', 's', 0.0, 5.0, read_only=True),
    Param('drive_host', '127.0.0.1', "the drive's Modbus TCP address", '-', read_only=True),
    Param('drive_port', 5020, "the drive's Modbus TCP port", '1', 1, 65535, read_only=True),
    Param('drive_timeout', 0.05, 'timeout of one Modbus request', 's', 0.001, 5.0,
          read_only=True),
    Param('drive_comm_timeout', 0.5, "the drive's own communication-loss stop", 's', 0.0, 60.0,
          read_only=True),
    Param('drive_period', 0.01, 'real time: the drive thread sends the set-point (when it '
          'changed, or the keep-alive) this often', 's', 0.001, 1.0, read_only=True),
    Param('calibration', '', "calibration YAML (`calibrate` writes it); '' = none: the node "
          'does not start', '-', read_only=True),
    Param('future_tolerance', 0.5, 'commands stamped further ahead are dropped', 's', 0.0,
          3600.0, read_only=True),
    Param('status_period', 0.1, 'rig/status at least this often', 's', 0.001, 3600.0,
          read_only=True),
    Param('belt_speed_decimation', 1, 'publish belt/speed every this many samples', '1', 1,
          1_000_000, read_only=True,
          realtime_default=10),         # 100 Hz: the treadmill loop of the real-time budget
    Param('frame_id', 'treadmill', 'frame of the published measurements', '-', read_only=True),
])


def hardware_parameter_table() -> list:
    """The node's whole table (registered in the ``irs_parameters`` entry-point group)."""
    return list(NODE_PARAMS)


def hardware_problem(values: dict):
    """``None``, or why the table's values do not fit together (``declare_table(check=...)``):
    the clock mode is one of the two; the board's watchdog and the link timeout span at least
    two samples (one late sample is no fault); the wheel torques the motors take are not
    refused; the drive hears from the node (keep-alive and
    drive thread) before its own communication-loss stop ends the run (0 = no such stop), and
    that stop comes after the board keeper's ``stall_grace`` (:mod:`.board_keeper`).
    """
    v = {**{p.name: p.default for p in NODE_PARAMS}, **values}
    if v['clock_mode'] not in ('realtime', 'lockstep'):
        return f"clock_mode must be 'realtime' or 'lockstep', got {v['clock_mode']!r}"
    for name in ('board_watchdog', 'link_timeout'):
        if v[name] < 2 * v['dt']:
            return f"{name} = {v[name]:g} s is shorter than two samples (2 dt = {2 * v['dt']:g} s)"
    if v['wheel_torque_reject'] < v['wheel_torque_limit']:
        return (f"wheel_torque_reject = {v['wheel_torque_reject']:g} N m is below "
                f"wheel_torque_limit = {v['wheel_torque_limit']:g} N m: a torque the motors "
                'take would latch the fault')
    comm = v['drive_comm_timeout']
    for name in ('drive_keepalive', 'drive_period'):
        if comm > 0 and v[name] >= comm:
            return (f"{name} = {v[name]:g} s is not shorter than drive_comm_timeout = {comm:g} "
                    f"s: the drive would stop itself between the node's writes")
    grace = v['stall_grace']
    if 0.0 < grace <= KEEPER_AFTER:
        return (f'stall_grace = {grace:g} s: 0 (no board keeper) or more than the '
                f"keeper's {1e3 * KEEPER_AFTER:g} ms")
    if comm > 0 and grace >= comm:
        return (f'stall_grace = {grace:g} s is not shorter than drive_comm_timeout = {comm:g} '
                's: the drive would stop the belt under a board that still holds the outputs')
    return None


def hardware_config(values: dict) -> HardwareConfig:
    """The core's configuration from the node's flat parameters (defaults for missing ones)."""
    return HardwareConfig(**core_values(NODE_PARAMS, values, nested=False))
