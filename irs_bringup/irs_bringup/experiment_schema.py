"""The schema of experiment files (pydantic; no rclpy): shape first, then what the shape names.

:func:`validate_document` checks a parsed experiment YAML against :class:`ExperimentModel`
(strict: booleans are not numbers, strings are not lists, unknown keys are errors);
:func:`environment_problems` then checks what the file names exists: packages and executables in
the ament index (as ``ros2 run`` resolves them), parameter files. Every problem is a
``(key path, what is wrong)`` pair; :func:`one_line` makes the single line the ``experiment``
command prints.
"""
from pathlib import Path
import re
from typing import Annotated, Any, Literal

from pydantic import (AfterValidator, BaseModel, ConfigDict, Field, ValidationError,
                      field_validator)
import yaml

from irs_common import yaml_io

#: Experiment and process-group names: they become directory names (``runs/<name>-<time>``).
SAFE_NAME = re.compile(r'[A-Za-z0-9][A-Za-z0-9_-]{0,99}')
#: Node names (ROS: letters, digits, underscores; not starting with a digit).
NODE_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]{0,99}')
#: Parameters the client library declares on every node (not in the nodes' tables).
RCLPY_PARAMETERS = frozenset({'use_sim_time', 'start_type_description_service'})


def _safe_name(value, what):
    if value is not None and not SAFE_NAME.fullmatch(value):
        raise ValueError(f'{value!r} is not a plain name for {what}: use letters, digits, '
                         "'_' and '-' (no '/', '..', spaces; at most 100 characters)")
    return value


def _none_is_empty(value, empty):
    return empty if value is None else value


def _param_value(value):
    """A value a ROS parameter can take; a list of ints and floats becomes floats."""
    scalars = (bool, int, float, str)
    if isinstance(value, dict):
        raise ValueError('a nested mapping: give flat names (<name>.<key>: value)')
    if isinstance(value, list):
        if not value:
            raise ValueError('an empty list cannot be passed to a ROS node')
        if not all(isinstance(v, scalars) for v in value):
            raise ValueError(f'a list of booleans, numbers or strings expected, got {value!r}')
        kinds = {bool if isinstance(v, bool) else str if isinstance(v, str) else float
                 for v in value}
        if len(kinds) > 1:
            raise ValueError(f'all elements of a list must have one type, got {value!r}')
        if kinds == {float} and any(isinstance(v, float) for v in value):
            value = [float(v) for v in value]
        return value
    if value is None or not isinstance(value, scalars):
        raise ValueError('a boolean, number, string or list of one of those expected, '
                         f'got {value!r}')
    return value


ParamValue = Annotated[Any, AfterValidator(_param_value)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra='forbid', strict=True, frozen=True)


class NodeModel(_Strict):
    """One entry of ``nodes``: how to start the node, as ``ros2 run`` would."""

    package: str = Field(min_length=1)
    executable: str = Field(min_length=1)
    params_files: list[str] = []
    params: dict[str, ParamValue] = {}
    remaps: dict[str, str] = {}
    process: str | None = None      # nodes with the same process group run in one process

    @field_validator('params_files', 'params', 'remaps', mode='before')
    @classmethod
    def _empty(cls, value, info):
        return _none_is_empty(value, [] if info.field_name == 'params_files' else {})

    @field_validator('process')
    @classmethod
    def _process(cls, value):
        return _safe_name(value, 'a process group')


class DeviceModel(_Strict):
    """One entry of ``devices``: a non-ROS process (an emulated device) started before the
    nodes and stopped after them; ``{run_dir}`` and ``{free_port}`` in ``args`` (and in the
    nodes' string parameters) become the run's directory and a free TCP port on 127.0.0.1.
    """

    package: str = Field(min_length=1)
    executable: str = Field(min_length=1)
    args: list[str] = []


class RecordModel(_Strict):
    """The ``record:`` section: topics to record and the process the recorder joins."""

    topics: list[str] = []
    process: str | None = None        # compose the recorder into this node group's process

    @field_validator('process')
    @classmethod
    def _process(cls, value):
        return _safe_name(value, 'a process group')

    @field_validator('topics', mode='before')
    @classmethod
    def _empty(cls, value):
        return _none_is_empty(value, [])

    @field_validator('topics')
    @classmethod
    def _names(cls, value):
        bad = [t for t in value if not t.strip() or ' ' in t]
        if bad:
            raise ValueError(f'topic names without spaces expected, got {bad!r}')
        return value


class ExperimentModel(_Strict):
    """The whole experiment file (format: the docstring of ``irs_bringup.experiment``)."""

    name: str | None = None
    description: str = ''
    clock: Literal['lockstep', 'realtime'] = 'lockstep'
    duration: float = Field(gt=0.0, allow_inf_nan=False)   # strict: true is not 1 s
    nodes: dict[str, NodeModel] = Field(min_length=1)      # at least one node
    record: RecordModel = RecordModel()
    devices: dict[str, DeviceModel] = {}
    surface: dict[str, Any] | None = None                   # the torque car's road (see below)

    @field_validator('surface')
    @classmethod
    def _surface(cls, value):
        """The ``surface:`` section: a :class:`irs_vehicle_sim.surface.SurfaceSpec` mapping
        (``{kind: split, mu_left: 0.8, mu_right: 0.3}``), checked here, given to the rig as its
        ``surface.*`` parameters by :func:`irs_bringup.experiment.load_experiment`.
        """
        if value is None:
            return value
        from irs_vehicle_sim.surface import SurfaceSpec
        SurfaceSpec.from_dict(value)           # ValueError: one sentence naming what is wrong
        return value

    @field_validator('name')
    @classmethod
    def _name(cls, value):
        return _safe_name(value, 'an experiment (it names the run directory)')

    @field_validator('record', mode='before')
    @classmethod
    def _record(cls, value):
        return _none_is_empty(value, {})

    @field_validator('nodes')
    @classmethod
    def _node_names(cls, value):
        bad = [n for n in value if not NODE_NAME.fullmatch(n)]
        if bad:
            raise ValueError(f'node names must be ROS names (letters, digits, _; not starting '
                             f'with a digit), got {bad!r}')
        rigs = [n for n, e in value.items()
                if (e.package, e.executable) == ('irs_vehicle_sim', 'vehicle_sim')]
        if len(rigs) > 1:
            raise ValueError(f'more than one vehicle_sim: {rigs}')
        return value


_FIELDS = {(): ExperimentModel, ('nodes', '*'): NodeModel, ('record',): RecordModel,
           ('devices', '*'): DeviceModel}


def _where(loc) -> str:
    return '.'.join(str(part) for part in loc) or '(top level)'


def _short(value, limit=60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + '...'


def _message(err) -> tuple[str, str]:
    """``(key path, what is wrong)`` of one pydantic error, in this file's words."""
    loc, kind, msg = tuple(err['loc']), err['type'], err['msg']
    if kind == 'extra_forbidden':
        parent = loc[:-1]
        pattern = ('nodes', '*') if len(parent) == 2 and parent[0] == 'nodes' else parent
        model = _FIELDS.get(pattern)
        known = ', '.join(model.model_fields) if model else ''
        return _where(loc), 'unknown key' + (f' (expected one of: {known})' if known else '')
    if kind == 'missing':
        return _where(loc), 'required but missing'
    if kind == 'value_error':
        return _where(loc), msg.removeprefix('Value error, ')
    if kind == 'too_short':
        return _where(loc), f"at least one entry expected, got {_short(err.get('input'))}"
    if loc == ('duration',):
        what = {'greater_than': 'a number of seconds greater than 0',
                'finite_number': 'a finite number of seconds'}.get(kind, 'a number of seconds')
        return _where(loc), f"expected {what}, got {_short(err.get('input'))}"
    if msg.startswith('Input should be'):
        msg = 'expected' + msg[len('Input should be'):]
    msg = re.sub(r' or instance of \w+$', '', msg)
    return _where(loc), f"{msg}, got {_short(err.get('input'))}"


def validate_document(doc) -> tuple[ExperimentModel | None, list]:
    """The validated model, or None and ``[(key path, message)]``."""
    if doc is None:
        return None, [('(top level)', 'the file is empty: a mapping of keys expected')]
    if not isinstance(doc, dict):
        return None, [('(top level)', f'a mapping of keys expected, got {_short(doc)}')]
    try:
        return ExperimentModel.model_validate(doc), []
    except ValidationError as exc:
        return None, [_message(err) for err in exc.errors(include_url=False)]


def one_line(path, problems) -> str:
    """``<file>: <key>: <what>`` (more problems appended with '; ')."""
    shown = '; '.join(f'{key}: {what}' for key, what in problems[:3])
    more = f' (and {len(problems) - 3} more)' if len(problems) > 3 else ''
    return f'{path}: {shown}{more}'


# ------------------------------------------------------------------ what the file names
def resolve_params_ref(ref: str) -> Path:
    """``pkg://<package>/<path>`` -> ``share/<package>/<path>``; other strings are paths.

    ``ValueError`` (message says what) for an unknown package or a missing file.
    """
    if ref.startswith('pkg://'):
        from ament_index_python.packages import (PackageNotFoundError,
                                                 get_package_share_directory)
        package, _, rel = ref[len('pkg://'):].partition('/')
        if not package or not rel:
            raise ValueError(f"'{ref}': expected pkg://<package>/<path in its share directory>")
        try:
            path = Path(get_package_share_directory(package)) / rel
        except PackageNotFoundError:
            raise ValueError(f"'{ref}': package '{package}' is not in the ament index") from None
    else:
        path = Path(ref)
    if path.is_dir():
        raise ValueError(f"parameter file '{ref}' is a directory, not a file ({path})")
    if not path.is_file():
        raise ValueError(f"parameter file '{ref}' not found ({path})")
    return path


def params_file_sections(path: Path) -> dict:
    """The parsed parameter file; ``ValueError`` unless it is ``{node: {ros__parameters: {}}}``."""
    try:
        doc = yaml_io.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f'{path}: not readable YAML: {" ".join(str(exc).split())}') from None
    doc = doc or {}
    if not isinstance(doc, dict) or not all(
            isinstance(s, dict) and isinstance(s.get('ros__parameters', {}), dict)
            for s in doc.values()):
        raise ValueError(f'{path}: expected <node name>: {{ros__parameters: {{...}}}} sections')
    return doc


def environment_problems(model: ExperimentModel) -> list:
    """``[(key path, message)]``: unknown packages/executables, bad or missing parameter files."""
    from .executables import ExecutableNotFound, package_executables
    problems = []
    for name, entry in model.nodes.items():
        try:
            names = package_executables(entry.package)
        except ExecutableNotFound:
            problems.append((f'nodes.{name}.package',
                             f"package '{entry.package}' is not in the ament index"))
        else:
            if entry.executable not in names:
                problems.append((f'nodes.{name}.executable',
                                 f"no executable '{entry.executable}' in package "
                                 f"'{entry.package}' (it has: {', '.join(names) or 'none'})"))
        paths = []
        for i, ref in enumerate(entry.params_files):
            try:
                path = resolve_params_ref(ref)
                params_file_sections(path)
                paths.append(path)
            except ValueError as exc:
                problems.append((f'nodes.{name}.params_files[{i}]', str(exc)))
        if len(paths) == len(entry.params_files):
            # what the node would refuse at start: a file with no section for it (a misspelt
            # node name), a parameter two files give different types (nodes run under /)
            from irs_common.params import params_file_problems
            problems += [(f'nodes.{name}.params_files', p)
                         for p in params_file_problems(paths, f'/{name}')]
    return problems


def parameter_table(key):
    """``(table, complete)`` of a node executable (registered by its package, see
    :func:`irs_common.params.registered_tables`), or ``(None, False)`` if it registers none.
    A registered table is all of the node's parameters, so unknown names are errors.
    """
    from irs_common.params import parameter_table as registered
    table = registered(*key)
    return (table, True) if table is not None else (None, False)
