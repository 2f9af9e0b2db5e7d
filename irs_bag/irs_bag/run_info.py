"""What a recorded run is, from its bag's metadata: name, controller, arm and car (no rclpy).

The experiment runner writes the MCAP metadata record ``irs_experiment`` (experiment name,
``node_parameters`` as JSON, start time). A recorder started by hand writes instead what each
node of the graph answered when asked for its parameters (records ``irs_node_parameters``,
:mod:`irs_bag.node_parameters`). The plots put :attr:`RunInfo.title` (run and controller) on
every figure, and the rerun export draws the arm and the car with the rig's own geometry
(``vehicle_sim`` parameters ``arm.*``, ``car.length``, ``car.width``). A bag with neither gets
the defaults of docs/conventions.md and the controller ``'controller unknown'``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from irs_models.arm_kinematics import ArmGeometry

from .node_parameters import node_parameters_from_records

__all__ = ['RunInfo', 'controller_label', 'run_info', 'run_info_from_metadata', 'run_name']

#: Car box drawn when the rig's size is unknown [m] (the 1:10 car, docs/vehicle_presets.md).
CAR_LENGTH, CAR_WIDTH = 0.45, 0.20


@dataclass(frozen=True)
class RunInfo:
    """A run's name, its controller in words, and the rig geometry the views draw."""

    name: str
    controller: str = 'controller unknown'
    experiment: str = ''
    geometry: ArmGeometry = field(default_factory=ArmGeometry)
    car_length: float = CAR_LENGTH        # [m]
    car_width: float = CAR_WIDTH          # [m]

    @property
    def title(self) -> str:
        """One line for a figure title: ``'<run> | <controller>'``."""
        return f'{self.name} | {self.controller}'


def controller_label(node_parameters: dict) -> str:
    """The run's controller in a few words, from the experiment's node parameters."""
    lat = node_parameters.get('lateral_controller')
    if lat is not None:
        mode = str(lat.get('mode', 'mrc'))
        if mode == 'pi':
            label = f"PI (kp {float(lat.get('kp', 0)):g}, ki {float(lat.get('ki', 0)):g})"
        else:
            with_actuator = bool(lat.get('include_actuator', True))
            label = f"MRC {'with' if with_actuator else 'without'} actuator model"
        plant = lat.get('plant', 'identified')
        return label if plant == 'identified' else f'{label}, design plant {plant}'
    if 'chassis_controller' in node_parameters:
        return 'chassis controller (torque car)'
    if 'excitation' in node_parameters:
        return 'open loop (excitation)'
    return 'no lateral controller'


def run_name(bag_path) -> str:
    """The run directory's name for ``<run>/bag``, else the bag's own name."""
    p = Path(str(bag_path))
    if p.suffix == '.mcap':
        p = p.parent if p.parent.name == 'bag' else p.with_suffix('')
    return p.parent.name if p.name == 'bag' and p.parent.name else p.name


def _geometry(rig: dict) -> ArmGeometry:
    keys = {'l1': 'arm.l1', 'l2': 'arm.l2', 'base_x': 'arm.base_x', 'base_y': 'arm.base_y',
            'attach_offset': 'arm.attach_offset', 'elbow': 'arm.elbow'}
    values = {k: rig[p] for k, p in keys.items() if p in rig}
    try:
        return ArmGeometry(**values)
    except (TypeError, ValueError):
        return ArmGeometry()


def run_info_from_metadata(name: str, meta: dict | None,
                           graph_parameters: dict | None = None) -> RunInfo:
    """:class:`RunInfo` from the ``irs_experiment`` record (a dict of strings) or None; without
    node parameters in it, from ``graph_parameters`` (``{node: {parameter: value}}``, what the
    nodes of a graph recorded by hand answered).
    """
    if not meta and not graph_parameters:
        return RunInfo(name)
    meta = meta or {}
    try:
        params = json.loads(meta.get('node_parameters', '{}'))
    except json.JSONDecodeError:
        params = {}
    if not isinstance(params, dict):
        params = {}
    params = params or dict(graph_parameters or {})
    rig = params.get('vehicle_sim') or {}
    try:
        length = float(rig.get('car.length', CAR_LENGTH))
        width = float(rig.get('car.width', CAR_WIDTH))
    except (TypeError, ValueError):
        length, width = CAR_LENGTH, CAR_WIDTH
    return RunInfo(name, controller_label(params) if params else 'controller unknown',
                   str(meta.get('experiment_name', '')), _geometry(rig), length, width)


def run_info(reader) -> RunInfo:
    """:class:`RunInfo` of an open :class:`~irs_bag.reader.BagReader`."""
    records = reader.metadata_records()
    meta = dict(records).get('irs_experiment')
    return run_info_from_metadata(run_name(reader.path), meta,
                                  node_parameters_from_records(records))
