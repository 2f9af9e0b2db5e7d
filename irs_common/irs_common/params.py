"""Parameter tables: one table per node declares, documents and validates its parameters.

Each :class:`Param` becomes a parameter declared with a ``ParameterDescriptor`` (description with
the unit, range, read-only flag). ``declare_table`` declares them all and returns a plain ``dict``
of values, which is what the ROS-free cores take. ``markdown_table`` renders the same table for
the docs, so the docs cannot drift from the code.

Parameters tell the truth: read-only unless a parameter is marked ``writable`` (and then the
node must pass a handler that applies it); every value, at start-up and on change, is validated
(type, range, finiteness, the parameter's own ``validator``) and a refused one is named in one
sentence; integers are taken as doubles where a double is expected; parameter files are checked
before the node spins; override names that match no parameter are reported. The rules in
detail: :func:`declare_table`.
"""
from dataclasses import dataclass, replace
import difflib
import math
import sys
from typing import Callable

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)

#: Relative tolerance at range edges, as rclpy's own range check (``Node.PARAM_REL_TOL``).
EDGE_REL_TOL = 1e-6

#: Overrides that are not the node's parameters yet are not unknown (declared later by rclpy).
_NOT_UNKNOWN_PREFIXES = ('qos_overrides.',)


@dataclass(frozen=True)
class Param:
    """One node parameter.

    ``unit`` is required ('1' for dimensionless, '-' for names and flags) and is shown in the
    description as ``[unit]``. ``low``/``high`` give an inclusive range for numbers (for arrays:
    of every element). ``writable`` parameters may be set while the node runs (the node's
    ``on_change`` handler applies them); all others are read-only. ``validator(value)`` returns
    ``None`` for a good value or a string saying what is wrong (or raises ``ValueError``); it is
    applied at start-up and to every change. Arrays must be non-empty unless ``allow_empty``.
    ``node_only`` parameters belong to the node (clock mode, frames, decimation, timeouts), not
    to its core: :func:`core_values` leaves them out, so the offline twin of the graph builds
    its cores from the same table as the nodes. ``realtime_default`` (when not ``None``) replaces
    ``default`` in a node that runs in real time (:func:`declare_table`); the description says it.
    """

    name: str
    default: object
    description: str
    unit: str
    low: float | None = None
    high: float | None = None
    read_only: bool | None = None     # deprecated spelling; normalised to ``not writable``
    writable: bool = False
    validator: Callable[[object], str | None] | None = None
    allow_empty: bool = False
    node_only: bool = False           # the node's own (clock, topics, rates): not the core's
    realtime_default: object = None   # the default in real time (message budget); None: default

    def __post_init__(self):
        writable = self.writable
        if self.read_only is not None:
            if self.read_only and self.writable:
                raise ValueError(f'parameter {self.name}: read_only=True and writable=True')
            writable = writable or not self.read_only
        object.__setattr__(self, 'writable', bool(writable))
        object.__setattr__(self, 'read_only', not writable)

    def text(self) -> str:
        """The description, with the real-time default when the parameter has one."""
        if self.realtime_default is None:
            return self.description
        return f'{self.description}; real time: {self.realtime_default!r} by default'

    def descriptor(self) -> ParameterDescriptor:
        desc = ParameterDescriptor(description=f'{self.text()} [{self.unit}]',
                                   read_only=self.read_only)
        if self.low is not None or self.high is not None:
            low = -math.inf if self.low is None else self.low
            high = math.inf if self.high is None else self.high
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                desc.integer_range = [IntegerRange(from_value=int(max(low, -2**62)),
                                                   to_value=int(min(high, 2**62)), step=0)]
            elif isinstance(self.default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(low),
                                                                to_value=float(high), step=0.0)]
        return desc

    # ------------------------------------------------------------------ validation (no rclpy)
    @property
    def kind(self) -> str:
        """'bool', 'int', 'double', 'string', or one of those + '[]' for arrays."""
        return _kind(self.default)

    def expected(self) -> str:
        """What a value must be, in words (used in every error message)."""
        kind = self.kind
        rng = self._range_text()
        if kind.endswith('[]'):
            elem = _KIND_WORDS[kind[:-2]][1]
            empty = '' if self.allow_empty else 'non-empty '
            return f'a {empty}array of {elem}' + (f' in {rng}' if rng else '')
        return _KIND_WORDS[kind][0] + (f' in {rng}' if rng else '')

    def _range_text(self) -> str:
        if self.low is None and self.high is None:
            return ''
        return f'[{self.low}, {self.high}]'

    def coerce(self, value):
        """``value`` as this parameter's type (ints become doubles); ``ValueError`` if not valid.

        The message names the parameter, the value and what was expected.
        """
        kind = self.kind
        try:
            if kind.endswith('[]'):
                if value is None or (isinstance(value, (list, tuple)) and not value):
                    if not self.allow_empty:
                        raise _Bad('an empty array')
                    return []
                if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
                    raise _Bad()
                out = [self._scalar(kind[:-2], v) for v in value]
            else:
                out = self._scalar(kind, value)
        except _Bad as bad:
            got = bad.what or f'{value!r} ({_type_word(value)})'
            raise ValueError(f"parameter '{self.name}': got {got}, expected {self.expected()}") \
                from None
        if self.validator is not None:
            try:
                reason = self.validator(out)
            except ValueError as exc:
                reason = str(exc) or 'refused by its validator'
            if reason:
                raise ValueError(f"parameter '{self.name}': {out!r} refused: {reason}")
        return out

    def _scalar(self, kind, v):
        if kind == 'bool':
            if not isinstance(v, bool):
                raise _Bad()
            return v
        if kind == 'string':
            if not isinstance(v, str):
                raise _Bad()
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise _Bad()
        if kind == 'int':
            if not isinstance(v, int):
                raise _Bad()
        else:
            v = float(v)
            if not math.isfinite(v):
                raise _Bad(f'{v!r} (not a finite number)')
        if not _in_range(v, self.low, self.high):
            raise _Bad(f'{v!r} (out of range)')
        return v


class _Bad(Exception):
    def __init__(self, what=''):
        super().__init__(what)
        self.what = what


_KIND_WORDS = {'bool': ('a boolean (true/false)', 'booleans'),
               'int': ('an integer', 'integers'),
               'double': ('a finite double', 'finite doubles'),
               'string': ('a string', 'strings')}


def _kind(default) -> str:
    if isinstance(default, bool):
        return 'bool'
    if isinstance(default, int):
        return 'int'
    if isinstance(default, float):
        return 'double'
    if isinstance(default, str):
        return 'string'
    if isinstance(default, (list, tuple)) and default:
        elem = _kind(default[0])
        if not elem.endswith('[]'):
            if elem == 'int' and any(isinstance(x, float) for x in default):
                elem = 'double'
            return elem + '[]'
    raise ValueError(f'cannot tell the parameter type of the default {default!r}: use a bool, '
                     'int, float, str or a non-empty list of one of those')


def _type_word(value) -> str:
    if value is None:
        return 'no value'
    if isinstance(value, bool):
        return 'boolean'
    if isinstance(value, int):
        return 'integer'
    if isinstance(value, float):
        return 'double'
    if isinstance(value, str):
        return 'string'
    if isinstance(value, (list, tuple)) or hasattr(value, '__iter__'):
        return 'array of ' + (_type_word(value[0]) + 's' if len(value) else 'nothing')
    return type(value).__name__


def _in_range(v, low, high) -> bool:
    if low is not None and v < low and not math.isclose(v, low, rel_tol=EDGE_REL_TOL):
        return False
    if high is not None and v > high and not math.isclose(v, high, rel_tol=EDGE_REL_TOL):
        return False
    return True


def check_values(table, values: dict, unknown: bool = True) -> dict:
    """``{name: message}`` of every problem of ``values`` against ``table`` (no rclpy).

    With ``unknown`` names that are not in the table are problems too. Used where parameters are
    checked without a node (experiment files, the offline closed loop).
    """
    by_name = {p.name: p for p in table}
    problems = {}
    for name, value in values.items():
        p = by_name.get(name)
        if p is None:
            if unknown:
                problems[name] = f"'{name}' is not a parameter" + _did_you_mean(name, by_name)
            continue
        try:
            p.coerce(value)
        except ValueError as exc:
            problems[name] = str(exc)
    return problems


def _did_you_mean(name, names) -> str:
    close = difflib.get_close_matches(name, list(names), n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(close)}?)" if close else ''


# ------------------------------------------------------------------- parameter files (no rclpy)
def params_file_sections(path) -> dict:
    """``{section: flat parameters}`` of a ``--params-file``; ``ValueError`` (one line) unless it
    is YAML of ``<node name>: {ros__parameters: {...}}`` sections.
    """
    import yaml

    from . import yaml_io
    try:
        with open(path) as f:
            doc = yaml_io.safe_load(f) or {}
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ValueError(f"--params-file {path}: not readable YAML: {' '.join(str(exc).split())}"
                         ) from None
    if not isinstance(doc, dict) or not all(
            isinstance(sec, dict) and isinstance(sec.get('ros__parameters', {}), dict)
            for sec in doc.values()):
        raise ValueError(f'--params-file {path}: expected <node name>: '
                         '{ros__parameters: {...}} sections')
    return {str(k): flatten(v.get('ros__parameters') or {}) for k, v in doc.items()}


def section_matches(section: str, node_fqn: str) -> bool:
    """Whether a parameter file's section name applies to the node ``node_fqn`` (``/ns/name``),
    as rcl matches them: a relative name is under ``/``, ``*`` is one name token, ``**`` any
    number of them (``/**``: every node).
    """
    import re
    pattern = section if section.startswith('/') else '/' + section
    regex = ''
    for token in pattern.strip('/').split('/'):
        regex += {'**': r'(?:/[^/]+)*', '*': r'/[^/]+'}.get(token, '/' + re.escape(token))
    return re.fullmatch(regex, node_fqn) is not None


#: The ``--params-file`` files of the node being built (:func:`expect_params_files`), checked
#: by its first :func:`declare_table`, before the node does or says anything else.
_PENDING_FILES: list | None = None


def expect_params_files(files) -> None:
    """The next node built gets ``files`` (None: nothing to check): :func:`declare_table` checks
    them against its name (:func:`check_pending_params_files`); ``run_nodes`` sets them before
    it builds each node.
    """
    global _PENDING_FILES
    _PENDING_FILES = None if files is None else list(files)


def check_pending_params_files(node_fqn: str) -> None:
    """``ValueError`` naming the first of :func:`params_file_problems` of the files expected by
    :func:`expect_params_files` (and how many more), once: the expectation is then cleared.
    """
    global _PENDING_FILES
    files, _PENDING_FILES = _PENDING_FILES, None
    problems = params_file_problems(files, node_fqn) if files else []
    if problems:
        more = f' (and {len(problems) - 1} more)' if len(problems) > 1 else ''
        raise ValueError(problems[0] + more)


def params_file_problems(files, node_fqn: str) -> list:
    """What is wrong with the ``--params-file`` ``files`` (in order) given to node ``node_fqn``:
    a file none of whose sections applies to the node (a misspelt node name), and a parameter
    that a later file gives another type than an earlier one (rcl would keep one silently).
    Integers for doubles are no change of type (the tables take them).
    """
    problems, seen = [], {}      # name -> (kind, file)
    for path in files:
        sections = params_file_sections(path)
        applying = [k for k in sections if section_matches(k, node_fqn)]
        if sections and not applying:
            names = [k for k in sections if '*' not in k]
            close = difflib.get_close_matches(node_fqn.rsplit('/', 1)[-1],
                                              [n.rsplit('/', 1)[-1] for n in names], n=1)
            hint = f" (a misspelt '{node_fqn.rsplit('/', 1)[-1]}'?)" if close else ''
            problems.append(f'--params-file {path}: no section for node {node_fqn}: it has '
                            f'{", ".join(sections)}{hint}')
        for key in applying:
            for name, value in sections[key].items():
                kind = _value_kind(value)
                before = seen.get(name)
                if before is not None and not _same_kind(before[0], kind):
                    problems.append(f"parameter '{name}' of node {node_fqn}: {before[1]} gives "
                                    f'{_KIND_WORDS_SHORT.get(before[0], before[0])}, {path} '
                                    f'{_KIND_WORDS_SHORT.get(kind, kind)} (one parameter, one '
                                    'type)')
                seen[name] = (kind, path)
    return problems


_KIND_WORDS_SHORT = {'bool': 'a boolean', 'int': 'an integer', 'double': 'a double',
                     'string': 'a string', 'bool[]': 'a boolean array',
                     'int[]': 'an integer array', 'double[]': 'a double array',
                     'string[]': 'a string array', 'none': 'no value', '[]': 'an empty array'}


def _value_kind(value) -> str:
    if value is None:
        return 'none'
    if isinstance(value, (list, tuple)):
        if not value:
            return '[]'
        kinds = {_value_kind(v) for v in value}
        return (kinds.pop() if len(kinds) == 1 else 'mixed') + '[]'
    return _kind(value)


def _same_kind(a: str, b: str) -> bool:
    numbers = {'int', 'double'}
    if a == b or '[]' in (a, b) and a.endswith('[]') and b.endswith('[]'):
        return True
    if a in numbers and b in numbers:
        return True
    return a.endswith('[]') and b.endswith('[]') and {a[:-2], b[:-2]} <= numbers


def ros_args_params_files(args) -> tuple[list, str | None]:
    """``(params files, node name remap or None)`` from a command line's ``--ros-args`` parts."""
    files, name, inside = [], None, False
    args = list(args or [])
    for i, arg in enumerate(args):
        if arg == '--ros-args':
            inside = True
        elif arg == '--':
            inside = False
        elif inside and arg == '--params-file' and i + 1 < len(args):
            files.append(args[i + 1])
        elif inside and arg in ('-r', '--remap') and i + 1 < len(args) \
                and args[i + 1].startswith('__node:='):
            name = args[i + 1].split(':=', 1)[1]
    return files, name


# ---------------------------------------------------------------------------------- rclpy side
_DOUBLE_TYPES = {ParameterType.PARAMETER_DOUBLE: ParameterType.PARAMETER_INTEGER,
                 ParameterType.PARAMETER_DOUBLE_ARRAY: ParameterType.PARAMETER_INTEGER_ARRAY}
_ARRAY_TYPES = (ParameterType.PARAMETER_BYTE_ARRAY, ParameterType.PARAMETER_BOOL_ARRAY,
                ParameterType.PARAMETER_INTEGER_ARRAY, ParameterType.PARAMETER_DOUBLE_ARRAY,
                ParameterType.PARAMETER_STRING_ARRAY)


class ParameterGuard:
    """The node's parameter callbacks, one set per node (see :func:`declare_table`).

    rclpy concatenates what several ``pre_set`` callbacks return, so a node must have exactly
    one that passes every parameter through; this object is it, shared by all of the node's
    tables. It also holds one ``on_set`` (validation) and one ``post_set`` (apply) callback.
    """

    ATTRIBUTE = '_irs_parameter_guard'

    def __init__(self, node):
        self.node = node
        self.params = {}      # name -> Param (declared through declare_table)
        self.handlers = {}    # name -> on_change(name, value), writable parameters only
        self.values = {}      # name -> the dict declare_table returned for it (kept current)
        self.checks = {}      # name -> check(candidate values) of its table, if it has one
        node.add_pre_set_parameters_callback(self.pre_set)
        node.add_on_set_parameters_callback(self.on_set)
        node.add_post_set_parameters_callback(self.post_set)

    @classmethod
    def of(cls, node) -> 'ParameterGuard':
        guard = getattr(node, cls.ATTRIBUTE, None)
        if guard is None:
            guard = cls(node)
            setattr(node, cls.ATTRIBUTE, guard)
        return guard

    def pre_set(self, parameters):
        """Integers for double (array) parameters become doubles before rclpy's type check.

        A name the node has not declared is refused here, naming it and the closest declared
        names: rclpy 7.1.6 refuses it too, but its message lists no name
        (``_check_undeclared_parameters`` hands ``any()`` a generator, then lists what is
        left of it: ``Invalid access to undeclared parameter(s): []``).
        """
        undeclared = [p.name for p in parameters if not self.node.has_parameter(p.name)]
        if undeclared and not getattr(self.node, '_allow_undeclared_parameters', False):
            declared = self.node.list_parameters([], 0).names
            listed = ', '.join(name + _did_you_mean(name, declared) for name in undeclared)
            # rclpy's own exception, which its parameter service answers as a refusal (rclpy
            # is loaded: it calls this); not imported here, so that this module stays ROS-free
            raise sys.modules['rclpy.exceptions'].ParameterNotDeclaredException(listed)
        out = []
        for param in parameters:
            p = self.params.get(param.name)
            if p is None:
                pass
            elif (
                p.kind in ('double', 'double[]') and param.type_.value == _DOUBLE_TYPES[_ptype(p)]
            ):
                value = float(param.value) if p.kind == 'double' else \
                    [float(v) for v in param.value]
                param = type(param)(param.name, value=value)
            elif (
                p.kind.endswith('[]')
                and param.type_.value in _ARRAY_TYPES
                and not len(param.value)
            ):
                # [] has no element type: give it the parameter's, so on_set can say what is wrong
                param = _parameter(param, p, [])
            out.append(param)
        return out

    def on_set(self, parameters) -> SetParametersResult:
        """Validate changes of our parameters; refuse the whole set with the first reason."""
        for param in parameters:
            p = self.params.get(param.name)
            if p is None:
                continue      # not ours (use_sim_time, another mechanism's): not our business
            if p.read_only:
                return SetParametersResult(successful=False, reason=(
                    f"parameter '{p.name}' is read-only (set it at start-up)"))
            try:
                p.coerce(param.value)
            except ValueError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return self._check_tables(parameters)

    def _check_tables(self, parameters) -> SetParametersResult:
        """Each changed table's ``check`` on its values as they would be after the change."""
        done = set()
        for param in parameters:
            check = self.checks.get(param.name)
            if check is None or id(check) in done:
                continue
            done.add(id(check))
            candidate = dict(self.values[param.name])
            for other in parameters:
                if other.name in candidate and other.name in self.params:
                    candidate[other.name] = self.params[other.name].coerce(other.value)
            reason = check(candidate)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def post_set(self, parameters):
        """Hand every accepted change of a writable parameter to its node's handler."""
        for param in parameters:
            handler = self.handlers.get(param.name)
            if handler is None:
                continue
            value = self.params[param.name].coerce(param.value)
            self.values[param.name][param.name] = value
            try:
                handler(param.name, value)
            except Exception as exc:
                self.node.get_logger().error(
                    f"parameter '{param.name}' = {value!r} accepted but its handler failed: {exc}")
                raise


def _ptype(p: Param) -> int:
    return {'double': ParameterType.PARAMETER_DOUBLE,
            'double[]': ParameterType.PARAMETER_DOUBLE_ARRAY}[p.kind]


def runs_in_real_time(node, table) -> bool:
    """Whether ``node`` runs in real time: its table's ``clock_mode`` (as its params files and
    ``-p`` give it) is ``'realtime'`` (the rig); for a table without ``clock_mode``:
    ``use_sim_time`` is false (lock-step graphs run every other node on simulation time).

    Real time has its own defaults: :func:`declare_table` gives a parameter with a
    ``realtime_default`` that no params file or ``-p`` sets that value when the node runs in real
    time (its ``realtime`` argument; ``None``: this function). They are the real-time message
    budget (docs/architecture.md#message-budget), so a node started the plain ROS way fits a
    small machine; lock-step nodes and the offline twin keep ``default``.
    """
    clock = next((p for p in table if p.name == 'clock_mode'), None)
    if clock is not None:
        override = getattr(node, '_parameter_overrides', {}).get(clock.name)
        return (clock.default if override is None else override.value) == 'realtime'
    if not node.has_parameter('use_sim_time'):
        return True
    return not node.get_parameter('use_sim_time').value


def declare_table(node, table, on_change=None, *, strict: bool = False,
                  check_unknown: bool = True, check=None, realtime: bool | None = None) -> dict:
    """Declare every parameter of ``table`` on ``node``; return ``{name: value}``.

    ``on_change(name, value)`` is called after a change of a writable parameter was accepted
    (``value`` converted: a double for a double parameter, a list for arrays); it is required
    when the table has a writable parameter (``TypeError`` otherwise). Initial values (defaults,
    params files, ``-p``) are validated like changes; a bad one raises one ``ValueError``.
    Override names that are no declared parameter are logged as one warning
    (``strict``: ``ValueError``) unless ``check_unknown`` is false. ``check(values)`` (optional)
    judges the table as a whole (limits that depend on another parameter): it returns ``None``
    or a sentence; a sentence refuses a change (and, at start-up, raises ``ValueError``).

    Notes
    -----
    Parameters tell the truth:

    * **Read-only unless a parameter says otherwise.** ``Param(..., writable=True)`` is a parameter
      the node applies while running; every other parameter has a read-only descriptor and rclpy
      refuses to set it after start-up. (``read_only=True`` is accepted as an alias of the default;
      ``read_only=False`` means ``writable=True``.)
    * **A writable parameter needs a handler.** The node passes ``on_change(name, value)`` to
      :func:`declare_table`; declaring a writable parameter without one raises ``TypeError``::

          self.p = declare_table(self, TABLE, on_change=self._on_parameter)

          def _on_parameter(self, name, value):   # called after rclpy stored the accepted value
              if name == 'command_timeout':
                  self.timeout = value

      Before that call, the change is validated (one ``on_set`` callback per node): type, range,
      finiteness of doubles, non-empty arrays, and the parameter's own ``validator``; a refused
      change returns ``SetParametersResult(successful=False, reason=...)`` naming the parameter,
      the value and what was expected. The ``dict`` ``declare_table`` returned is kept current too.
    * **Integers are doubles where a double is expected.** ``-p x0:=0`` or ``x0: 0`` in a params
      file (an INTEGER) for a double parameter is taken as ``0.0``, likewise ``[1, 2]`` for a
      double array: at start-up the node's parameter overrides are converted before declaration, at
      run time a ``pre_set`` callback converts the request before rclpy's type check (rclpy 7.1
      checks the type against the descriptor before any ``on_set`` callback, so an ``on_set``
      callback cannot do it). ``ParameterDescriptor.dynamic_typing`` would also let integers in,
      but it drops rclpy's type check altogether (a string would then replace a double), so it is
      not used.
    * **Start-up errors are one ``ValueError``** naming the parameter, the value and what was
      expected (``run_node`` turns it into one line and exit code 2), also when a second params
      file gives a parameter another type.
    * **Parameter files are checked** first (:func:`params_file_problems` of the files
      ``run_nodes`` expects for the node, :func:`expect_params_files`), before the node does or
      logs anything: a ``--params-file`` with no section for the node (a misspelt node name) and
      a later file that gives a parameter another type are start-up errors; rcl drops both
      silently.
    * **Unknown names are reported.** Overrides (params files, ``-p``) naming no declared parameter
      are listed in one warning at the end of ``declare_table``, with the closest declared names;
      ``strict=True`` makes that an error. Warning by default, because a params file with a ``/**``
      section may legitimately carry parameters for other nodes. A node that declares several
      tables should pass them in one call (``declare_table(node, A + B)``), or
      ``check_unknown=False`` to all but the last call, so that names of a later table are not
      reported.
    """
    check_pending_params_files(node.get_fully_qualified_name())
    writable = [p.name for p in table if p.writable]
    if writable and on_change is None:
        raise TypeError(
            f'writable parameter(s) {writable} of node {node.get_name()!r} need an '
            'on_change(name, value) handler: declare_table(node, table, on_change=...)'
        )
    guard = ParameterGuard.of(node)
    overrides = getattr(node, '_parameter_overrides', {})
    if realtime is None:
        realtime = runs_in_real_time(node, table)
    values = {}
    for p in table:
        value = _declare_one(node, p, overrides, realtime)
        values[p.name] = list(value) if isinstance(value, tuple) else value
    if check is not None:
        reason = check(values)
        if reason:
            raise ValueError(f"node '{node.get_name()}': {reason}")
    for p in table:
        guard.params[p.name] = p
        guard.values[p.name] = values
        if p.writable:
            guard.handlers[p.name] = on_change
        if check is not None:
            guard.checks[p.name] = check
    if check_unknown:
        report_unknown_overrides(node, strict=strict)
    return values


def _declare_one(node, p: Param, overrides: dict, realtime: bool):
    """Declare ``p`` on ``node`` (its real-time default if ``realtime``), its override (params
    file, ``-p``) converted first; the value it takes. One ``ValueError`` for a bad default,
    override or type.
    """
    if p.default is None:
        raise ValueError(f'parameter {p.name}: a default is required to fix its type')
    default = p.default
    try:
        p.coerce(p.default)
        if p.realtime_default is not None:
            real_time = p.coerce(p.realtime_default)
            default = real_time if realtime else default
    except ValueError as exc:
        raise ValueError(f'default of {exc}') from None
    override = overrides.get(p.name)
    if override is not None:
        try:
            value = p.coerce(override.value)
        except ValueError as exc:
            raise ValueError(f"{exc} (node '{node.get_name()}', set by a params file or -p; "
                             'of several params files the last one wins)') from None
        overrides[p.name] = _parameter(override, p, value)   # e.g. 0 -> 0.0 for a double
    try:
        node.declare_parameter(p.name, default, p.descriptor())
    except Exception as exc:
        if type(exc).__module__ != 'rclpy.exceptions':
            raise
        raise ValueError(f"parameter '{p.name}' (node '{node.get_name()}'): {exc}; "
                         f'expected {p.expected()}') from None
    return node.get_parameter(p.name).value


def _parameter(override, p: Param, value):
    """A parameter object of the override's class (rclpy's ``Parameter``) holding ``value``."""
    cls = type(override)
    if isinstance(value, list) and not value:    # an empty array: its type cannot be inferred
        return cls(p.name, cls.Type.from_parameter_value(p.default), [])
    return cls(p.name, value=value)


def unknown_overrides(node) -> list:
    """Names given to ``node`` (params files, ``-p``) that it has not declared, sorted."""
    overrides = getattr(node, '_parameter_overrides', {})
    return sorted(name for name in overrides
                  if not node.has_parameter(name) and not name.startswith(_NOT_UNKNOWN_PREFIXES))


def report_unknown_overrides(node, strict: bool = False) -> list:
    """Warn about (``strict``: raise ``ValueError`` for) :func:`unknown_overrides`; return them."""
    unknown = unknown_overrides(node)
    if unknown:
        declared = node.list_parameters([], 0).names
        listed = ', '.join(name + _did_you_mean(name, declared) for name in unknown[:10])
        if len(unknown) > 10:
            listed += f' and {len(unknown) - 10} more'
        msg = f"unknown parameter(s) given to node '{node.get_name()}' (misspelt?): {listed}"
        if strict:
            raise ValueError(msg)
        node.get_logger().warning(msg + '; ignored')
    return unknown


def markdown_table(table) -> str:
    """The parameter table as Markdown (name, default, unit, range, writable, description)."""
    rows = ['| name | default | unit | range | writable | description |',
            '|---|---|---|---|---|---|']
    for p in table:
        rng = '' if p.low is None and p.high is None else f'[{p.low}, {p.high}]'
        rw = 'yes' if p.writable else ''
        rows.append(
            f'| `{p.name}` | `{p.default!r}` | {p.unit} | {rng} | {rw} | {p.text()} |'
        )
    return '\n'.join(rows)


def table_from_defaults(defaults: dict, meta: dict, read_only=(), writable=(),
                        validators=None) -> list:
    """A parameter table from ``{name: default}`` and ``{name: (unit, low, high, description)}``.

    Defaults come from the ROS-free core (its dataclasses), units and descriptions from ``meta``;
    a name missing from ``meta`` is an error, so no parameter goes undocumented. Parameters are
    read-only unless named in ``writable`` (``read_only`` is accepted for compatibility: those
    are read-only anyway); ``validators`` maps names to ``Param.validator`` functions.
    """
    missing = sorted(set(defaults) - set(meta))
    if missing:
        raise ValueError(f'no unit/description for parameter(s) {missing}')
    both = sorted(set(read_only) & set(writable))
    if both:
        raise ValueError(f'parameter(s) {both} both read-only and writable')
    validators = validators or {}
    table = []
    for name, default in defaults.items():
        unit, low, high, desc = meta[name]
        if isinstance(default, (list, tuple)):
            default = list(default)
        if isinstance(default, float):
            low = None if low is None else float(low)
            high = None if high is None else float(high)
        table.append(Param(name, default, desc, unit, low, high, writable=name in writable,
                           validator=validators.get(name)))
    return table


def node_only(params) -> list:
    """Copies of ``params`` marked ``node_only`` (a table's block of node parameters)."""
    return [replace(p, node_only=True) for p in params]


def core_values(table, values: dict, nested: bool = True) -> dict:
    """What a core takes from a node's parameters, nested by the dots of their names.

    The table's defaults, overridden by ``values`` (flat names: a node's declared values or an
    experiment's parameters), without the ``node_only`` parameters and names the table does
    not hold (rclpy's ``use_sim_time``); flat names if not ``nested``. The node and the offline
    twin both build their cores from this, so neither keeps a list of keys to strip.
    """
    core = {p.name: p.default for p in table if not p.node_only}
    core.update((k, v) for k, v in values.items() if k in core)
    return unflatten(core) if nested else core


def flatten(mapping: dict, prefix: str = '') -> dict:
    """``{'a': {'b': 1}}`` -> ``{'a.b': 1}`` (ROS parameter names of nested YAML)."""
    out = {}
    for key, value in mapping.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def unflatten(values: dict) -> dict:
    """``{'a.b': 1}`` -> ``{'a': {'b': 1}}``."""
    out = {}
    for name, value in values.items():
        node = out
        *parents, leaf = name.split('.')
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = list(value) if isinstance(value, tuple) else value
    return out


#: Entry-point group in which every package registers its nodes' parameter tables:
#: ``<executable> = <module>:<table or function returning it>`` (setup.cfg).
TABLE_GROUP = 'irs_parameters'


def registered_tables() -> dict:
    """``{(package, executable): table}`` of every installed node that registers its table in
    :data:`TABLE_GROUP`, so tools above the nodes (experiment files, the docs) find them without
    importing the packages by name.
    """
    from importlib.metadata import entry_points
    tables = {}
    for ep in entry_points(group=TABLE_GROUP):
        table = ep.load()
        tables[(ep.dist.name, ep.name)] = list(table() if callable(table) else table)
    return dict(sorted(tables.items()))


def parameter_table(package: str, executable: str):
    """The parameter table of ``package``'s ``executable``, or None if it registers none."""
    from importlib.metadata import entry_points
    for ep in entry_points(group=TABLE_GROUP, name=executable):
        if ep.dist.name == package:
            table = ep.load()
            return list(table() if callable(table) else table)
    return None
