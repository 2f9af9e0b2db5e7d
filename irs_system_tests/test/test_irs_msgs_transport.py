"""Every custom irs_msgs type crosses Fast DDS between two processes unchanged."""
import subprocess
import sys

import irs_msgs.msg as irs
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

TYPES = ['SteeringCommand', 'SteeringActuatorState', 'TreadmillDriveCommand', 'TreadmillState',
         'BeltSpeed', 'DriverCommand', 'LateralReference', 'LateralControllerStatus',
         'SensingStatus', 'RigStatus', 'WheelTorqueCommand', 'WheelEncoders', 'TyreState']
QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)


def filled(mtype, seed):
    """A message with every field set to a distinct non-default value."""
    msg = mtype()
    for i, (field, ftype) in enumerate(msg.get_fields_and_field_types().items()):
        k = seed * 100 + i + 1
        if ftype == 'std_msgs/Header':
            msg.header.stamp.sec, msg.header.stamp.nanosec = k, 1000 * k
            msg.header.frame_id = f'frame_{k}'
        elif ftype == 'double':
            setattr(msg, field, k + 0.25)
        elif ftype == 'boolean':
            setattr(msg, field, True)
        elif ftype == 'string':
            setattr(msg, field, f'text {k} ü')
        elif ftype in ('uint8', 'uint64'):
            setattr(msg, field, k % 200 + 1)
        elif ftype == 'int64':
            setattr(msg, field, -k)
        elif ftype == 'uint32':
            setattr(msg, field, k % 1000 + 1)
        elif ftype == 'double[4]':                 # the torque car's per-wheel arrays
            setattr(msg, field, [k + 0.25 * w for w in range(1, 5)])
        elif ftype == 'int64[4]':
            setattr(msg, field, [-k * w for w in range(1, 5)])
        elif ftype == 'boolean[4]':
            setattr(msg, field, [True, False, True, k % 2 == 0])
        else:
            raise AssertionError(
                f'test does not know how to fill {ftype} ({mtype.__name__}.{field})'
            )
    return msg


def test_all_message_types_are_listed():
    declared = sorted(
        n
        for n in dir(irs)
        if n[0].isupper() and hasattr(getattr(irs, n), 'get_fields_and_field_types')
    )
    assert declared == sorted(TYPES)


def test_every_irs_msgs_type_round_trips_between_processes(ros, tmp_path):
    node = ros.node
    echo = subprocess.Popen(
        [sys.executable, '-m', 'irs_system_tests.msg_echo', *TYPES],
        stdout=open(tmp_path / 'echo.log', 'wb'),
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        received = {}
        pubs, subs = {}, {}
        for name in TYPES:
            mtype = getattr(irs, name)
            pubs[name] = node.create_publisher(mtype, f'echo_in/{name}', QOS)
            subs[name] = node.create_subscription(
                mtype, f'echo_out/{name}', lambda m, n=name: received.setdefault(n, m), QOS)
        assert ros.wait_for_matched(list(pubs.values()) + list(subs.values()), timeout=30.0), \
            (tmp_path / 'echo.log').read_text()
        sent = {name: filled(getattr(irs, name), i) for i, name in enumerate(TYPES)}
        # Matched on our side is not yet matched on the echo's: its answer to a message that
        # came before its writer knew our reader is lost (VOLATILE). So each message is sent
        # again every 0.5 s until its echo came; every copy is the same message.
        for _ in range(40):
            for name in set(TYPES) - set(received):
                pubs[name].publish(sent[name])
            if ros.spin_until(lambda: len(received) == len(TYPES), timeout=0.5):
                break
        assert len(received) == len(TYPES), f'missing: {sorted(set(TYPES) - set(received))}'
        for name in TYPES:
            assert received[name] == sent[name], name
            assert received[name] is not sent[name]
    finally:
        echo.send_signal(2)
        assert echo.wait(15) == 0
