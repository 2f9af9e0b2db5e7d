"""A node executable's own command line: ``--help``, and the refusal of anything else.

A node is configured through ROS arguments only::

    ros2 run <package> <executable> --ros-args -p name:=value --params-file file.yaml

Outside ``--ros-args ... [--]`` it takes ``-h``/``--help`` (:func:`help_text`: what the node is,
its usage and its parameter table) and nothing else (:func:`refusal`). rclpy itself ignores
such arguments, so ``vehicle_sim -p clock_mode:=lockstep`` (``--ros-args`` forgotten) would
start a rig in real time, its default, while its user waits for a lock-step run, and
``vehicle_sim clock_mode:=lockstep`` is a remap rule in rcl's deprecated syntax, not a
parameter; here both are a one-line start-up error instead.

No rclpy import (:mod:`irs_common.node_main` calls it before ``rclpy.init``).
"""
from __future__ import annotations

import ast
import importlib.util
import re
import textwrap

from .cli import describe

HELP_FLAGS = ('-h', '--help')

#: Where the full tables are, with the real-time defaults explained.
DOCS = 'docs/parameters.md'


def own_arguments(argv) -> list[str]:
    """The arguments of ``argv`` (program name first) outside every ``--ros-args ... [--]``
    section, in order: rcl's grammar, in which ``--`` ends a ROS section.
    """
    own, in_ros = [], False
    for arg in list(argv)[1:]:
        if arg == '--ros-args':
            in_ros = True
        elif in_ros and arg == '--':
            in_ros = False
        elif not in_ros:
            own.append(arg)
    return own


def wants_help(own_args) -> bool:
    """True if the arguments outside ``--ros-args`` ask for help."""
    return any(arg in HELP_FLAGS for arg in own_args)


def executable_of(module: str):
    """``(package, executable)`` of the console script whose ``main`` is in ``module``, or None.

    Found through the installed ``console_scripts`` entry points, so ``python -m <module>``
    names the executable as ``ros2 run`` would.
    """
    from importlib.metadata import entry_points
    for ep in entry_points(group='console_scripts'):
        if ep.module == module and ep.dist is not None:
            return ep.dist.name, ep.name
    return None


def summary(module: str) -> str:
    """The first paragraph of ``module``'s docstring as plain text, without its leading
    "<name> node:" (read from the source: the module is not imported again).
    """
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.origin or not spec.origin.endswith('.py'):
        return ''
    with open(spec.origin, encoding='utf-8') as f:
        first = describe(ast.get_docstring(ast.parse(f.read())) or '')
    first = re.sub(r'^\w+ node:\s*', '', first)
    return first[:1].upper() + first[1:]


def usage(package: str, executable: str) -> str:
    """The usage line, as ``ros2 run`` starts the node."""
    return (f'usage: ros2 run {package} {executable} [--ros-args [-p NAME:=VALUE]... '
            f'[--params-file FILE]... [-r FROM:=TO]...]')


def parameter_lines(table, width: int = 99) -> list[str]:
    """One entry per parameter: ``name [unit] = default, range [low, high], writable``, then
    its description indented (wrapped at ``width``).
    """
    lines = []
    for p in table:
        head = f'  {p.name} [{p.unit}] = {p.default!r}'
        if p.low is not None or p.high is not None:
            head += f', range [{p.low}, {p.high}]'
        if p.writable:
            head += ', writable'
        lines.append(head)
        lines += textwrap.wrap(p.text(), width, initial_indent=' ' * 6,
                               subsequent_indent=' ' * 6)
    return lines


def help_text(package: str, executable: str, about: str, table) -> str:
    """What ``<executable> --help`` prints: usage, what the node is, its parameters."""
    parts = [usage(package, executable), '']
    if about:
        parts += [textwrap.fill(about, 99), '']
    if table is None:
        parts.append(f'Parameters: {DOCS}.')
    else:
        parts += [f'Parameters (read-only unless writable; units in brackets; {DOCS}):',
                  *parameter_lines(table)]
    return '\n'.join(parts) + '\n'


def refusal(own_args, executable: str) -> str:
    """The one-line error for arguments a node does not take (``own_args`` non-empty)."""
    listed = ' '.join(own_args)
    flags = ('-p', '--param', '--params-file', '-r', '--remap')
    hint = ''
    if any(arg in flags or ':=' in arg for arg in own_args):
        suggested, prev = [], ''
        for arg in own_args:       # a bare name:=value is meant as a parameter
            suggested += ['-p', arg] if ':=' in arg and prev not in flags else [arg]
            prev = arg
        hint = f"; ROS arguments go after --ros-args: {executable} --ros-args " \
               f"{' '.join(suggested)}"
    return (f"{executable} takes no arguments of its own, got '{listed}'{hint} "
            f'({executable} --help lists its parameters)')
