"""Meta-tests of the nodes' parameters: documented with units, docs current, YAML consistent."""
from pathlib import Path

import pytest
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
           'chassis_controller': 'irs_control/config/chassis_controller.yaml',
           'driver': 'irs_bringup/config/driver.yaml',
           'rig_hardware': 'irs_hardware/config/hardware.yaml'}


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


def test_config_files_only_set_declared_parameters_with_valid_values():
    tables = {node: {p.name: p for p in table} for _pkg, node, table in node_tables()}
    for node, rel in CONFIGS.items():
        doc = yaml.safe_load((ROOT / rel).read_text())
        values = flatten(doc[node]['ros__parameters'])
        for name, value in values.items():
            assert name in tables[node], f'{rel}: {name} is not a parameter of {node}'
            tables[node][name].coerce(value)     # type (an int is a double), range, validator


def test_architecture_doc_lists_every_topic():
    text = (ROOT / 'docs' / 'architecture.md').read_text()
    for io in NODE_TOPICS.values():
        for topic in io['pub'] + io['sub']:
            assert f'`{topic}`' in text, topic


NODE_CLASSES = {
    'vehicle_sim': 'irs_vehicle_sim.vehicle_sim_node:VehicleSimNode',
    'rig_hardware': 'irs_hardware.rig_hardware_node:RigHardwareNode',
    'arm_pose_estimator': 'irs_sensing.arm_pose_estimator_node:ArmPoseEstimatorNode',
    'treadmill_regulator': 'irs_treadmill.treadmill_regulator_node:TreadmillRegulatorNode',
    'lateral_controller': 'irs_control.lateral_controller_node:LateralControllerNode',
    'reference_generator': 'irs_control.reference_generator_node:ReferenceGeneratorNode',
    'chassis_controller': 'irs_control.chassis_controller_node:ChassisControllerNode',
    'driver': 'irs_bringup.driver.driver_node:DriverNode',
    'excitation': 'irs_sysid.excitation_node:ExcitationNode',
    'recorder': 'irs_bag.recorder_node:Recorder',
    'live_view': 'irs_bag.live_view_node:LiveViewNode',
}
RCLPY_PARAMETERS = {'use_sim_time', 'start_type_description_service'}


def _all_tables():
    from irs_bag.recorder_node import NODE_PARAMS as RECORDER
    return [(node, table) for _pkg, node, table in node_tables()] + [('recorder', RECORDER)]


def test_every_node_declares_its_whole_table_through_the_parameter_mechanism(
    tmp_path, monkeypatch
):
    """Built with defaults (live_view with a file to write), every node has exactly its table's
    parameters, each with the table's read-only flag; every writable one has a handler and takes
    its own value back through the on-set/post-set path, every read-only one refuses a change.
    """
    import importlib

    import rclpy
    from rclpy.parameter import Parameter

    from irs_common.params import ParameterGuard

    monkeypatch.chdir(tmp_path)          # the recorder's default bag directory is relative
    assert {n for n, _t in _all_tables()} == set(NODE_CLASSES)
    rclpy.init()
    try:
        for node_name, table in _all_tables():
            module, cls = NODE_CLASSES[node_name].split(':')
            # live_view's default streams to a rerun viewer, and with none running rerun waits
            # 5 s to connect and 5 s more at the end: it writes its stream to a file here
            options = ({'parameter_overrides': [Parameter('save', value=str(tmp_path / 'v.rrd'))]}
                       if node_name == 'live_view' else {})
            node = getattr(importlib.import_module(module), cls)(**options)
            try:
                guard = getattr(node, ParameterGuard.ATTRIBUTE)
                declared = set(node.list_parameters([], 0).names) - RCLPY_PARAMETERS
                assert declared == {p.name for p in table}, (
                    f'{node_name}: declared outside its table'
                )
                for p in table:
                    assert guard.params[p.name] == p, f'{node_name}.{p.name}'
                    assert node.describe_parameter(p.name).read_only == p.read_only
                    current = node.get_parameter(p.name).value
                    [res] = node.set_parameters([Parameter(p.name, value=current)])
                    if p.writable:
                        assert callable(guard.handlers.get(p.name)), (
                            f'{node_name}.{p.name}: no handler'
                        )
                        assert res.successful, f'{node_name}.{p.name}: {res.reason}'
                    else:
                        assert p.name not in guard.handlers
                        assert not res.successful and 'read-only' in res.reason, (
                            f'{node_name}.{p.name}'
                        )
            finally:
                node.destroy_node()
    finally:
        rclpy.shutdown()


def test_parameter_tables_are_well_formed_for_the_mechanism():
    """Every default passes its own checks and has a type the mechanism can declare."""
    for node_name, table in _all_tables():
        for p in table:
            assert p.coerce(p.default) == p.default, f'{node_name}.{p.name}'
            assert p.writable is not p.read_only


def test_param_docs_help_prints_usage_and_writes_nothing(tmp_path, monkeypatch, capsys):
    from irs_bringup.param_docs import main
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(['--help'])
    assert exc.value.code == 0
    assert 'usage:' in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []
    assert main([str(tmp_path / 'p.md')]) == 0
    assert (tmp_path / 'p.md').read_text() == render()
