"""Meta-tests of the nodes' parameters: documented with units, docs current, YAML consistent."""
from pathlib import Path

import yaml

from irs_bringup.experiment import NODE_TOPICS
from irs_bringup.param_docs import node_tables, render
from irs_common.params import flatten

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = {'vehicle_sim': 'irs_vehicle_sim/config/rig.yaml',
           'arm_pose_estimator': 'irs_sensing/config/sensing.yaml',
           'treadmill_regulator': 'irs_treadmill/config/treadmill.yaml',
           'lateral_controller': 'irs_control/config/lateral_controller.yaml',
           'reference_generator': 'irs_control/config/reference_generator.yaml',
           'driver': 'irs_bringup/config/driver.yaml'}


def test_every_parameter_has_a_description_and_a_unit():
    for _pkg, node, table in node_tables():
        names = [p.name for p in table]
        assert len(names) == len(set(names)), f'{node}: duplicate parameter names'
        for p in table:
            assert p.description.strip() and p.unit.strip(), f'{node}.{p.name}'
            assert f'[{p.unit}]' in p.descriptor().description


def test_parameters_doc_is_current():
    assert (ROOT / 'docs' / 'parameters.md').read_text() == render(), \
        'run: ./irs exec python -m irs_bringup.param_docs'


def test_config_files_only_set_declared_parameters_of_the_right_type():
    tables = {node: {p.name: p for p in table} for _pkg, node, table in node_tables()}
    for node, rel in CONFIGS.items():
        doc = yaml.safe_load((ROOT / rel).read_text())
        values = flatten(doc[node]['ros__parameters'])
        for name, value in values.items():
            assert name in tables[node], f'{rel}: {name} is not a parameter of {node}'
            default = tables[node][name].default
            assert type(value) is type(default) or (isinstance(default, list) and isinstance(value, list)), \
                f'{rel}: {name} = {value!r} has another type than the default {default!r}'


def test_architecture_doc_lists_every_topic():
    text = (ROOT / 'docs' / 'architecture.md').read_text()
    for io in NODE_TOPICS.values():
        for topic in io['pub'] + io['sub']:
            assert f'`{topic}`' in text, topic
