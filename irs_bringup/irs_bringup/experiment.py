"""Experiment files: what runs, with which parameters, on which clock, for how long (no rclpy).

An experiment file (YAML, ``config/experiments/``) names the clock (``lockstep``: the rig
publishes ``/clock`` and runs are reproducible to the bit; ``realtime``), the duration [s], every
node with its package, executable, parameter files, overrides, remaps and optional ``process:``
group, the topics to record and, for the torque car, the road surface. It exists so that a run
is one reviewed file, checked before anything starts; the annotated format:
:class:`Experiment`.

Clock handling is the runner's job: for ``lockstep`` it sets ``clock_mode: lockstep``,
``autostart: false`` and ``max_steps`` on the rig and ``use_sim_time: true`` on every other node;
for ``realtime`` ``clock_mode: realtime``.

Deployment (:meth:`Experiment.deployed`): a lock-step file that places no node (no
``process:``) runs composed, every node and the recorder in one ``container`` process, the
fastest deployment with the same bag to the bit (``irs_system_tests/test/test_deployments.py``);
a file that places its nodes, and every real-time file, runs as written. ``--composed`` and
``--process-per-node`` choose either deployment for any file.
"""
from copy import deepcopy
from dataclasses import dataclass, field, replace
import math
from pathlib import Path

import yaml

from irs_common import yaml_io
from irs_common.cli import InputError, did_you_mean

RIG_KEY = ('irs_vehicle_sim', 'vehicle_sim')
#: The rigs: the simulator and the hardware node (docs/hardware.md), one per experiment.
HARDWARE_RIG_KEY = ('irs_hardware', 'rig_hardware')
RIG_KEYS = (RIG_KEY, HARDWARE_RIG_KEY)
#: How :meth:`Experiment.deployed` places the nodes in processes (``experiment run``:
#: nothing, ``--composed``, ``--process-per-node``).
DEPLOYMENTS = ('default', 'composed', 'process_per_node')

#: Topics each node executable publishes and subscribes (relative names), used to wait until the
#: graph is connected and documented in docs/architecture.md.
NODE_TOPICS = {
    ('irs_vehicle_sim', 'vehicle_sim'): {
        'pub': ['/clock', 'arm/joint_states', 'belt/speed', 'steering/state', 'ground_truth/odom',
                'ground_truth/sensor_point', 'rig/status', 'rig/timing', 'treadmill/reset'],
        'sub': ['steering/command', 'treadmill/drive', 'driver/command', 'treadmill/state']},
    ('irs_hardware', 'rig_hardware'): {
        'pub': ['/clock', 'arm/joint_states', 'belt/speed', 'rig/status', 'rig/diagnostics',
                'rig/timing', 'treadmill/reset'],
        'sub': ['steering/command', 'treadmill/drive']},
    ('irs_sensing', 'arm_pose_estimator'): {
        'pub': ['pose', 'velocity', 'lateral_position', 'sensing/status'],
        'sub': ['arm/joint_states']},
    ('irs_control', 'lateral_controller'): {
        'pub': ['steering/command', 'lateral/status'],
        'sub': ['lateral_position', 'lateral/reference']},
    ('irs_control', 'reference_generator'): {'pub': ['lateral/reference'], 'sub': []},
    ('irs_control', 'chassis_controller'): {
        'pub': ['wheels/torque_command', 'steering/command', 'chassis/status'],
        'sub': ['wheels/encoders', 'pose', 'velocity', 'belt/speed']},
    ('irs_treadmill', 'treadmill_regulator'): {
        'pub': ['treadmill/drive', 'treadmill/state'],
        'sub': ['pose', 'velocity', 'belt/speed', 'treadmill/reset']},
    ('irs_bringup', 'driver'): {'pub': ['driver/command'], 'sub': []},
    ('irs_sysid', 'excitation'): {'pub': ['steering/command'], 'sub': []},   # target steering
}

#: Nodes whose topics depend on a parameter: key -> (parameter, {value: topics}); the value in
#: ``NODE_TOPICS`` is the one for the parameter's default.
NODE_TOPICS_BY_PARAMETER = {
    RIG_KEY: ('plant', {'two_track': {       # the torque car's rig (docs/torque_car.md)
        'pub': NODE_TOPICS[RIG_KEY]['pub'] + ['wheels/encoders', 'rig/tyre_truth'],
        'sub': NODE_TOPICS[RIG_KEY]['sub'] + ['wheels/torque_command']}}),
    HARDWARE_RIG_KEY: ('wheels', {True: {    # the torque car on the real rig (docs/hardware.md)
        'pub': NODE_TOPICS[HARDWARE_RIG_KEY]['pub'] + ['wheels/encoders'],
        'sub': NODE_TOPICS[HARDWARE_RIG_KEY]['sub'] + ['wheels/torque_command']}}),
    ('irs_sysid', 'excitation'): ('target', {
        'steering': {'pub': ['steering/command'], 'sub': []},
        'drive': {'pub': ['treadmill/drive'], 'sub': []}}),
}


def node_topics(entry) -> dict:
    """``{'pub': [...], 'sub': [...]}`` of an experiment's node (empty if not known)."""
    io = NODE_TOPICS.get(entry.key, {'pub': [], 'sub': []})
    if entry.key in NODE_TOPICS_BY_PARAMETER:
        name, by_value = NODE_TOPICS_BY_PARAMETER[entry.key]
        io = by_value.get(node_parameters(entry).get(name), io)
    return io


class ExperimentError(InputError):
    """The experiment file is missing, unreadable or inconsistent (message says what and where)."""


@dataclass
class NodeEntry:
    """One node of an experiment: what to start, with which parameters, in which process."""

    name: str
    package: str
    executable: str
    params_files: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    remaps: dict = field(default_factory=dict)
    process: str | None = None      # process group (same value: one process); None = its own

    @property
    def key(self):
        return (self.package, self.executable)


@dataclass
class Experiment:
    """A loaded experiment file.

    An experiment file (YAML, see ``config/experiments/``)::

        name: figure10_mrc_with_actuator
        description: one line
        clock: lockstep            # lockstep (rig publishes /clock, reproducible) | realtime
        duration: 8.0              # [s] simulated (lockstep) or wall (realtime) time
        nodes:                     # node name -> how to start it (as `ros2 run` would)
          vehicle_sim:
            package: irs_vehicle_sim
            executable: vehicle_sim
            params_files: [pkg://irs_vehicle_sim/config/rig.yaml]   # share/<pkg>/... or a path
            params: {plant: identified}                              # overrides, flat names
            remaps: {}
            process: rig           # optional group: nodes with the same one share a process
                                   # (none in the file: lock-step runs composed, deployed())
        record:
          topics: [arm/joint_states, ...]     # what the recorder writes to the bag ([] = no bag)
          process: loop                       # optional: the recorder composed with that group
        surface: {kind: split, mu_left: 0.8, mu_right: 0.3}   # optional, torque car only: the road

    The ``surface:`` section (irs_vehicle_sim.surface.SurfaceSpec: ``uniform`` mu, a ``patch`` in
    x, ``split`` left/right, a ``step`` in time) becomes the rig's ``surface.*`` parameters; it
    needs ``plant: two_track`` in the rig's ``params`` and no ``surface.*`` parameter there as
    well.
    """

    name: str
    description: str
    clock: str
    duration: float
    nodes: list
    record_topics: list
    path: Path | None = None
    text: str = ''
    record_process: str | None = None    # the recorder runs composed in this process group
    devices: dict = field(default_factory=dict)   # name -> (package, executable, args)

    def node(self, package, executable):
        """The entry that runs ``package/executable``, or None."""
        return next((n for n in self.nodes if n.key == (package, executable)), None)

    def rig(self):
        """The rig's entry (``vehicle_sim`` or ``rig_hardware``), or None."""
        return next((n for n in self.nodes if n.key in RIG_KEYS), None)

    def composed(self, process: str = 'graph') -> 'Experiment':
        """A copy with every node, and the recorder, in the one process group ``process``.

        One ``container`` process runs the whole graph on one executor, with the in-process
        handover between its nodes: 5-7x faster in lock-step on this 2-core machine than one
        process per node (README, measured figures). The nodes stay separate ROS nodes on
        topics; only the file's ``process:`` choices are replaced (the nodes are copies).
        """
        return replace(self, nodes=[replace(n, process=process) for n in deepcopy(self.nodes)],
                       record_process=process)

    def per_node(self) -> 'Experiment':
        """A copy with every node, and the recorder, in a process of its own (the nodes are
        copies).
        """
        return replace(self, nodes=[replace(n, process=None) for n in deepcopy(self.nodes)],
                       record_process=None)

    def places_nodes(self) -> bool:
        """Whether the file names a ``process:`` group for a node or the recorder."""
        return self.record_process is not None or any(n.process is not None for n in self.nodes)

    def deployed(self, deployment: str = 'default') -> 'Experiment':
        """The experiment as :data:`DEPLOYMENTS` ``deployment`` places it in processes.

        ``default``: a lock-step experiment whose file places no node runs :meth:`composed`,
        since lock-step bags are the same to the bit in either deployment and the composed one
        runs several times faster; every other file as it places its nodes. Real-time files run
        as written: the deployment is part of what a real-time run measures (the rig's deadline
        misses), and no two real-time bags are the same, so the runner cannot prove that one
        deployment stands for the other. ``composed``: :meth:`composed`; ``process_per_node``:
        :meth:`per_node`.
        """
        if deployment == 'composed':
            return self.composed()
        if deployment == 'process_per_node':
            return self.per_node()
        if deployment != 'default':
            raise ValueError(f'deployment: one of {", ".join(DEPLOYMENTS)} expected, '
                             f'got {deployment!r}')
        if self.clock == 'lockstep' and not self.places_nodes():
            return self.composed()
        return self

    def processes(self) -> dict:
        """``{node name: process group}`` (None: its own process), ``recorder`` included when
        the experiment records: the deployment, for the bag's metadata.
        """
        out = {n.name: n.process for n in self.nodes}
        if self.record_topics:
            out['recorder'] = self.record_process
        return out

    def deployment_line(self) -> str:
        """How the nodes sit in processes, for the runner's output: ``composed: every node and
        the recorder in one process 'graph'``, ``process per node (6 processes)``, or the groups.
        """
        groups, alone = {}, []
        for name, group in self.processes().items():
            if group is None:
                alone.append(name)
            else:
                groups.setdefault(group, []).append(name)
        if not groups:
            return f'process per node ({len(alone)} processes)'
        if len(groups) == 1 and not alone:
            group, members = next(iter(groups.items()))
            recorder = ' and the recorder' if 'recorder' in members else ''
            return f"composed: every node{recorder} in one process '{group}'"
        parts = [f"'{g}' ({', '.join(m)})" for g, m in groups.items()] + alone
        return f'{len(parts)} processes: ' + ', '.join(parts)

    def with_duration(self, duration: float) -> 'Experiment':
        """A copy that runs ``duration`` s instead (``experiment run --duration``); one
        :class:`ExperimentError` line unless it is a finite number of at least one rig step.
        """
        if isinstance(duration, bool) or not isinstance(duration, (int, float)) \
                or not math.isfinite(duration) or duration <= 0:
            raise ExperimentError(f'--duration: a finite number of seconds > 0 expected, '
                                  f'got {duration!r}')
        exp = replace(self, duration=float(duration))
        problems = _duration_problems(exp)
        if problems:
            raise ExperimentError(f'--duration: {problems[0][1]}')
        return exp


def new_run_dir(runs_dir, name: str) -> Path:
    """``<runs_dir>/<name>-<YYYYmmdd-HHMMSS>``, with ``-2``, ``-3`` ... if that exists
    (absolute; not created).
    """
    import datetime
    stamp = datetime.datetime.now().strftime('%Y%m%d-%H%M%S')
    base = Path(runs_dir).resolve()
    path, n = base / f'{name}-{stamp}', 1
    while path.exists():
        n += 1
        path = base / f'{name}-{stamp}-{n}'
    return path


def make_run_dir(path: Path) -> Path:
    """Create the run directory ``path`` (:func:`new_run_dir`) and return it; when another run
    created it meanwhile (two runs of one experiment started within a second), the next free
    ``<path>-2``, ``-3`` ... instead. ``mkdir`` decides, so two processes never share one.
    """
    candidate, n = Path(path), 1
    while True:
        try:
            candidate.mkdir(parents=True)
            return candidate
        except FileExistsError:
            n += 1
            candidate = Path(path).with_name(f'{Path(path).name}-{n}')


def experiments_dir() -> Path:
    """``share/irs_bringup/config/experiments`` of the installed package."""
    from ament_index_python.packages import get_package_share_directory
    return Path(get_package_share_directory('irs_bringup')) / 'config' / 'experiments'


def find_experiment(name_or_path: str) -> Path:
    """A path as given, or ``<name>.yaml`` among the installed experiments."""
    if not name_or_path:
        raise ExperimentError('no experiment named (an empty argument)')
    p = Path(name_or_path)
    if p.suffix in ('.yaml', '.yml') or p.exists():
        if p.is_dir():
            raise ExperimentError(f'experiment file {p} is a directory, not a file')
        if not p.is_file():
            raise ExperimentError(f'experiment file {p} does not exist')
        return p
    candidate = experiments_dir() / f'{name_or_path}.yaml'
    if not candidate.is_file():
        names = [x.stem for x in experiments_dir().glob('*.yaml')]
        raise ExperimentError(did_you_mean(name_or_path, names, 'experiment', 'experiment list'))
    return candidate


def resolve_params_file(ref: str) -> Path:
    """``pkg://<package>/<path>`` -> ``share/<package>/<path>``; other strings are paths."""
    from .experiment_schema import resolve_params_ref
    try:
        return resolve_params_ref(ref)
    except ValueError as exc:
        raise ExperimentError(str(exc)) from None


def load_experiment(name_or_path: str) -> Experiment:
    """Read and validate an experiment file (``experiment_schema``) before anything starts.

    Checked: the shape (keys, types: booleans are not numbers), the names (the experiment's is a
    plain file name, nodes' are ROS names), that packages, executables and parameter files exist,
    the nodes' parameters against their ROS-free tables, and that ``duration`` is at least one rig
    step. Any problem raises one :class:`ExperimentError` line: ``<file>: <key>: <what>``.
    """
    from .experiment_schema import SAFE_NAME, environment_problems, one_line, validate_document
    path = find_experiment(name_or_path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ExperimentError(f'{path}: cannot be read: {exc}') from None
    try:
        doc = yaml_io.safe_load(text)
    except yaml.YAMLError as exc:
        raise ExperimentError(f'{path}: not valid YAML: {" ".join(str(exc).split())}') from None
    model, problems = validate_document(doc)
    if model is None:
        raise ExperimentError(one_line(path, problems))
    name = model.name or path.stem
    if not SAFE_NAME.fullmatch(name):
        raise ExperimentError(
            one_line(
                path,
                [
                    (
                        'name',
                        f'the file name {name!r} is not a plain '
                        "name for the run directory: set 'name:'",
                    )
                ],
            )
        )
    problems = environment_problems(model)
    if problems:
        raise ExperimentError(one_line(path, problems))
    nodes = [NodeEntry(n, e.package, e.executable, list(e.params_files), dict(e.params),
                       dict(e.remaps), e.process) for n, e in model.nodes.items()]
    problems = _apply_surface(model.surface, nodes)
    if problems:
        raise ExperimentError(one_line(path, problems))
    exp = Experiment(name, model.description, model.clock, float(model.duration), nodes,
                     list(model.record.topics), path, text, model.record.process,
                     {n: (d.package, d.executable, list(d.args))
                      for n, d in model.devices.items()})
    problems = _parameter_problems(exp) or _duration_problems(exp) or _lockstep_problems(exp)
    if problems:
        raise ExperimentError(one_line(path, problems))
    return exp


def _apply_surface(surface, nodes) -> list:
    """Give the ``surface:`` section to the rig as its ``surface.<key>`` parameters.

    The section (already checked by ``SurfaceSpec``) needs the torque car: a ``vehicle_sim``
    node whose ``params`` set ``plant: two_track`` and no ``surface.*`` parameter of their own
    (one place only). Returns ``[(key path, message)]`` of what is wrong.
    """
    if surface is None:
        return []
    rigs = [n for n in nodes if (n.package, n.executable) == RIG_KEY]
    if not rigs:
        return [('surface', 'needs a vehicle_sim node (irs_vehicle_sim) to drive on it')]
    rig = rigs[0]
    if rig.params.get('plant') != 'two_track':
        return [('surface', f'only the torque car has tyres: set nodes.{rig.name}.params.plant: '
                            f"two_track (got {rig.params.get('plant', 'the default')!r})")]
    twice = sorted(k for k in rig.params if k.startswith('surface.'))
    if twice:
        return [('surface', f'given here and as nodes.{rig.name}.params {twice}: keep one')]
    rig.params.update({f'surface.{k}': v for k, v in surface.items()})
    return []


def _parameter_problems(exp: Experiment) -> list:
    """``[(key path, message)]`` of node parameters their ROS-free tables refuse."""
    from irs_common.params import check_values

    from .experiment_schema import RCLPY_PARAMETERS, parameter_table
    problems = []
    for entry in exp.nodes:
        table, complete = parameter_table(entry.key)
        if table is None:
            continue
        values = {k: v for k, v in node_parameters(entry).items() if k not in RCLPY_PARAMETERS
                  and v not in ('{free_port}',)}     # placeholder: the runner's free port
        for pname, message in check_values(table, values, unknown=complete).items():
            if pname in entry.params:
                where = f'nodes.{entry.name}.params.{pname}'
            else:
                files = [i for i, ref in enumerate(entry.params_files)
                         if pname in node_parameters(NodeEntry(entry.name, entry.package,
                                                               entry.executable, [ref]))]
                where = f'nodes.{entry.name}.params_files[{files[-1] if files else 0}]'
            problems.append((where, message))
    return problems


#: The topic each of the rig's ``lockstep_inputs`` takes its commands on (its subscriptions).
LOCKSTEP_INPUT_TOPICS = {'steering': 'steering/command', 'drive': 'treadmill/drive',
                         'driver': 'driver/command', 'wheels': 'wheels/torque_command'}


def _lockstep_problems(exp: Experiment) -> list:
    """A lock-step run waits, each step, for every input in the rig's ``lockstep_inputs`` and,
    with ``reference_sync``, the lateral controller for its reference: a topic of these that no
    node of the experiment publishes would stop the run at t = 0. ``[(key path, message)]``.
    """
    if exp.clock != 'lockstep':
        return []
    from irs_common.params import parameter_table
    published = {absolute(e.remaps.get(t, t)) for e in exp.nodes for t in node_topics(e)['pub']}
    waits = []        # (key path, name, topic)
    rig = exp.rig()
    if rig is not None:
        inputs = node_parameters(rig).get('lockstep_inputs')
        if inputs is None:
            inputs = next((p.default for p in parameter_table(*rig.key) or []
                           if p.name == 'lockstep_inputs'), [])
        for name in inputs:
            if name in LOCKSTEP_INPUT_TOPICS:
                waits.append((f'nodes.{rig.name}.params.lockstep_inputs', repr(name),
                              LOCKSTEP_INPUT_TOPICS[name], rig))
    for e in exp.nodes:
        if e.key == ('irs_control', 'lateral_controller') and \
                node_parameters(e).get('reference_sync') is True:
            waits.append((f'nodes.{e.name}.params.reference_sync', 'reference_sync',
                          'lateral/reference', e))
    problems = []
    for key, what, topic, entry in waits:
        topic = absolute(entry.remaps.get(topic, topic))
        if topic not in published:
            problems.append((key, f'{what} waits each step for {topic}, which no node of the '
                                  'experiment publishes (the run would not get past t = 0)'))
    return problems


def _duration_problems(exp: Experiment) -> list:
    """The run must be at least one rig step: 0 steps would mean 'run forever' on the rig."""
    rig = exp.rig()
    dt = float(node_parameters(rig).get('dt', 0.001)) if rig is not None else 0.001
    if exp.duration < dt and not math.isclose(exp.duration, dt, rel_tol=1e-9):
        return [('duration', f'{exp.duration!r} s is shorter than one rig step (dt = {dt} s): '
                             'at least one step is needed')]
    return []


def node_parameters(entry: NodeEntry) -> dict:
    """The flat parameters the node will have: its params files in order, then ``params``."""
    from irs_common.params import flatten
    values = {}
    for ref in entry.params_files:
        doc = yaml_io.safe_load(resolve_params_file(ref).read_text()) or {}
        for node_name, section in doc.items():
            if node_name in (entry.name, '/**', '**') or node_name.lstrip('/') == entry.name:
                values.update(flatten((section or {}).get('ros__parameters', {})))
    values.update(entry.params)
    return values


def clock_overrides(exp: Experiment, entry: NodeEntry, dt: float,
                    expected: dict | None = None) -> dict:
    """Parameters the runner adds for the experiment's clock mode; ``expected``: the endpoints
    the lock-step rig waits for before its first step (default :func:`expected_endpoints`).
    """
    if entry.key in RIG_KEYS:
        if exp.clock == 'lockstep':
            return {'clock_mode': 'lockstep', 'autostart': False,
                    'start_subscribers': start_subscribers(exp, entry, expected),
                    'max_steps': int(round(exp.duration / dt))}
        return {'clock_mode': 'realtime', 'autostart': False,
                'max_steps': int(round(exp.duration / dt))}
    if exp.clock != 'lockstep':
        return {}
    from .experiment_schema import parameter_table
    table, _complete = parameter_table(entry.key)
    if table is not None and any(p.name == 'start_subscribers' for p in table):
        return {'use_sim_time': True,
                'start_subscribers': start_subscribers(exp, entry, expected)}
    return {'use_sim_time': True}


def start_subscribers(exp: Experiment, entry: NodeEntry, expected: dict | None = None) -> str:
    """``'/topic=count,...'``: the subscriptions each topic ``entry`` publishes has in the run
    (``expected``, default :func:`expected_endpoints`), which the node waits for before its first
    step (:mod:`irs_common.start_gate`).
    """
    expected = expected_endpoints(exp) if expected is None else expected
    # a rig names its topics as it publishes them (its start_subscribers are not remapped)
    own = {absolute(t if entry.key in RIG_KEYS else entry.remaps.get(t, t))
           for t in node_topics(entry)['pub']}
    return ','.join(f'{t}={subs}' for t, (_pubs, subs) in expected.items() if t in own)


def absolute(topic: str) -> str:
    """Topic name as the graph reports it (nodes run in the root namespace)."""
    return topic if topic.startswith('/') else '/' + topic


def expected_endpoints(exp: Experiment) -> dict:
    """``{topic: (publishers, subscribers)}`` the graph must show before the run starts."""
    counts = {}
    for entry in exp.nodes:
        io = node_topics(entry)
        for kind, idx in (('pub', 0), ('sub', 1)):
            for topic in io[kind]:
                topic = absolute(entry.remaps.get(topic, topic))
                c = counts.setdefault(topic, [0, 0])
                c[idx] += 1
    for topic in exp.record_topics:
        counts.setdefault(absolute(topic), [0, 0])[1] += 1
    if exp.clock == 'lockstep' and '/clock' in counts:
        # every node but the rig runs on sim time: it subscribes /clock once (its TimeSource, which
        # the ticker of the reference generator and the driver rides on)
        counts['/clock'][1] += sum(1 for e in exp.nodes if e.key not in RIG_KEYS)
    else:
        counts.pop('/clock', None)  # only the lock-step rig publishes /clock
    # A topic nobody publishes (e.g. driver/command without a driver node) is not waited for.
    return {t: tuple(c) for t, c in counts.items() if c[0] > 0 and c[1] > 0}
