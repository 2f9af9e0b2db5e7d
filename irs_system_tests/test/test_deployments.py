"""Composition: the same experiment composed in one process or one process per node.

Lock-step runs are reproducible to the bit whatever the deployment: the composed graph (every
node and the recorder in one ``container`` process, one executor) and the process-per-node
graph record the same messages, every field bit for bit, on every topic. Receive times differ by
nature; a lock-step resend records identical duplicates, so distinct messages per topic are
compared.
"""
import json

from irs_bag.reader import BagReader
from irs_bringup.experiment import load_experiment
from irs_bringup.experiment_runner import ExperimentRunner


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


def _experiment(composed: bool):
    exp = load_experiment('figure10_mrc_with_actuator')
    exp.name = 'deployment_' + ('composed' if composed else 'processes')
    exp.duration = 1.0                        # [s] the step at 0.5 s and half a second after
    # composed: the recorder too, in-process (irs_bringup's ComposableRecorder)
    return exp.composed('loop') if composed else exp


def test_composed_and_process_per_node_record_identical_bags(tmp_path):
    bags = {}
    for composed in (False, True):
        exp = _experiment(composed)
        result = ExperimentRunner(exp, runs_dir=tmp_path / 'runs', progress=False).run()
        assert result.completed, result.message
        if composed:   # one container for the five nodes and the recorder
            assert set(result.exit_codes) == {'loop'}, result.exit_codes
        else:
            assert len(result.exit_codes) == 6, result.exit_codes
        assert all(code == 0 for code in result.exit_codes.values()), result.exit_codes
        bags[composed] = _payloads(result.bag_dir)
        with BagReader(result.bag_dir) as reader:   # the deployment is in the bag's metadata
            processes = json.loads(dict(reader.metadata_records())['irs_experiment']['processes'])
        assert processes == {name: ('loop' if composed else None)
                             for name in [*(n.name for n in exp.nodes), 'recorder']}
    separate, composed = bags[False], bags[True]
    assert set(separate) == set(composed) == {'/' + t.lstrip('/') for t in exp.record_topics}
    for topic in separate:
        assert len(separate[topic]) > 0
        assert separate[topic] == composed[topic], f'{topic} differs between the deployments'
    # 1 s at 1 kHz: steps 0..1000 on a 1 kHz topic (the step response itself is in the data).
    assert len(separate['/arm/joint_states']) == 1001
