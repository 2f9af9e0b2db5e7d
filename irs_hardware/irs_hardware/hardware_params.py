"""Parameters of the ``rig_hardware`` node (ROS-free table, irs_common.params)."""
from irs_common.params import Param

NODE_PARAMS = [
    Param('clock_mode', 'realtime', "'realtime' (the board samples by itself) or 'lockstep' "
          '(the board samples once per step: emulator only)', '-', read_only=True),
    Param('lockstep_inputs', ['steering'], "lock-step: inputs whose command for step k must "
          "arrive before step k+1: any of 'steering', 'drive'", '-', read_only=True),
    Param('autostart', True, 'start at once; false: wait for rig/start (std_srvs/Trigger)', '-',
          read_only=True),
    Param('max_steps', 0, 'stop after this many steps (0 = run until shut down)', '1', 0, 2**62),
    Param('start_subscribers', '', 'accepted for the experiment runner (lock-step start)', '-',
          read_only=True),
    Param('dt', 0.001, "the board's sampling interval", 's', 1e-4, 0.05, read_only=True),
    Param('port', '/dev/ttyACM0', "the board's serial port", '-', read_only=True),
    Param('baud', 1000000, "the board's baud rate (8N1)", '1/s', 9600, 12000000,
          read_only=True),
    Param('board_watchdog', 0.025, "the board's watchdog: no command for this long -> servo "
          'centre, enable line low', 's', 0.005, 1.0, read_only=True),
    Param('drive_host', '127.0.0.1', "the drive's Modbus TCP address", '-', read_only=True),
    Param('drive_port', 5020, "the drive's Modbus TCP port", '1', 1, 65535, read_only=True),
    Param('drive_timeout', 0.05, 'timeout of one Modbus request', 's', 0.001, 5.0,
          read_only=True),
    Param('drive_comm_timeout', 0.5, "the drive's own communication-loss stop", 's', 0.0, 60.0,
          read_only=True),
    Param('calibration', '', 'calibration YAML (irs_hardware calibrate writes it)', '-',
          read_only=True),
    Param('link_timeout', 0.02, 'real time: no board sample for this long latches the fault',
          's', 0.002, 10.0, writable=True),
    Param('command_timeout', 0.1, 'real time: a steering command older than this latches the '
          'fault', 's', 0.001, 3600.0, writable=True),
    Param('u_max', 12.7, 'drive voltage range [0, u_max]; outside latches the fault', 'V', 0.1,
          100.0, read_only=True),
    Param('future_tolerance', 0.5, 'commands stamped further ahead are dropped', 's', 0.0,
          3600.0, read_only=True),
    Param('status_period', 0.1, 'rig/status at least this often', 's', 0.001, 3600.0,
          read_only=True),
    Param('belt_speed_decimation', 1, 'publish belt/speed every this many samples', '1', 1,
          1_000_000, read_only=True),
    Param('frame_id', 'treadmill', 'frame of the published measurements', '-', read_only=True),
]
