"""A torque-car run's bag as arrays (no rclpy): one time base per topic, by header stamp.

:func:`load_run` reads a run directory, a bag directory or an ``.mcap`` file into a :class:`Run`:
the experiment's name, every node's flat parameters (from the bag's ``irs_experiment``
metadata) and ``series``, topic key -> ``{'t': [s], field: array}`` in SI units (the wheels'
vectors as ``(N, 4)`` arrays, FL, FR, RL, RR). It exists so that the torque car's metrics and
plots read one set of arrays, not the bag; the topics and fields: :func:`load_run`.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from irs_common import yaml_io
from irs_common.orientation import yaw_from_quaternion

__all__ = ['Run', 'TOPICS', 'load_run', 'resolve_bag']


def _q(o) -> float:
    return yaw_from_quaternion(o.x, o.y, o.z, o.w)


def _kv(msg, key: str) -> float:
    """The value of ``key`` in the first status of a DiagnosticArray as a float (NaN if
    absent or not a number; ``true``/``false`` as 1/0).
    """
    for kv in (msg.status[0].values if msg.status else []):
        if kv.key == key:
            v = {'true': '1', 'false': '0'}.get(kv.value, kv.value)
            try:
                return float(v)
            except ValueError:
                return float('nan')
    return float('nan')


#: key -> (topic, {field: getter(msg)})
TOPICS = {
    'tyre': ('/rig/tyre_truth', {
        'slip': lambda m: list(m.slip), 'omega': lambda m: list(m.omega),
        'mu': lambda m: list(m.mu), 'fx': lambda m: list(m.fx),
        'x_belt': lambda m: m.x_belt, 'u': lambda m: m.u}),
    'enc': ('/wheels/encoders', {'velocity': lambda m: list(m.velocity)}),
    'cmd': ('/wheels/torque_command', {
        'torque': lambda m: list(m.torque), 'locked': lambda m: [float(b) for b in m.locked]}),
    'odom': ('/ground_truth/odom', {
        'x': lambda m: m.pose.pose.position.x, 'y': lambda m: m.pose.pose.position.y,
        'yaw': lambda m: _q(m.pose.pose.orientation), 'r': lambda m: m.twist.twist.angular.z}),
    'pose': ('/pose', {'x': lambda m: m.pose.position.x, 'y': lambda m: m.pose.position.y,
                       'yaw': lambda m: _q(m.pose.orientation)}),
    'velocity': ('/velocity', {'r': lambda m: m.twist.angular.z}),
    'belt': ('/belt/speed', {'speed': lambda m: m.speed}),
    'steer': ('/steering/command', {'front': lambda m: m.front_angle,
                                    'rear': lambda m: m.rear_angle}),
    'act': ('/steering/state', {'front': lambda m: m.front_achieved,
                                'rear': lambda m: m.rear_achieved}),
    'status': ('/chassis/status', {
        'v_hat': lambda m: _kv(m, 'v_hat'), 'v_ref': lambda m: _kv(m, 'v_ref'),
        'braking': lambda m: _kv(m, 'braking'),
        'slip': lambda m: [_kv(m, f'slip_{w}') for w in ('FL', 'FR', 'RL', 'RR')],
        'target': lambda m: [_kv(m, f'slip_target_{w}') for w in ('FL', 'FR', 'RL', 'RR')]}),
}


@dataclass
class Run:
    """One run: experiment ``name``, its bag ``path``, node ``params``, ``series`` and the
    reader's ``warnings`` (e.g. only a prefix of an unfinished bag was readable).
    """

    name: str
    path: Path
    params: dict = field(default_factory=dict)
    series: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    def param(self, key: str, default=None):
        """The first node parameter called ``key`` (e.g. ``'brake.torque'``), else ``default``."""
        for values in self.params.values():
            if key in values:
                return values[key]
        return default

    def has(self, *keys: str) -> bool:
        """True if every topic key (e.g. ``'tyre'``) has at least two samples."""
        return all(k in self.series and self.series[k]['t'].size >= 2 for k in keys)


def resolve_bag(path) -> Path:
    """The bag of a run directory (``<run>/bag``), else ``path`` itself; ``ValueError`` if
    it does not exist.
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f'{path}: no such run directory or bag')
    if p.is_dir() and (p / 'bag').is_dir():
        return p / 'bag'
    return p


def _name_from_path(bag: Path) -> str:
    run_dir = bag.parent if bag.name == 'bag' or bag.suffix == '.mcap' else bag
    if run_dir.name == 'bag':
        run_dir = run_dir.parent
    return re.sub(r'-\d[\d_T:-]*$', '', run_dir.name)


def _metadata(reader) -> tuple[str | None, dict]:
    name, params = None, {}
    for key, meta in reader.metadata_records():
        if key != 'irs_experiment':
            continue
        try:
            doc = yaml_io.safe_load(meta.get('experiment_yaml', '')) or {}
            name = doc.get('name', name) if isinstance(doc, dict) else name
            params = json.loads(meta.get('node_parameters', '{}')) or params
        except (yaml.YAMLError, ValueError):
            continue
    return name, params if isinstance(params, dict) else {}


def _stamp_s(msg) -> float:
    s = msg.header.stamp
    return int(s.sec) + int(s.nanosec) * 1e-9


def load_run(path) -> Run:
    """Read the run at ``path``.

    ``load_run(path)`` reads a run directory (``<run>/bag``), a bag directory or an ``.mcap`` file
    and returns a :class:`Run`: the experiment's ``name`` (from the bag's ``irs_experiment``
    metadata, else the run directory's name without its ``-<time>`` suffix), the flat parameters of
    every node (from the same metadata; empty without it) and ``series``: topic key -> ``{'t': [s],
    field: array}``. Vectors of the four wheels are ``(N, 4)`` arrays, wheels FL, FR, RL, RR.

    =========  ==========================  ============================================
    key        topic                       fields
    =========  ==========================  ============================================
    tyre       /rig/tyre_truth             slip, omega [rad/s], mu, fx [N], x_belt [m], u [m/s]
    enc        /wheels/encoders            velocity [rad/s]
    cmd        /wheels/torque_command      torque [N m], locked
    odom       /ground_truth/odom          x, y [m], yaw [rad], r [rad/s]
    pose       /pose                       x, y [m], yaw [rad]  (the arm's measurement)
    velocity   /velocity                   r [rad/s]  (the arm's yaw rate)
    belt       /belt/speed                 speed [m/s]  (the belt encoder)
    steer      /steering/command           front, rear [rad]
    act        /steering/state             front, rear [rad]  (achieved)
    status     /chassis/status             v_hat (arm), v_ref (wheels) [m/s], braking, slip,
                                           target (the controller's view; DiagnosticArray
                                           key/values ``v_hat``, ``v_ref``, ``braking``,
                                           ``slip_FL``, ``slip_target_FL`` ...; NaN where absent)
    =========  ==========================  ============================================

    A topic missing from the bag is missing from ``series``. Messages whose stamp repeats (a
    lock-step resend) are kept once (the last one).

    Raises
    ------
    ValueError
        No such path, not a readable bag, or none of the torque car's topics in it.
    """
    from irs_bag.reader import BagReader
    from irs_bag import BagError

    bag = resolve_bag(path)
    by_topic = {topic: (key, getters) for key, (topic, getters) in TOPICS.items()}
    rows: dict = {key: {} for key in TOPICS}
    try:
        with BagReader(bag, allow_partial=True) as reader:
            name, params = _metadata(reader)
            warnings = list(reader.warnings)
            present = [t for t in by_topic if t in reader.topics]
            if not any(t in present for t in ('/rig/tyre_truth', '/wheels/torque_command')):
                raise ValueError(f'{path}: no /rig/tyre_truth or /wheels/torque_command '
                                 'messages: not a torque-car run')
            for m, msg in reader.decoded(present):
                key, getters = by_topic[m.topic]
                rows[key][_stamp_s(msg)] = [get(msg) for get in getters.values()]
    except BagError as exc:
        raise ValueError(f'{path}: not a readable bag ({exc})') from None
    except (AttributeError, TypeError) as exc:
        raise ValueError(f'{path}: a message does not have the expected fields ({exc})') \
            from None
    series = {}
    for key, by_stamp in rows.items():
        if not by_stamp:
            continue
        stamps = sorted(by_stamp)
        data = {'t': np.array(stamps, dtype=float)}
        for i, fname in enumerate(TOPICS[key][1]):
            data[fname] = np.array([by_stamp[s][i] for s in stamps], dtype=float)
        series[key] = data
    return Run(name or _name_from_path(Path(bag)), Path(bag), params, series, warnings)
