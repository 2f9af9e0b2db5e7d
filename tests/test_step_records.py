"""The per-step records' written ``__init__`` takes and sets exactly their dataclass fields.

The seven records the 1 kHz loop builds every step have a written ``__init__`` (compiled by
mypyc it is native code, where the one ``dataclasses`` generates stays Python:
``irs_common.native_cores``). Each must accept every field by name, in the order of the
fields, with the field's default, and set it; a field added to the class but not to its
``__init__`` fails here.
"""
import dataclasses

import pytest

from irs_control.discrete_rst import ControlOutput
from irs_models.arm_kinematics import ArmPose
from irs_sensing.pose_estimator import PoseEstimate
from irs_treadmill.regulator import RegulatorOutput
from irs_vehicle_sim.actuator import ActuatorState
from irs_vehicle_sim.rig import RigInputs, RigOutputs

RECORDS = (ArmPose, PoseEstimate, ControlOutput, RegulatorOutput, ActuatorState, RigInputs,
           RigOutputs)


def _value(field: dataclasses.Field, i: int):
    """A value for ``field`` that differs from its default and from the other fields'."""
    # a string (postponed annotations), or the class where the compiled class resolved it
    kind = field.type if isinstance(field.type, str) else getattr(field.type, '__name__', '')
    if field.default is not dataclasses.MISSING and field.default is None:
        return None
    if kind == 'bool':
        return not field.default if field.default is not dataclasses.MISSING else bool(i % 2)
    if kind == 'float':
        return 0.5 + i
    if kind == 'str':
        return f'text {i}'
    if kind == 'tuple':
        return (float(i),)
    if kind == 'ActuatorState':
        return ActuatorState(commanded=float(i))
    raise AssertionError(f'{field.name}: add a value for type {kind!r}')


@pytest.mark.parametrize('record', RECORDS, ids=lambda r: r.__name__)
def test_init_takes_and_sets_every_field_in_order_with_its_default(record):
    fields = dataclasses.fields(record)
    values = {f.name: _value(f, i) for i, f in enumerate(fields)}
    by_name = record(**values)
    assert {name: getattr(by_name, name) for name in values} == values
    by_position = record(*values.values())
    assert by_position == by_name
    required = {f.name: values[f.name] for f in fields if f.default is dataclasses.MISSING}
    defaulted = record(**required)
    assert {f.name: getattr(defaulted, f.name) for f in fields
            if f.default is not dataclasses.MISSING} == \
        {f.name: f.default for f in fields if f.default is not dataclasses.MISSING}
