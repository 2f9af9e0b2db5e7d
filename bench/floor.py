"""The floor: a minimal plant -> estimator -> controller -> plant loop, one message per hop.

Each hop is one ``std_msgs/Float64`` (data = step index) with the project's sensor QoS (reliable,
keep-last 100). Three executors are compared, each in 3 processes (one node each) and, for the
lean executor, with the 3 nodes in one process:

- ``single``: rclpy's ``SingleThreadedExecutor``;
- ``waitset``: a bare loop over one raw rcl wait set (what the recorder does), no executor;
- ``lean``: :class:`irs_common.executor.LeanExecutor` (what every IRS node runs on).

Lock-step: the plant publishes step k+1 as soon as the controller's answer to k arrives; result:
steps/s and CPU per hop. Real time: the plant publishes on a 1 kHz wall timer; a deadline miss is
a step whose answer had not arrived when the next step was due; loop latency is publish ->
answer received. Run: ``./irs exec python bench/floor.py [--seconds 10]`` (prints JSON lines).
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time

TOPICS = {'plant': ('floor/c', 'floor/a'), 'estimator': ('floor/a', 'floor/b'),
          'controller': ('floor/b', 'floor/c')}


def _qos():
    from irs_common import qos
    return qos.SENSOR


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


class _Relay:
    """Estimator/controller: answer every message with the same data on the next topic."""

    def __init__(self, node, role):
        from std_msgs.msg import Float64
        sub_topic, pub_topic = TOPICS[role]
        self.pub = node.create_publisher(Float64, pub_topic, _qos())
        self.sub = node.create_subscription(Float64, sub_topic, self.pub.publish, _qos())


class _Plant:
    """Publishes steps; lock-step: next on answer; real time: on a 1 kHz timer."""

    def __init__(self, node, clock, steps, period=0.001):
        from std_msgs.msg import Float64
        self.node, self.clock, self.steps, self.period = node, clock, steps, period
        self.Float64 = Float64
        self.pub = node.create_publisher(Float64, 'floor/a', _qos())
        node.create_subscription(Float64, 'floor/c', self.on_answer, _qos())
        self.k = -1
        self.sent_at = {}
        self.latencies = []
        self.misses = 0
        self.answered = set()
        self.done = False
        self.t0 = None
        self.cpu0 = None

    def ready(self) -> bool:
        return (
            self.pub.get_subscription_count() >= 1 and self.node.count_publishers('floor/c') >= 1
        )

    def start(self):
        self.t0, self.cpu0 = time.monotonic(), _cpu()
        if self.clock == 'lockstep':
            self.publish_next()
        else:
            self.timer = self.node.create_timer(self.period, self.tick)

    def publish_next(self):
        self.k += 1
        if self.k >= self.steps:
            self.done = True
            return
        self.sent_at[self.k] = time.monotonic()
        self.pub.publish(self.Float64(data=float(self.k)))

    def tick(self):
        if self.k >= 0 and self.k not in self.answered:
            self.misses += 1
        self.publish_next()

    def on_answer(self, msg):
        k = int(msg.data)
        self.answered.add(k)
        self.latencies.append(time.monotonic() - self.sent_at.pop(k, time.monotonic()))
        if self.clock == 'lockstep':
            self.publish_next()

    def result(self) -> dict:
        import numpy as np
        wall = time.monotonic() - self.t0
        lat = np.array(self.latencies) * 1e3
        return {'steps': self.k, 'wall_s': wall, 'steps_per_s': self.k / wall,
                'plant_cpu_s': _cpu() - self.cpu0, 'misses': self.misses,
                'miss_pct': 100.0 * self.misses / max(self.k, 1),
                'latency_p50_ms': float(np.percentile(lat, 50)) if lat.size else None,
                'latency_p99_ms': float(np.percentile(lat, 99)) if lat.size else None}


def _spin_waitset(node, stop):
    """The raw wait-set loop over the subscriptions and timers of ``node`` (no executor)."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    subs = list(node.subscriptions)
    timers, ws = None, None
    while not stop():
        if timers is None or len(timers) != len(node._timers):
            timers = list(node.timers)
            ws = _rclpy.WaitSet(len(subs), 0, len(timers), 0, 0, 0, node.context.handle)
        ws.clear_entities()
        for s in subs:
            ws.add_subscription(s.handle)
        for t in timers:
            ws.add_timer(t.handle)
        ws.wait(100_000_000)
        ready_t = ws.get_ready_entities('timer')
        for t in timers:
            if t.handle.pointer in ready_t and t.handle.is_timer_ready():
                t.handle.call_timer()
                t.callback()
        ready = ws.get_ready_entities('subscription')
        for s in subs:
            if s.handle.pointer in ready:
                while (got := s.handle.take_message(s.msg_type, False)) is not None:
                    s.callback(got[0])


def node_process(roles, mode, clock, steps, seconds):
    """One process: the given roles as nodes; prints one JSON line when done."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from irs_common.executor import LeanExecutor
    rclpy.init()
    nodes = [rclpy.create_node(f'floor_{r}') for r in roles]
    plant = None
    for node, role in zip(nodes, roles):
        if role == 'plant':
            plant = _Plant(node, clock, steps)
        else:
            _Relay(node, role)
    executor = None
    if mode != 'waitset':
        executor = LeanExecutor() if mode == 'lean' else SingleThreadedExecutor()
        for n in nodes:
            executor.add_node(n)
    cpu0 = _cpu()
    deadline = time.monotonic() + seconds + 30.0
    if plant is not None:
        while not plant.ready() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05) if executor else _spin_briefly(nodes[0])
        # discovery of the answer path: give the relays time to match their peers
        t_match = time.monotonic() + 1.0
        while time.monotonic() < t_match:
            executor.spin_once(timeout_sec=0.05) if executor else _spin_briefly(nodes[0])
        plant.start()
        end = time.monotonic() + seconds

        def stop():
            return plant.done or time.monotonic() > end
    else:
        flag = os.environ.get('FLOOR_STOP_FILE')

        def stop():
            return os.path.exists(flag) or time.monotonic() > deadline
    if executor is not None:
        while not stop():
            executor.spin_once(timeout_sec=0.1)
    else:
        _spin_waitset(nodes[0], stop)
    out = plant.result() if plant else {}
    out.update({'roles': roles, 'cpu_s': _cpu() - cpu0})
    print(json.dumps(out), flush=True)
    if executor is not None:
        executor.shutdown(timeout_sec=0)
    for n in nodes:
        n.destroy_node()
    rclpy.try_shutdown()


def _spin_briefly(node):
    import rclpy
    rclpy.spin_once(node, timeout_sec=0.05)


def run(mode, clock, composed, seconds, steps=10**9, domain=None) -> dict:
    """One floor measurement; returns the plant's figures plus total CPU per hop [us]."""
    import tempfile
    if domain is None:
        from common import domain as claim     # bench/common.py: the suite's allocator
        domain = claim()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    stop_file = os.path.join(tempfile.mkdtemp(), 'stop')
    env['FLOOR_STOP_FILE'] = stop_file
    groups = [['plant', 'estimator', 'controller']] if composed else \
        [['estimator'], ['controller'], ['plant']]
    procs = [subprocess.Popen([sys.executable, __file__, '--child', ','.join(g), '--mode', mode,
                               '--clock', clock, '--seconds', str(seconds),
                               '--steps', str(steps)],
                              stdout=subprocess.PIPE, text=True, env=env) for g in groups]
    plant_out = procs[-1].communicate(timeout=seconds + 120)[0]
    open(stop_file, 'w').close()
    outs = [json.loads(plant_out.strip().splitlines()[-1])]
    for p in procs[:-1]:
        outs.append(json.loads(p.communicate(timeout=30)[0].strip().splitlines()[-1]))
    res = dict(outs[0])
    cpu = sum(o['cpu_s'] for o in outs)
    res.update({'mode': mode, 'clock': clock, 'composed': composed, 'cpu_total_s': cpu,
                'cpu_per_step_us': 1e6 * cpu / max(res['steps'], 1),
                'cpu_per_hop_us': 1e6 * cpu / max(res['steps'], 1) / 3.0})
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--child')
    ap.add_argument('--mode', default='lean', choices=['single', 'waitset', 'lean'])
    ap.add_argument('--clock', default='lockstep', choices=['lockstep', 'realtime'])
    ap.add_argument('--seconds', type=float, default=10.0)
    ap.add_argument('--steps', type=int, default=10**9)
    a = ap.parse_args(argv)
    if a.child:
        node_process(a.child.split(','), a.mode, a.clock, a.steps, a.seconds)
        return 0
    for clock in ('lockstep', 'realtime'):
        for mode in ('single', 'waitset', 'lean'):
            print(json.dumps(run(mode, clock, False, a.seconds)), flush=True)
        print(json.dumps(run('lean', clock, True, a.seconds)), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
