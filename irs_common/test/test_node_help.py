"""A node's own command line: what is outside --ros-args, --help, the refusal (no node)."""
from hypothesis import given, settings, strategies as st
from rclpy.utilities import remove_ros_args

from irs_common.node_help import help_text, own_arguments, refusal, summary, wants_help
from irs_common.params import Param

OWN = st.sampled_from(['x', '--help', '-h', 'foo', '--verbose'])
ROS_PAIR = st.sampled_from([['-p', 'a:=1'], ['-r', 'b:=c'], ['--log-level', 'info'],
                            ['--param', 'z:=[1, 2]'], ['--enclave', '/e']])


@st.composite
def command_lines(draw):
    """``[program, ...]``: own arguments and ``--ros-args`` sections, each closed by ``--``
    except possibly the last.
    """
    argv = ['prog']
    for _ in range(draw(st.integers(0, 4))):
        if draw(st.booleans()):
            argv.append(draw(OWN))
        else:
            argv.append('--ros-args')
            for pair in draw(st.lists(ROS_PAIR, max_size=3)):
                argv += pair
            argv.append('--')
    if draw(st.booleans()):
        argv += ['--ros-args', *draw(ROS_PAIR)]
    return argv


@settings(max_examples=300, deadline=None)
@given(command_lines())
def test_own_arguments_are_what_rcl_leaves(argv):
    """The grammar agrees with rcl's own parser (``remove_ros_args``) on every such line."""
    assert own_arguments(argv) == remove_ros_args(argv)[1:]


def test_own_arguments_keep_a_bare_assignment_that_rcl_takes_for_a_remap():
    # rcl reads 'clock_mode:=lockstep' before --ros-args as a remap rule (deprecated syntax)
    assert own_arguments(['vehicle_sim', 'clock_mode:=lockstep']) == ['clock_mode:=lockstep']
    assert own_arguments(['n', '--ros-args', '-p', 'a:=1']) == []
    assert own_arguments(['n', '-p', 'a:=1', '--ros-args', '-r', 'x:=y', '--', '-h']) == \
        ['-p', 'a:=1', '-h']
    assert wants_help(['-h']) and wants_help(['x', '--help']) and not wants_help(['-help'])


def test_refusal_names_the_arguments_and_the_command_that_was_meant():
    assert refusal(['-p', 'clock_mode:=lockstep'], 'vehicle_sim') == (
        "vehicle_sim takes no arguments of its own, got '-p clock_mode:=lockstep'; ROS "
        'arguments go after --ros-args: vehicle_sim --ros-args -p clock_mode:=lockstep '
        '(vehicle_sim --help lists its parameters)')
    bare = refusal(['rate:=50', '-r', 'a:=b'], 'driver')
    assert bare.endswith('driver --ros-args -p rate:=50 -r a:=b (driver --help lists its '
                         'parameters)'), bare
    assert refusal(['foo'], 'recorder') == ("recorder takes no arguments of its own, got 'foo' "
                                            '(recorder --help lists its parameters)')


def test_help_lists_every_parameter_with_unit_default_range_and_writability():
    table = [Param('rate', 100.0, 'ticks per second', 'Hz', 1.0, 1000.0, writable=True),
             Param('frame_id', 'map', 'the frame ' + 'of the pose ' * 12, '-'),
             Param('budget', 5, 'messages', '1', realtime_default=1)]
    text = help_text('pkg', 'exe', 'Does a thing.', table)
    lines = text.splitlines()
    assert lines[0].startswith('usage: ros2 run pkg exe [--ros-args ')
    assert 'Does a thing.' in lines
    assert '  rate [Hz] = 100.0, range [1.0, 1000.0], writable' in lines
    assert "  frame_id [-] = 'map'" in lines
    assert '  budget [1] = 5' in lines
    assert any('real time: 1 by default' in line for line in lines)
    assert max(len(line) for line in lines[1:]) <= 99
    assert 'docs/parameters.md' in help_text('pkg', 'exe', '', None)


def test_summary_is_the_first_paragraph_of_the_module_docstring_in_plain_text(tmp_path,
                                                                              monkeypatch):
    (tmp_path / 'fake_rig_node.py').write_text(
        '"""``fake_rig`` node: the simulated rig on ROS topics (thin wrapper of\n'
        ':mod:`.rig`), with ``/clock``.\n\nMore."""\nraise SystemExit("not imported")\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    assert summary('fake_rig_node') == ('The simulated rig on ROS topics (thin wrapper of rig), '
                                        'with /clock.')
    assert summary('irs_common.node_help').startswith("A node executable's own command line: "
                                                      '--help, and')
    assert summary('no_such_module_anywhere') == ''
