"""``rig_hardware`` node: the real rig on ``vehicle_sim``'s topics (thin wrapper of
:mod:`.hardware_rig`).

Publishes ``arm/joint_states`` (sensor_msgs/JointState, the three pot angles [rad]),
``belt/speed`` (irs_msgs/BeltSpeed, encoder speed [m/s] and count) every board sample, with
``vehicle_sim``'s types, frame and QoS (SENSOR_PUB); ``rig/status`` (irs_msgs/RigStatus:
``fault_text`` is the latched fault, '' when none) on a change and every ``status_period``;
``rig/diagnostics`` (diagnostic_msgs/DiagnosticArray: link, board and drive health, the fault's
``time.monotonic()``) every second and at once on a fault, and ``rig/timing`` (real time:
deadline misses and loop latency, as ``vehicle_sim``) every second. Takes ``steering/command``
(front angle) and ``treadmill/drive`` (COMMAND QoS). The torque car (``wheels``): also
``wheels/encoders`` (irs_msgs/WheelEncoders, forward counts and velocities [rad/s] over
``wheel_window``; SENSOR_PUB, every sample, as ``vehicle_sim``'s) and ``wheels/torque_command``
(irs_msgs/WheelTorqueCommand [N m], COMMAND QoS, the lock-step input ``wheels``). Services
``rig/start`` and ``rig/reset`` (std_srvs/Trigger; reset clears the latched fault once the devices
answer again), and in real time ``rig/recover`` as on ``vehicle_sim`` (docs/safety.md): the reset
plus ``treadmill/reset`` (std_msgs/Empty, COMMAND QoS) for the regulator's latched fault; the car
is the operator's to place (no rig holds a real car). ``rig/status`` says ``SAFE_STOPPED`` with the
fault as ``stop_cause`` while a fault is latched, ``SAFE_RUNNING`` otherwise.

Clock modes as ``vehicle_sim``: ``lockstep`` (the board in triggered mode: each step's commands,
paired by stamp, go to the drive and then the board, whose answer is the next sample; /clock
and every output stamped t_k = k dt; the step is published again after
``lockstep_resend_period`` without progress) or ``realtime`` (the board samples at 1 kHz by
itself; a reader thread hands each sample to the executor, which publishes it stamped
``t_start + tick dt``, and the steering command goes to the board at once; a drive thread
writes the set-point every ``drive_period``, off the 1 kHz path; a board keeper process
repeats the last command to the board through a stall of the node of up to ``stall_grace``,
:mod:`.board_keeper`). Bad and stale commands latch the fault (:mod:`.hardware_rig`); on exit the
outputs go to the safe state.
"""
from __future__ import annotations

import collections
import math
import threading
import time
import traceback

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.loop_timing import LoopTiming, format_ms, timing_level
from irs_common.node_main import run_node
from irs_common.params import declare_table
from irs_common.stamp_gate import FUTURE, OLD, StampGate, answer_age
from irs_common.stamp_sync import StampSync
from irs_common.stamps import from_ns, to_ns
from irs_common.start_gate import ALREADY_RUNNING, StartGate
from irs_msgs.msg import (BeltSpeed, RigStatus, SteeringCommand, TreadmillDriveCommand,
                          WheelEncoders, WheelTorqueCommand)

from .calibration import CalibrationError, load_calibration
from .driver import DriveError, LinkError, SerialModbusRig
from .drive_modbus import ModbusDrive
from .hardware_params import hardware_config, hardware_problem, NODE_PARAMS
from .hardware_rig import HardwareRig
from .paths import resolve

#: ``rig/timing`` levels of :func:`irs_common.loop_timing.timing_level`.
TIMING_LEVELS = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR)

ARM_JOINTS = ['arm_joint1', 'arm_joint2', 'arm_joint3']
READ_WAIT = 0.005       # [s] the reader thread's longest wait for the board's next samples
INPUTS = {'steering': ('steering/command', SteeringCommand),
          'drive': ('treadmill/drive', TreadmillDriveCommand),
          'wheels': ('wheels/torque_command', WheelTorqueCommand)}    # with wheels only


class RigHardwareNode(Node):
    """See the module docstring."""

    def __init__(self, **node_options):
        super().__init__('rig_hardware', **node_options)
        self.p = declare_table(self, NODE_PARAMS, on_change=self._on_parameter,
                               check=hardware_problem)
        self.lockstep = self.p['clock_mode'] == 'lockstep'
        self.inputs = {n: v for n, v in INPUTS.items() if n != 'wheels' or self.p['wheels']}
        self.rig = self._make_rig()
        self.dt_ns = int(round(self.p['dt'] * 1e9))
        self.lock = threading.RLock()
        self.required = tuple(n for n in self.p['lockstep_inputs'] if n) if self.lockstep else ()
        unknown = set(self.required) - set(self.inputs)
        if unknown:
            raise ValueError(f'lockstep_inputs: unknown input(s) {sorted(unknown)}; expected '
                             f'some of {sorted(self.inputs)}'
                             + (" ('wheels' needs wheels: true)" if 'wheels' in unknown else ''))
        self.sync = StampSync(self.required) if self.required else None
        tol = int(round(self.p['future_tolerance'] * 1e9))
        self.gates = {n: StampGate(tol) for n in self.inputs}
        self.received_at = {}
        self.pub_clock = self.create_publisher(Clock, '/clock', qos.CLOCK_PUB) if self.lockstep \
            else None
        self.pub_arm = self.create_publisher(JointState, 'arm/joint_states', qos.SENSOR_PUB)
        self.pub_belt = self.create_publisher(BeltSpeed, 'belt/speed', qos.SENSOR_PUB)
        self.pub_encoders = self.create_publisher(WheelEncoders, 'wheels/encoders',
                                                  qos.SENSOR_PUB) if self.p['wheels'] else None
        self.pub_status = self.create_publisher(RigStatus, 'rig/status', qos.STATUS_PUB)
        self.pub_diag = self.create_publisher(DiagnosticArray, 'rig/diagnostics', qos.STATUS_PUB)
        self.pub_timing = None if self.lockstep else self.create_publisher(
            DiagnosticArray, 'rig/timing', qos.STATUS_PUB)
        self.timing = LoopTiming()
        self.arm_sent = {}
        self.last_steer_stamp = -1
        for name, (topic, mtype) in self.inputs.items():
            self.create_subscription(mtype, topic, lambda m, n=name: self._on_command(n, m),
                                     qos.COMMAND)
        self.create_service(Trigger, 'rig/start', self._on_start)
        self.create_service(Trigger, 'rig/reset', self._on_reset)
        self.pub_treadmill_reset = self.create_publisher(Empty, 'treadmill/reset', qos.COMMAND)
        self.create_service(Trigger, 'rig/recover', self._on_recover)
        self.started = self.complete = False
        self.k = self.tick0 = self.stamp0_ns = 0
        self.status_key, self.status_k = None, -10 ** 9
        self.status_every = max(1, int(round(self.p['status_period'] / self.p['dt'])))
        self.drive_status = (None, math.nan)
        self.last_outputs = []
        self.last_progress = time.monotonic()
        self.threads = []
        self.pending = collections.deque()      # real time: samples read, not yet published
        self.samples_ready = None if self.lockstep else self.create_guard_condition(
            self._on_samples)
        self.generation = 0          # rig/reset reopens the devices: reads before it are void
        self.running = True
        self.create_timer(1.0, self._slow_tick)
        if self.lockstep:      # the drive's keep-alive (its communication-loss stop)
            self.create_timer(0.02, self._lockstep_keepalive)
            self.create_timer(0.05, self._lockstep_resend)
        if self.p['autostart']:
            # from the first spin, not the constructor: the loop starts once the process is
            # built and its objects frozen (node_main), so no start-up pause feeds the board late
            self.autostart_timer = self.create_timer(0.01, self._autostart)
        self.get_logger().info(f"rig_hardware up: {self.p['clock_mode']}, board "
                               f"{self.p['port']}, drive {self.p['drive_host']}:"
                               f"{self.p['drive_port']}, calibration "
                               f"{self.p['calibration'] or '(none)'}")

    def _make_rig(self):
        """The core on its devices, or None without a calibration file (start refused)."""
        if not self.p['calibration']:
            return None
        try:
            cal = load_calibration(resolve(self.p['calibration']))
        except CalibrationError as exc:
            raise ValueError(str(exc)) from None
        drive = ModbusDrive(self.p['drive_host'], self.p['drive_port'],
                            timeout=self.p['drive_timeout'],
                            comm_timeout_ms=int(self.p['drive_comm_timeout'] * 1000))
        io = SerialModbusRig(self.p['port'], self.p['baud'], drive,
                             watchdog_ms=int(round(self.p['board_watchdog'] * 1000)),
                             safe_pulse_us=cal.servo.centre_us, wheels=self.p['wheels'],
                             stall_grace=0.0 if self.lockstep else self.p['stall_grace'])
        return HardwareRig(io, cal, hardware_config(self.p))

    # ---------------------------------------------------------------- start, reset, stop
    def _start(self) -> str:
        with self.lock:
            if self.rig is None:
                return ('no calibration: set the parameter calibration to the file '
                        '`calibrate` wrote (docs/hardware.md)')
            if self.started:
                return ALREADY_RUNNING
            try:
                self.rig.io.start(self.lockstep)
            except (LinkError, DriveError) as exc:
                return str(exc)
            self.started = True
            if self.lockstep:
                self._begin_lockstep()
                return ''
            self.stamp0_ns = self.get_clock().now().nanoseconds
            for target in (self._read_loop, self._drive_loop):
                self.threads.append(threading.Thread(target=target, daemon=True))
                self.threads[-1].start()
            return ''

    def _autostart(self):
        self.destroy_timer(self.autostart_timer)
        why = self._start()
        if why:
            self.get_logger().error(f'not started: {why}')

    def _begin_lockstep(self):
        """Publish step 0 once ``start_subscribers`` are matched (at most 10 s:
        :class:`~irs_common.start_gate.StartGate`).
        """
        gate = StartGate(self)

        def begin():
            if not gate.ready():
                return
            self.destroy_timer(timer)
            with self.lock:
                self._publish_next(timeout=1.0)
        timer = self.create_timer(0.01, begin)

    def _on_start(self, _req, resp):
        why = self._start()
        resp.success = not why
        resp.message = why or f"started ({self.p['clock_mode']})"
        return resp

    def _on_reset(self, _req, resp):
        with self.lock:
            if not self.started:
                why, was = 'not started', ''
            else:
                was = self.rig.fault
                why = self.rig.reset(self.lockstep, time.monotonic())
            if not why:
                # the link's age counts from the devices restarted, not from the request
                self.rig.last_reading_time = time.monotonic()
                self.pending.clear()
                self.generation += 1
                self.tick0 = None
                self.received_at.clear()
                if self.lockstep:
                    self._publish_next(timeout=1.0)
                else:                  # stamps go on from now
                    self.stamp0_ns = self.get_clock().now().nanoseconds
                    self.k = 0
        resp.success = not why
        resp.message = why or f'fault cleared (was: {was or "none"})'
        self.get_logger().info(f'rig/reset: {resp.message}')
        if self.started:
            self._publish_status(force=True)
        return resp

    def _on_recover(self, req, resp):
        if self.lockstep:
            resp.success = False
            resp.message = 'not running in real time (lock-step runs restart with rig/reset)'
            return resp
        self._on_reset(req, resp)
        if resp.success:
            self.pub_treadmill_reset.publish(Empty())
            resp.message = f'recovering: devices restarted, treadmill reset; {resp.message}'
        return resp

    def _on_parameter(self, name, value):
        self.p[name] = value
        if self.rig is not None and hasattr(self.rig.cfg, name):
            setattr(self.rig.cfg, name, value)

    def shutdown_safe(self):
        """Outputs to the safe state (node exit)."""
        self.running = False
        for thread in self.threads:
            thread.join(timeout=1.0)
        if self.rig is None or not self.started:
            return
        with self.lock:
            self.rig.trip('node exit', time.monotonic())
            self.rig.io.close()

    def destroy_node(self):
        self.shutdown_safe()
        return super().destroy_node()

    # ---------------------------------------------------------------- inputs
    def _on_command(self, name, msg):
        if name == 'wheels':
            value = (tuple(msg.torque), tuple(msg.locked))
        else:
            value = msg.front_angle if name == 'steering' else msg.voltage
        stamp = to_ns(msg.header.stamp)
        now = time.monotonic()
        with self.lock:
            if not self.started:
                return
            if name in self.required:
                self._lockstep_input(name, stamp, value, now)
                return
            now_ns = self._stamp_ns() if self.lockstep else self.get_clock().now().nanoseconds
            if self.gates[name].check(stamp, now_ns) in (FUTURE, OLD):
                return
            # a command counts from the sample it answers (a graph that falls behind is stale)
            self.received_at[name] = now - answer_age(stamp, self.stamp0_ns, self._stamp_ns())
            self._apply(name, value, now)
            if name == 'steering' and not self.lockstep:
                sent = self.arm_sent.pop(stamp, None)
                if sent is not None:
                    self.timing.add_latency(now - sent)
                self.last_steer_stamp = max(self.last_steer_stamp, stamp)
                self.rig.write_board((stamp - self.stamp0_ns) // self.dt_ns + (self.tick0 or 0),
                                     now)

    def _apply(self, name, value, now):
        if name == 'steering':
            self.rig.command_steer(value, now)
        elif name == 'wheels':
            self.rig.command_wheels(*value, now)
        else:
            self.rig.command_drive(value, now)

    # ---------------------------------------------------------------- lock-step
    def _stamp_ns(self) -> int:
        return self.stamp0_ns + self.k * self.dt_ns

    def _lockstep_input(self, name, stamp, value, now):
        current = self._stamp_ns()
        if stamp < current or stamp - current > self.gates[name].future_tolerance_ns:
            return
        for stamp_ns, values in self.sync.add(name, stamp, value):
            if stamp_ns != self._stamp_ns():
                continue
            if self.p['max_steps'] and self.k >= self.p['max_steps']:
                if not self.complete:
                    self.complete = True
                    self.get_logger().info(f'run complete: {self.k} steps')
                    self._publish_status(force=True)
                return
            for key, val in values.items():
                self._apply(key, val, now)
            self.rig.write_outputs(self.rig.last_tick, now)
            self._publish_next(timeout=1.0)

    def _publish_next(self, timeout: float):
        try:
            readings = self.rig.io.read(timeout)
        except LinkError as exc:
            self.rig.trip(str(exc), time.monotonic())
            readings = []
        self.last_progress = time.monotonic()
        if not readings:
            self.rig.trip('link lost: the board did not answer the step', time.monotonic())
            self._publish_status(force=True)
            return
        self._on_reading(readings[-1])

    def _lockstep_keepalive(self):
        with self.lock:
            now = time.monotonic()
            if self.started and self.rig.drive_due(now) is not None:
                self.rig.send_drive(self.rig.outputs()[2], now)

    def _lockstep_resend(self):
        with self.lock:
            if (not self.started or self.complete or not self.last_outputs or
                    time.monotonic() - self.last_progress < self.p['lockstep_resend_period']):
                return
            for pub, msg in self.last_outputs:
                pub.publish(msg)
            self.last_progress = time.monotonic()

    # ---------------------------------------------------------------- real time
    def _read_loop(self):
        """Real time: read the board, hand the samples to the executor (its guard condition:
        every callback of a composed process stays on one thread), watch the link.

        The link and the commands' age are judged only while this thread runs itself: after a
        pass more than ``READ_WAIT + link_timeout / 2`` after the one before (the node was
        stopped or starved; the board keeper held the board meanwhile), the link check pauses
        for ``link_timeout`` and the stale-command check for ``command_timeout / 2``, while the
        samples and commands that arrived meanwhile are taken (as ``StaleTimer`` does for the
        other nodes). A link silent for ``stall_grace + link_timeout`` of this thread's own
        running time (each pass counts at most ``READ_WAIT + link_timeout / 2``, so a stop of
        the node itself is not counted as the link's silence) is lost whatever the pauses.
        """
        resumed = last = -math.inf
        own_silent = 0.0      # [s] this thread's running time since its last sample
        while self.running:
            generation = self.generation
            try:
                readings = self.rig.io.read(READ_WAIT)
            except Exception as exc:    # this thread must outlive any of them
                with self.lock:
                    if generation == self.generation:    # not the port a reset closed
                        if not isinstance(exc, LinkError):
                            # a driver bug, not the link: latched like a link fault (the
                            # board's watchdog holds the outputs safe), its traceback logged
                            # with the first trip, and the thread reads on
                            if self.rig.ok:
                                self.get_logger().error('board read failed unexpectedly:\n'
                                                        + traceback.format_exc())
                            exc = f'board read failed unexpectedly ({exc!r})'
                        self.rig.trip(str(exc), time.monotonic())
                        self._publish_status(force=True)
                time.sleep(0.05 if generation == self.generation else 0.0)
                continue
            now = time.monotonic()
            cfg = self.rig.cfg
            longest_pass = READ_WAIT + cfg.link_timeout / 2
            if now - last > longest_pass and last > -math.inf:
                resumed = now
            own_silent = 0.0 if readings else own_silent + min(now - last, longest_pass)
            last = now
            with self.lock:
                if generation != self.generation:
                    continue                # read before rig/reset: the old session's
                if readings:
                    self.pending.extend(readings)
                    self.samples_ready.trigger()
                    self.rig.last_reading_time = now
                if self.rig.ok and (now - resumed >= cfg.link_timeout
                                    or own_silent > self.p['stall_grace'] + cfg.link_timeout) \
                        and not self.rig.check_link(now):
                    self._publish_status(force=True)
                if now - resumed >= cfg.command_timeout / 2:
                    self._check_stale(now)

    def _on_samples(self):
        with self.lock:
            while self.pending:
                self._on_reading(self.pending.popleft())

    def _drive_loop(self):
        """Real time: the set-point when due (a change, the keep-alive) every ``drive_period``
        and the drive's status every second, the Modbus requests outside the node's lock.
        """
        next_poll = time.monotonic() + 1.0
        while self.running:
            time.sleep(self.p['drive_period'])
            now = time.monotonic()
            with self.lock:
                setpoint = self.rig.drive_due(now)
            error = self.rig.send_drive(setpoint, now) if setpoint is not None else ''
            if error:
                with self.lock:
                    self.rig.trip(error, time.monotonic())
                    self._publish_status(force=True)
            if now >= next_poll:
                next_poll = now + 1.0
                answer = self.rig.read_drive()
                with self.lock:
                    self.drive_status = self.rig.drive_verdict(answer, time.monotonic())

    def _check_stale(self, now):
        for name in ('steering', 'wheels'):
            seen = self.received_at.get(name)
            if seen is not None and self.rig.ok and now - seen > self.rig.cfg.command_timeout:
                self.rig.trip(f'{name} command stale ({1e3 * (now - seen):.0f} ms > '
                              f'{1e3 * self.rig.cfg.command_timeout:.0f} ms)', now)
                self._publish_status(force=True)

    # ---------------------------------------------------------------- outputs
    def _on_reading(self, reading):
        m = self.rig.measure(reading)
        if self.tick0 is None:
            self.tick0 = m.tick - self.k if self.lockstep else m.tick
        self.k = m.tick - self.tick0
        if not self.lockstep:
            if self.p['max_steps'] and self.k >= self.p['max_steps'] and not self.complete:
                self.complete = True          # the run is over: safe outputs, no fault
                self.rig.stop(reading.received)
                self.get_logger().info(f'run complete: {self.k} steps')
                self._publish_status(force=True)
            if 'steering' in self.received_at:
                self.timing.step(self.last_steer_stamp >= self._stamp_ns() - self.dt_ns)
            if reading.received - self.rig.board_time > 0.002:
                self.rig.write_board(None, reading.received)   # the board watchdog's keep-alive
        stamp = from_ns(self._stamp_ns())
        outputs = []
        if self.pub_clock is not None:
            outputs.append((self.pub_clock, Clock(clock=stamp)))
        js = JointState(name=ARM_JOINTS, position=[float(a) for a in m.angles])
        js.header.stamp, js.header.frame_id = stamp, self.p['frame_id']
        outputs.append((self.pub_arm, js))
        if self.k % self.p['belt_speed_decimation'] == 0:
            belt = BeltSpeed(speed=float(m.belt_speed), encoder_count=int(m.belt_count))
            belt.header.stamp, belt.header.frame_id = stamp, self.p['frame_id']
            outputs.append((self.pub_belt, belt))
        if self.pub_encoders is not None:
            enc = WheelEncoders(counts=[int(c) for c in m.wheel_counts],
                                velocity=[float(v) for v in m.wheel_velocity],
                                counts_per_rev=int(self.rig.cal.wheels.counts_per_rev),
                                window=int(self.p['wheel_window']))
            enc.header.stamp = stamp      # no frame, as vehicle_sim's
            outputs.append((self.pub_encoders, enc))
        if not self.lockstep:
            self.arm_sent[self._stamp_ns()] = time.monotonic()
        for pub, msg in outputs:
            pub.publish(msg)
        self.last_outputs = outputs
        self._publish_status()

    def _publish_status(self, force=False):
        key = (self.rig.fault, self.complete)
        if not force and key == self.status_key and self.k - self.status_k < self.status_every:
            return
        if self.rig.fault and key != self.status_key:
            self.get_logger().error(f'rig fault (latched, outputs safe): {self.rig.fault}')
            self._publish_diagnostics()
        self.status_key, self.status_k = key, self.k
        st = RigStatus(car_on_belt=True, fault_text=self.rig.fault,
                       rejected_steer_count=self.rig.refused['steering'],
                       rejected_drive_count=self.rig.refused['drive'], step=max(0, self.k),
                       run_complete=self.complete, stop_cause=self.rig.fault,
                       safe_state=RigStatus.SAFE_STOPPED if self.rig.fault
                       else RigStatus.SAFE_RUNNING)
        st.header.stamp = from_ns(self._stamp_ns())
        self.pub_status.publish(st)

    def _slow_tick(self):
        if not self.started:
            return
        with self.lock:
            if self.lockstep:
                self.drive_status = self.rig.check_drive(time.monotonic())
            if not self.rig.ok:
                self._publish_status(force=True)
            if len(self.arm_sent) > 2000:
                self.arm_sent.clear()
            self._publish_diagnostics()

    def _publish_diagnostics(self):
        io, rig = self.rig.io, self.rig
        status, speed = self.drive_status
        values = {'fault': rig.fault, 'fault_time': rig.fault_time, 'faults': rig.faults,
                  'bad_frames': io.bad_frames, 'lost_samples': rig.lost_samples,
                  'tick': rig.last_tick, 'drive_status': status, 'drive_belt_speed': speed,
                  'refused_steering': rig.refused['steering'],
                  'refused_drive': rig.refused['drive']}
        if self.pub_encoders is not None:
            values.update(refused_wheels=rig.refused['wheels'],    # the motor commands now
                          wheel_commands=list(rig.outputs()[3]))
        level = DiagnosticStatus.ERROR if rig.fault else DiagnosticStatus.OK
        st = DiagnosticStatus(level=level, name='rig_hardware: devices', hardware_id='irs_rig',
                              message=rig.fault or 'ok',
                              values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])
        arr = DiagnosticArray(status=[st])
        arr.header.stamp = self.get_clock().now().to_msg()
        self.pub_diag.publish(arr)
        if self.pub_timing is not None:
            summary = {**self.timing.summary(), 'lost_samples': rig.lost_samples,
                       'bad_frames': io.bad_frames, 'commands_sent': rig.commands_sent,
                       'faults': rig.faults}
            t = DiagnosticStatus(level=TIMING_LEVELS[timing_level(summary)],
                                 name='rig_hardware: real-time loop', hardware_id='irs_rig',
                                 message=(f"{summary['miss_pct']:.2f} % deadline misses, "
                                          f"latency p99 {format_ms(summary['latency_p99_ms'])} "
                                          'ms'),
                                 values=[KeyValue(key=k, value=f'{v:.6g}' if isinstance(v, float)
                                                  else str(v)) for k, v in summary.items()])
            a = DiagnosticArray(status=[t])
            a.header.stamp = arr.header.stamp
            self.pub_timing.publish(a)


def main(args=None):
    return run_node(RigHardwareNode, args)
