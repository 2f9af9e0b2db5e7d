"""Deployment: the default deployment records the same bag as one process per node.

Lock-step runs are reproducible to the bit whatever the deployment, which is why a lock-step
experiment runs composed by default (``Experiment.deployed``): every node and the recorder in
one ``container`` process, one executor. For each experiment family that runs so (Figure 10, a
sysid experiment, the torque car), a short run in the default deployment and one with a
process per node record the same messages, every field bit for bit, on every topic. Receive
times differ by nature; a lock-step resend records identical duplicates, so distinct messages
per topic are compared.
"""
import json

from mcap.stream_reader import StreamReader
import pytest

from irs_bag.node_parameters import RECORD
from irs_bag.reader import BagReader
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import COMPOSED_CHUNK_MESSAGES, ExperimentRunner

#: experiment -> (duration [s]: long enough for its first event, a topic the rig publishes at
#: every 1 ms step).
CASES = {
    # the reference step at 0.5 s and half a second of the MRC's answer
    'figure10_mrc_with_actuator': (1.0, '/arm/joint_states'),
    # the first steer step (1 deg at 0.5 s) and its release at 1.1 s through the servo model
    'sysid_actuator_steps': (1.2, '/steering/state'),
    # braking from 0.05 s: fixed-target ABS cycling on split mu, the tyres' truth recorded
    'torque_braking_abs_split': (0.4, '/wheels/encoders'),
}


def _message_class(type_name: str):
    """``'pkg/msg/Type'`` -> the message class."""
    import importlib
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def _payloads(bag_dir) -> dict:
    """``{topic: {message repr}}``: every field of every message, floats exactly (``repr`` of a
    float round-trips to the same bits). CDR bytes are not compared: Fast DDS leaves alignment
    padding uninitialised and pads in-process deliveries differently.
    """
    from rclpy.serialization import deserialize_message
    out = {}
    with BagReader(bag_dir) as reader:
        types = {name: _message_class(info.type) for name, info in reader.topics.items()}
        for m in reader.messages():
            msg = deserialize_message(bytes(m.data), types[m.topic])
            out.setdefault(m.topic, set()).add(repr(msg))
    return out


def _largest_chunk(bag_dir) -> int:
    """The most messages in one chunk of the bag (from the message indexes after each chunk)."""
    sizes, current = [], None
    with open(next(bag_dir.glob('*.mcap')), 'rb') as f:
        for record in StreamReader(f, emit_chunks=True).records:
            kind = type(record).__name__
            if kind == 'Chunk':
                current = 0
                sizes.append(current)
            elif kind == 'MessageIndex' and current is not None:
                sizes[-1] += len(record.records)
    return max(sizes)


def _run(exp, runs_dir) -> tuple:
    """Run ``exp``; its payloads and the bag's largest chunk [messages], after checking the
    processes and the bag's metadata.
    """
    result = ExperimentRunner(exp, runs_dir=runs_dir, progress=False).run()
    assert result.completed, result.message
    groups = set(exp.processes().values())
    assert set(result.exit_codes) == (groups if None not in groups else set(exp.processes()))
    assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes
    with BagReader(result.bag_dir) as reader:   # the deployment is in the bag's metadata
        records = reader.metadata_records()
    recorded = json.loads(dict(records)['irs_experiment']['processes'])
    assert recorded == exp.processes()
    # the experiment's node parameters are in that record: the recorder asks the nodes for none
    assert [name for name, _ in records if name == RECORD] == []
    return _payloads(result.bag_dir), _largest_chunk(result.bag_dir)


@pytest.mark.parametrize('name', sorted(CASES))
def test_default_deployment_records_the_bag_of_process_per_node(tmp_path, name):
    duration, every_step = CASES[name]
    exp = load_experiment(name).with_duration(duration)
    default, separate = exp.deployed(), exp.deployed('process_per_node')
    # the default: the nodes and the recorder in one process; the other: one process each
    assert len(set(default.processes().values())) == 1, default.processes()
    assert None not in default.processes().values(), default.processes()
    assert set(separate.processes().values()) == {None}
    default.name, separate.name = f'{name}_default', f'{name}_per_node'
    (composed, composed_chunk), (per_node, per_node_chunk) = (_run(default, tmp_path),
                                                              _run(separate, tmp_path))
    # the recorder in the loop's process cuts its chunks short; on its own it need not
    assert composed_chunk <= COMPOSED_CHUNK_MESSAGES < per_node_chunk
    assert set(per_node) == set(composed) == {'/' + t.lstrip('/') for t in exp.record_topics}
    for topic in per_node:
        assert len(per_node[topic]) > 0, topic
        assert per_node[topic] == composed[topic], f'{topic} differs between the deployments'
    # every 1 ms step of the run is in the bags: steps 0 .. duration / dt
    assert len(per_node[every_step]) == round(duration * 1000) + 1
