"""Parameter tables: one table per node declares, documents and validates its parameters.

Each :class:`Param` becomes a parameter declared with a ``ParameterDescriptor`` (description with
the unit, range, read-only flag). ``declare_table`` declares them all and returns a plain ``dict``
of values, which is what the ROS-free cores take. ``markdown_table`` renders the same table for
the docs, so the docs cannot drift from the code.
"""
from dataclasses import dataclass
import math

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor


@dataclass(frozen=True)
class Param:
    """One node parameter.

    ``unit`` is required ('1' for dimensionless, '-' for names and flags) and is shown in the
    description as ``[unit]``. ``low``/``high`` give an inclusive range for numbers.
    """

    name: str
    default: object
    description: str
    unit: str
    low: float | None = None
    high: float | None = None
    read_only: bool = False

    def descriptor(self) -> ParameterDescriptor:
        desc = ParameterDescriptor(description=f'{self.description} [{self.unit}]',
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


def declare_table(node, table) -> dict:
    """Declare every parameter of ``table`` on ``node``; return ``{name: value}``."""
    values = {}
    for p in table:
        if p.default is None:
            raise ValueError(f'parameter {p.name}: a default is required to fix its type')
        node.declare_parameter(p.name, p.default, p.descriptor())
        values[p.name] = node.get_parameter(p.name).value
    return values


def markdown_table(table) -> str:
    """The parameter table as Markdown (name, default, unit, range, description)."""
    rows = ['| name | default | unit | range | description |', '|---|---|---|---|---|']
    for p in table:
        rng = '' if p.low is None and p.high is None else f'[{p.low}, {p.high}]'
        ro = ' (read-only)' if p.read_only else ''
        rows.append(f'| `{p.name}` | `{p.default!r}` | {p.unit} | {rng} | {p.description}{ro} |')
    return '\n'.join(rows)


def table_from_defaults(defaults: dict, meta: dict, read_only=()) -> list:
    """A parameter table from ``{name: default}`` and ``{name: (unit, low, high, description)}``.

    Defaults come from the ROS-free core (its dataclasses), units and descriptions from ``meta``;
    a name missing from ``meta`` is an error, so no parameter goes undocumented.
    """
    missing = sorted(set(defaults) - set(meta))
    if missing:
        raise ValueError(f'no unit/description for parameter(s) {missing}')
    table = []
    for name, default in defaults.items():
        unit, low, high, desc = meta[name]
        if isinstance(default, (list, tuple)):
            default = list(default)
        if isinstance(default, float):
            low = None if low is None else float(low)
            high = None if high is None else float(high)
        table.append(Param(name, default, desc, unit, low, high, name in read_only))
    return table


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
