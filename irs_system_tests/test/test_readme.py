"""The README as a newcomer meets it: every command it shows exists and accepts its arguments.

Each indented command line of ``README.md`` is checked in its short form:

- ``make <target>``: the Makefile has that target;
- a node started with ``--ros-args``: the executable resolves through the ament index, every
  ``--params-file`` exists, every ``-p name:=value`` names a parameter of that node's table
  (``irs_parameters`` registry) with a value the table accepts;
- ``./irs run <package> <executable>`` with real names (not the generic usage lines), any
  other command: run with its arguments up to the first placeholder (``runs/<run>/bag``)
  and ``--help``, which must exit 0 (argparse reads every option before it); an experiment,
  sweep or container spec it names must exist.

The real-time lines themselves run for real in ``test_realtime_by_hand.py``; the links of the
README point at files that exist.
"""
from pathlib import Path
import re
import shlex
import subprocess

import pytest

from irs_bringup.executables import resolve_executable

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / 'README.md'


def readme_commands() -> list:
    """``[(line, argv)]`` of the README's indented command lines, ``$S``/``$RT`` expanded."""
    from ament_index_python.packages import get_package_share_directory
    env = {'S': str(Path(get_package_share_directory('irs_bringup')).parent)}
    env['RT'] = f"{env['S']}/irs_bringup/config/realtime.yaml"
    out = []
    for line in README.read_text().splitlines():
        if not line.startswith('    ') or line.lstrip().startswith('S='):
            continue
        argv = shlex.split(line, comments=True)
        argv = [re.sub(r'\$(\w+)', lambda m: env[m.group(1)], a) for a in argv]
        argv = argv[:-1] if argv[-1:] == ['&'] else argv       # started in the background
        if argv[:1] == ['make'] or argv[:2] == ['./irs', 'run'] and '<' not in argv[2]:
            out.append((line.strip(), argv))
    return out


COMMANDS = readme_commands()


def test_readme_is_short_and_starts_with_demo_and_test():
    lines = README.read_text().splitlines()
    assert len(lines) <= 150, len(lines)
    assert [c for _, c in COMMANDS[:2]] == [['make', 'demo'], ['make', 'test']]
    assert len(COMMANDS) >= 20, COMMANDS


def test_readme_links_point_at_files():
    text = README.read_text()
    targets = re.findall(r'\]\(([^)#]+)(?:#[^)]*)?\)', text)
    assert len(targets) > 15
    missing = [t for t in targets if not t.startswith('http') and not (ROOT / t).exists()]
    assert not missing


def _check_node(argv):
    from irs_common.params import check_values, parameter_table
    package, executable, *rest = argv[2:]
    assert Path(resolve_executable(package, executable)).is_file()
    rest = rest[rest.index('--ros-args') + 1:]
    overrides = {}
    for flag, value in zip(rest, rest[1:]):
        if flag == '--params-file':
            assert Path(value).is_file(), value
        elif flag == '-p':
            name, _, text = value.partition(':=')
            overrides[name] = _yaml_value(text)
    if overrides and executable != 'recorder':
        table = parameter_table(package, executable)
        assert {p.name for p in table} >= set(overrides), overrides
        check_values(table, overrides)          # raises on a value the table refuses


def _yaml_value(text):
    import yaml
    return yaml.safe_load(text)


def _check_names(argv):
    """The experiment, sweep or container spec a command names exists."""
    words = argv[4:]
    if argv[3] == 'experiment' and words[:1] == ['run']:
        from irs_bringup.experiment import find_experiment
        find_experiment(words[1])
    elif argv[3] == 'sweep' and words and words[0] not in ('list', 'similitude'):
        from irs_studies.sweep.sweep_file import find_sweep
        find_sweep(words[0])
    elif argv[3] == 'container':
        from irs_bringup.container import load_spec
        assert len(load_spec(words[0])) == 5


@pytest.mark.parametrize('line, argv', COMMANDS, ids=[c for c, _ in COMMANDS])
def test_readme_command_exists_and_takes_its_arguments(line, argv):
    if argv[0] == 'make':
        assert re.search(rf'^{argv[1]}:', (ROOT / 'Makefile').read_text(), re.M), line
        return
    if '--ros-args' in argv:
        _check_node(argv)
        return
    _check_names(argv)
    short = []
    for a in argv[4:]:
        if '<' in a:
            break
        short.append(a)
    exe = resolve_executable(argv[2], argv[3])
    res = subprocess.run([exe, *short, '--help'], capture_output=True, text=True, timeout=120,
                         cwd=ROOT)
    assert res.returncode == 0 and 'usage:' in res.stdout, (line, res.stdout, res.stderr)
