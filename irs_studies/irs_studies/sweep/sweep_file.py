"""Sweep files: a scenario, the axes over it, the metrics and the plots (pydantic; no rclpy).

A sweep file (YAML, ``config/sweeps/``) names a scenario (an experiment file, run offline), the
overrides every point shares (``fixed``), the axes whose Cartesian product is the set of points
(categorical ``cases``; numeric ``values``, ``range``, ``log_range``; Monte Carlo ``normal``,
``uniform``, one draw per seed), the seeds, the metrics and the plots. Parameter paths are
``<node>.<flat parameter name>``. Every point builds its controller from its own parameters, so
an axis that sets a design parameter redesigns the controller at each point. It exists so that a
design study is one reviewed file, validated before anything runs: :func:`load_sweep` raises
:class:`SweepError` with one line naming the file, the key and what is wrong. An annotated
example: :class:`SweepModel`; the format in short: docs/sweeps.md.
"""
from __future__ import annotations

from pathlib import Path
import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, \
    model_validator
import yaml

from irs_common import yaml_io
from irs_common.cli import InputError, did_you_mean

#: Nodes a parameter path may name, and the LoopConfig field each maps to.
NODES = {'rig': 'rig', 'estimator': 'estimator', 'controller': 'controller',
         'reference': 'reference', 'regulator': 'regulator', 'driver': 'driver'}
SAFE_NAME = re.compile(r'[A-Za-z0-9][A-Za-z0-9_-]{0,99}')


class SweepError(InputError):
    """The sweep file is missing, unreadable or inconsistent (message: one line)."""


def _path(value: str) -> str:
    node, dot, name = value.partition('.')
    if not dot or node not in NODES or not name:
        raise ValueError(f"parameter path {value!r}: expected <node>.<parameter> with node one "
                         f"of {', '.join(NODES)}")
    return value


class _Strict(BaseModel):
    model_config = ConfigDict(extra='forbid', frozen=True)


class RangeModel(_Strict):
    """``num`` values from ``start`` to ``stop`` inclusive."""

    start: float = Field(allow_inf_nan=False)
    stop: float = Field(allow_inf_nan=False)
    num: int = Field(ge=1, le=10000)


class NormalModel(_Strict):
    """A Monte Carlo axis drawn from a normal distribution."""

    mean: float = Field(allow_inf_nan=False)
    std: float = Field(ge=0.0, allow_inf_nan=False)


class UniformModel(_Strict):
    """A Monte Carlo axis drawn uniformly from [low, high)."""

    low: float = Field(allow_inf_nan=False)
    high: float = Field(allow_inf_nan=False)


class AxisModel(_Strict):
    """One axis: exactly one of values / range / log_range / cases / normal / uniform."""

    name: str
    values: list[float] | None = None
    range: RangeModel | None = None
    log_range: RangeModel | None = None
    cases: dict[str, dict[str, Any]] | None = None
    normal: NormalModel | None = None
    uniform: UniformModel | None = None
    set: dict[str, float] = {}
    unit: str = ''             # the axis's unit, for tables and plots (e.g. Hz, m/s)

    @field_validator('name')
    @classmethod
    def _name(cls, value):
        if not re.fullmatch(r'[A-Za-z_][A-Za-z0-9_]{0,63}', value):
            raise ValueError(f'{value!r}: an axis name is a plain identifier (it names a column)')
        if value in ('seed', 'point', 'error'):
            raise ValueError(f'{value!r} is reserved (a results column)')
        return value

    @field_validator('set')
    @classmethod
    def _set(cls, value):
        for key, factor in value.items():
            _path(key)
            if factor != factor or factor in (float('inf'), float('-inf')):
                raise ValueError(f'{key}: the factor must be finite')
        return value

    @field_validator('cases')
    @classmethod
    def _cases(cls, value):
        if value is not None:
            if not value:
                raise ValueError('at least one case expected')
            for case in value.values():
                for key in case:
                    _path(key)
        return value

    @field_validator('log_range')
    @classmethod
    def _log(cls, value):
        if value is not None and not (value.start > 0 and value.stop > 0):
            raise ValueError('a log range needs start > 0 and stop > 0')
        return value

    @field_validator('values')
    @classmethod
    def _values(cls, value):
        if value is not None and not value:
            raise ValueError('at least one value expected')
        return value

    @model_validator(mode='after')
    def _one_kind(self):
        kinds = [k for k in ('values', 'range', 'log_range', 'cases', 'normal', 'uniform')
                 if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError(f"axis '{self.name}': exactly one of values, range, log_range, "
                             f'cases, normal, uniform expected, got {kinds or "none"}')
        if kinds[0] != 'cases' and not self.set:
            raise ValueError(f"axis '{self.name}': 'set' must name at least one parameter "
                             '(<node>.<parameter>: factor)')
        if kinds[0] == 'cases' and self.set:
            raise ValueError(f"axis '{self.name}': a categorical axis sets parameters in its "
                             "cases, not in 'set'")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in ('values', 'range', 'log_range', 'cases', 'normal', 'uniform')
                    if getattr(self, k) is not None)


class PlotModel(_Strict):
    """A heat map of ``metric`` over ``x`` and ``y`` (mean over seeds), one panel per ``facet``
    value; ``boundary``: the same with the contour where the metric crosses ``threshold``.
    """

    kind: Literal['heatmap', 'boundary']
    x: str
    y: str
    metric: str
    facet: str | None = None
    threshold: float | None = None
    log: bool = False          # colour scale log10 (heat map)
    vmax: float | None = None  # clip the colour scale at this value (heat map)
    file: str | None = None    # PNG name; default sweep_<name>_<metric>.png

    @field_validator('file')
    @classmethod
    def _file(cls, value):
        """A plain file name: the PNG goes into the results directory, nowhere else."""
        if value is not None and not re.fullmatch(r'[A-Za-z0-9][A-Za-z0-9_.-]{0,99}\.png', value):
            raise ValueError(f'{value!r}: a plain PNG file name expected (letters, digits, _ - .; '
                             'no folder: the plots go into the results directory)')
        return value


class SweepModel(_Strict):
    """The whole sweep file.

    A sweep file (YAML, see ``config/sweeps/``)::

        name: actuator_speed                  # plain name: the results directory's
        description: one line
        scenario: figure10_mrc_with_actuator  # an experiment file (name or path), run OFFLINE
        duration: 5.0                         # [s] optional: overrides the experiment's duration
        fixed:                                # overrides of every point: <node>.<parameter>: value
          rig.plant: bicycle
        axes:                                 # the Cartesian product of these is the set of points
          - name: design                      # categorical: each value names a set of overrides
            cases:
              mrc_with_actuator: {controller.mode: mrc, controller.include_actuator: true}
              pi: {controller.mode: pi}
          - name: actuator_hz                 # numeric: values, range (linear) or log_range
            unit: Hz                          # optional, for tables and plots
            log_range: {start: 1.0, stop: 20.0, num: 6}
            set:                              # parameter -> factor: parameter = factor * value
              rig.actuator_front.lag_hz: 1.0
              controller.actuator_pole: 6.283185307179586   # redesign at each point (2 pi f)
          - name: gain_factor                 # Monte Carlo: one draw per seed (see seeds)
            normal: {mean: 1.0, std: 0.1}
            set: {rig.identified.gain: 12.5308}
        seeds: 3                              # n -> seeds 0..n-1, or a list; rig.seed = seed
        metrics: [ise_norm, overshoot_percent, stable, gain_margin_db, off_belt]
        plots:
          - {kind: heatmap, x: speed, y: actuator_hz, metric: ise_norm, facet: design, log: true}
          - {kind: boundary, x: speed, y: actuator_hz, metric: stable, threshold: 0.5,
             facet: design}
    """

    name: str
    description: str = ''
    scenario: str = Field(min_length=1)
    duration: float | None = Field(default=None, gt=0.0, allow_inf_nan=False)
    fixed: dict[str, Any] = {}
    axes: list[AxisModel] = Field(min_length=1)
    seeds: int | list[int] = 1
    metrics: list[str] = Field(min_length=1)
    plots: list[PlotModel] = []

    @field_validator('name')
    @classmethod
    def _name(cls, value):
        if not SAFE_NAME.fullmatch(value):
            raise ValueError(f'{value!r}: a plain name expected (letters, digits, _ and -)')
        return value

    @field_validator('fixed')
    @classmethod
    def _fixed(cls, value):
        for key in value:
            _path(key)
        return value

    @field_validator('seeds', mode='before')
    @classmethod
    def _seeds_type(cls, value):
        if isinstance(value, bool) or (isinstance(value, list) and any(
                isinstance(s, bool) or not isinstance(s, int) for s in value)):
            raise ValueError('a count or a list of integer seeds expected')
        return value

    @field_validator('seeds')
    @classmethod
    def _seeds(cls, value):
        if isinstance(value, int) and not 1 <= value <= 100000:
            raise ValueError('a seed count from 1 to 100000 expected')
        if isinstance(value, list) and (not value or any(s < 0 for s in value)
                                        or len(set(value)) != len(value)):
            raise ValueError('a non-empty list of distinct non-negative seeds expected')
        return value

    @model_validator(mode='after')
    def _consistent(self):
        from .metrics import METRICS
        names = [a.name for a in self.axes]
        if len(set(names)) != len(names):
            raise ValueError(f'axis names must be distinct, got {names}')
        unknown = [m for m in self.metrics if m not in METRICS]
        if unknown:
            raise ValueError(f'unknown metric(s) {unknown}; known: {", ".join(METRICS)}')
        for i, p in enumerate(self.plots):
            for key in ('x', 'y', 'facet'):
                v = getattr(p, key)
                if v is not None and v not in names + ['seed']:
                    raise ValueError(f'plots[{i}].{key}: {v!r} is not an axis ({names})')
            if p.metric not in self.metrics:
                raise ValueError(f'plots[{i}].metric: {p.metric!r} is not among the metrics')
            if p.kind == 'boundary' and p.threshold is None:
                raise ValueError(f'plots[{i}]: a boundary needs a threshold')
        return self

    @property
    def seed_list(self) -> list[int]:
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)


def sweeps_dir() -> Path:
    """``share/irs_studies/config/sweeps`` of the installed package."""
    from ament_index_python.packages import get_package_share_directory
    return Path(get_package_share_directory('irs_studies')) / 'config' / 'sweeps'


def find_sweep(name_or_path: str) -> Path:
    """A path as given, or ``<name>.yaml`` among the installed sweeps."""
    p = Path(name_or_path)
    if p.suffix in ('.yaml', '.yml') or p.exists():
        if not p.is_file():
            raise SweepError(f'sweep file {p} does not exist')
        return p
    try:
        candidate = sweeps_dir() / f'{name_or_path}.yaml'
    except Exception:  # noqa: BLE001 - no ament index: only paths work
        raise SweepError(f"sweep file '{name_or_path}' does not exist") from None
    if not candidate.is_file():
        names = [x.stem for x in candidate.parent.glob('*.yaml')]
        raise SweepError(did_you_mean(name_or_path, names, 'sweep', 'sweep list'))
    return candidate


def _where(loc) -> str:
    return '.'.join(str(x) for x in loc) or '(top level)'


def load_sweep(name_or_path: str) -> tuple[SweepModel, Path]:
    """Read and validate a sweep file; :class:`SweepError` (one line) on any problem."""
    path = find_sweep(name_or_path)
    try:
        doc = yaml_io.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepError(f'{path}: cannot be read: {exc}') from None
    except yaml.YAMLError as exc:
        raise SweepError(f'{path}: not valid YAML: {" ".join(str(exc).split())}') from None
    if not isinstance(doc, dict):
        raise SweepError(f'{path}: a mapping with name, scenario, axes and metrics expected')
    try:
        model = SweepModel.model_validate(doc)
    except ValidationError as exc:
        err = exc.errors()[0]
        msg = err['msg'].removeprefix('Value error, ')
        more = f' (and {len(exc.errors()) - 1} more)' if len(exc.errors()) > 1 else ''
        raise SweepError(f'{path}: {_where(err["loc"])}: {msg}{more}') from None
    return model, path
