"""Drive a lock-step ``vehicle_sim`` from the test process (the test plays the controller).

``run_lockstep(ros, command_fn, duration)`` answers every rig step t_k (seen on the trigger topic)
with ``SteeringCommand(front = command_fn(t_k))`` stamped t_k, and records the rig's outputs by
stamp. It waits for the graph to connect (the rig is started with ``autostart: false`` and then
through its ``rig/start`` service), never on fixed sleeps.
"""
from geometry_msgs.msg import PointStamped
from std_srvs.srv import Trigger

from irs_common import qos
from irs_common.stamps import to_ns
from irs_msgs.msg import SteeringActuatorState, SteeringCommand
from sensor_msgs.msg import JointState

from irs_bringup.graph import call_rig_start
from irs_bringup.processes import NodeSpec


#: The rig's topics :func:`run_lockstep` records, one subscription each: the rig holds step 0
#: until each of its writers has matched the test's reader (``start_subscribers``,
#: :mod:`irs_common.start_gate`; the reader's own view of the match does not settle it, and a
#: writer that matches after step 0 never delivers step 0).
RECORDED = 'ground_truth/sensor_point=1,steering/state=1,arm/joint_states=1'


def rig_spec(start_subscribers=RECORDED, **params):
    """The rig in lock-step on the steering input only, waiting for rig/start, then for the
    subscriptions ``start_subscribers`` names (``'topic=count,...'``).
    """
    from ament_index_python.packages import get_package_share_directory
    base = {'clock_mode': 'lockstep', 'lockstep_inputs': ['steering'], 'autostart': False,
            'start_subscribers': start_subscribers}
    rig_yaml = f"{get_package_share_directory('irs_vehicle_sim')}/config/rig.yaml"
    return NodeSpec('irs_vehicle_sim', 'vehicle_sim', params_files=[rig_yaml],
                    params={**base, **params})


def offline_rig_params(**params) -> dict:
    """The same rig parameters as :func:`rig_spec` for the offline core (node-only keys out)."""
    from irs_bringup.experiment import NodeEntry, node_parameters
    spec = rig_spec(**params)
    values = node_parameters(NodeEntry('vehicle_sim', spec.package, spec.executable,
                                       spec.params_files, spec.params))
    for key in ('clock_mode', 'lockstep_inputs', 'autostart', 'lockstep_resend_period',
                'default_drive_voltage', 'frame_id', 'child_frame_id', 'publish_wheel_speeds',
                'max_steps', 'start_subscribers'):
        values.pop(key, None)
    return values


def run_lockstep(ros, command_fn, duration, timeout=300.0):
    """Run the rig for ``duration`` s; returns ``{topic: {stamp_ns: msg}}``."""
    node = ros.node
    rec = {'point': {}, 'actuator': {}, 'arm': {}}
    pub = node.create_publisher(SteeringCommand, 'steering/command', qos.COMMAND_PUB)
    end_ns = int(round(duration * 1e9))

    def on_point(msg):
        stamp = to_ns(msg.header.stamp)
        if stamp in rec['point']:
            return
        rec['point'][stamp] = msg
        if stamp < end_ns:
            cmd = SteeringCommand()
            cmd.header.stamp = msg.header.stamp
            cmd.front_angle = float(command_fn(stamp * 1e-9))
            pub.publish(cmd)

    subs = [
        node.create_subscription(PointStamped, 'ground_truth/sensor_point', on_point, qos.SENSOR),
        node.create_subscription(SteeringActuatorState, 'steering/state',
                                 lambda m: rec['actuator'].setdefault(to_ns(m.header.stamp), m),
                                 qos.SENSOR),
        node.create_subscription(JointState, 'arm/joint_states',
                                 lambda m: rec['arm'].setdefault(to_ns(m.header.stamp), m),
                                 qos.SENSOR),
    ]
    assert ros.wait_for_matched([pub, *subs], timeout=30.0), 'rig topics did not match'
    client = node.create_client(Trigger, 'rig/start')
    assert ros.spin_until(client.service_is_ready, 30.0), 'rig/start not available'
    ok, message = call_rig_start(ros, client)
    assert ok, message
    n_steps = int(round(duration * 1000)) + 1
    done = ros.spin_until(lambda: all(len(v) >= n_steps for v in rec.values()), timeout)
    if not done:
        expected = {round(k * 1e6) for k in range(n_steps)}     # the steps' stamps [ns]
        missing = {name: sorted(expected - set(v))[:5] for name, v in rec.items()}
        raise AssertionError(f'lock-step run incomplete: {[len(v) for v in rec.values()]} of '
                             f'{n_steps} samples; the first stamps missing: {missing}')
    return rec
