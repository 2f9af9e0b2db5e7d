"""declare_table on a plain rclpy node: start-up checks, on-set validation, post-set handlers.

The callbacks run inside ``Node.set_parameters`` (the same path the parameter services take),
so no spinning is needed.
"""
import math

from hypothesis import given, settings, strategies as st
import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from irs_common.params import Param, ParameterGuard, declare_table, unknown_overrides

TABLE = [Param('x0', 0.5, 'initial x', 'm', -1.0, 1.0, writable=True),
         Param('gain', 2.0, 'gain without range', '1', writable=True),
         Param('poles', [1.0, 2.0], 'poles', '1/s', writable=True),
         Param('even', 2, 'an even count', '1', 0, 100, writable=True,
               validator=lambda v: None if v % 2 == 0 else 'must be even'),
         Param('mode', 'a', 'mode', '-', read_only=True),
         Param('dt', 0.001, 'step', 's', 1e-5, 0.05)]


@pytest.fixture
def ctx():
    context = Context()
    rclpy.init(context=context)
    nodes = []

    def make(*args):
        node = Node(
            'params_test', context=context, cli_args=['--ros-args', *args] if args else None
        )
        nodes.append(node)
        return node
    yield make
    for node in nodes:
        node.destroy_node()
    rclpy.try_shutdown(context=context)


def _declare(node, **kw):
    seen = []
    values = declare_table(node, TABLE, on_change=lambda name, value: seen.append((name, value)),
                           **kw)
    return values, seen


def test_integer_overrides_are_taken_for_doubles_at_start_up(ctx, tmp_path):
    f = tmp_path / 'p.yaml'
    f.write_text('params_test:\n  ros__parameters:\n    gain: 3\n    poles: [4, 5]\n')
    node = ctx('-p', 'x0:=0', '-p', 'dt:=0.002', '--params-file', str(f))
    values, seen = _declare(node)
    assert values['x0'] == 0.0 and type(values['x0']) is float
    assert values['gain'] == 3.0 and type(values['gain']) is float
    assert values['poles'] == [4.0, 5.0] and all(type(v) is float for v in values['poles'])
    assert node.get_parameter('x0').type_ == Parameter.Type.DOUBLE
    assert values['dt'] == 0.002 and seen == []     # handlers are for changes, not start-up


def test_changes_of_writable_parameters_reach_the_handler_as_doubles(ctx):
    node = ctx()
    values, seen = _declare(node)
    [res] = node.set_parameters([Parameter('x0', value=1)])          # an INTEGER for a double
    assert res.successful, res.reason
    assert seen == [('x0', 1.0)] and type(seen[0][1]) is float
    assert node.get_parameter('x0').value == 1.0 and values['x0'] == 1.0
    res = node.set_parameters_atomically([Parameter('poles', value=[3, 4]),
                                          Parameter('even', value=4)])
    assert res.successful, res.reason
    assert seen[1:] == [('poles', [3.0, 4.0]), ('even', 4)] and values['even'] == 4


@pytest.mark.parametrize(
    'name, value, reason',
    [
        ('x0', 2.0, 'out of range'),  # rclpy's range check (descriptor)
        ('x0', math.nan, 'out of range'),
        ('x0', 'abc', 'Wrong parameter type'),  # rclpy's type check (descriptor)
        ('gain', math.nan,
         "parameter 'gain': got nan (not a finite number), expected a finite double"),
        ('gain', math.inf, "parameter 'gain': got inf (not a finite number)"),
        ('poles', [],
         "parameter 'poles': got an empty array, expected a non-empty array of finite"),
        ('poles', [1.0, math.nan], "parameter 'poles': got nan (not a finite number)"),
        ('even', 3, "parameter 'even': 3 refused: must be even"),
        ('mode', 'b', 'read-only'),
        ('dt', 0.002, 'read-only'),
    ],
)
def test_bad_changes_are_refused_with_a_reason_and_change_nothing(ctx, name, value, reason):
    node = ctx()
    values, seen = _declare(node)
    before = node.get_parameter(name).value
    [res] = node.set_parameters([Parameter(name, value=value)])
    assert not res.successful and reason in res.reason, res.reason
    assert node.get_parameter(name).value == before and values[name] == before and seen == []


def test_an_atomic_set_with_one_bad_value_sets_none(ctx):
    node = ctx()
    _values, seen = _declare(node)
    res = node.set_parameters_atomically([Parameter('x0', value=0.25),
                                          Parameter('gain', value=math.inf)])
    assert not res.successful and 'gain' in res.reason
    assert node.get_parameter('x0').value == 0.5 and seen == []


def test_a_writable_parameter_without_a_handler_is_a_programming_error(ctx):
    with pytest.raises(TypeError, match=r"writable parameter\(s\) \['x0'.*need an on_change"):
        declare_table(ctx(), TABLE)
    # read-only tables need no handler
    assert declare_table(ctx(), [p for p in TABLE if p.read_only]) == {'mode': 'a', 'dt': 0.001}


@pytest.mark.parametrize(
    'args, message',
    [
        (('-p', 'x0:=abc'),
         "parameter 'x0': got 'abc' (string), expected a finite double in [-1.0, 1.0]"),
        (('-p', 'x0:=5.0'),
         "parameter 'x0': got 5.0 (out of range), expected a finite double in [-1.0, 1.0]"),
        (('-p', 'gain:=.nan'), "parameter 'gain': got nan (not a finite number)"),
        (('-p', 'poles:=[]'), "parameter 'poles': got an empty array, expected a non-empty array"),
        (('-p', 'even:=3'), "parameter 'even': 3 refused: must be even"),
        (('-p', 'even:=true'),
         "parameter 'even': got True (boolean), expected an integer in [0, 100]"),
        (('-p', 'mode:=1'), "parameter 'mode': got 1 (integer), expected a string"),
    ],
)
def test_bad_start_up_values_are_one_value_error(ctx, args, message):
    with pytest.raises(ValueError) as info:
        _declare(ctx(*args))
    text = str(info.value)
    assert message in text and "node 'params_test'" in text and '\n' not in text, text


def test_a_second_params_file_that_changes_the_type_is_reported(ctx, tmp_path):
    first, second = tmp_path / 'a.yaml', tmp_path / 'b.yaml'
    first.write_text('/**:\n  ros__parameters:\n    x0: 0.25\n')
    second.write_text('params_test:\n  ros__parameters:\n    x0: [1.0, 2.0]\n')
    with pytest.raises(ValueError) as info:
        _declare(ctx('--params-file', str(first), '--params-file', str(second)))
    assert "parameter 'x0': got [1.0, 2.0] (array of doubles), expected a finite double" \
        in str(info.value)
    assert 'the last one wins' in str(info.value)


def test_rclpy_refusals_at_declaration_become_value_errors(ctx):
    node = ctx()
    node.add_on_set_parameters_callback(
        lambda params: type(_declare_result())(successful=False, reason='vetoed by the node'))
    with pytest.raises(
        ValueError, match=r"parameter 'x0' \(node 'params_test'\): .*vetoed by the node"
    ):
        _declare(node)


def _declare_result():
    from rcl_interfaces.msg import SetParametersResult
    return SetParametersResult()


def test_unknown_override_names_are_reported(ctx, capfd):
    node = ctx('-p', 'x00:=1.0', '-p', 'gian:=2.0', '-p', 'use_sim_time:=true',
               '-p', 'qos_overrides./clock.subscription.depth:=5')
    _declare(node)
    assert unknown_overrides(node) == ['gian', 'x00']
    assert captured_contains(
        capfd,
        "unknown parameter(s) given to node 'params_test' (misspelt?): "
        'gian (did you mean gain?), x00 (did you mean x0?); ignored',
    )
    strict = ctx('-p', 'x00:=1.0')
    with pytest.raises(ValueError, match=r'unknown parameter\(s\) .*x00 \(did you mean x0\?\)'):
        _declare(strict, strict=True)
    quiet = ctx('-p', 'use_sim_time:=true')
    _declare(quiet, strict=True)                      # rclpy's own parameters are not unknown
    assert unknown_overrides(quiet) == []


def captured_contains(capfd, text):
    """rcutils logs to stderr from C, synchronously: the text is there once the call returned."""
    out, err = capfd.readouterr()
    return text in out + err


def test_two_tables_on_one_node_share_one_set_of_callbacks(ctx):
    node = ctx('-p', 'b:=1')
    seen = []
    handler = lambda n, v: seen.append((n, v))  # noqa: E731
    a = declare_table(
        node, [Param('a', 1.0, 'a', 'm', writable=True)], handler, check_unknown=False
    )
    b = declare_table(node, [Param('b', 1.0, 'b', 'm', writable=True)], handler)
    guard = getattr(node, ParameterGuard.ATTRIBUTE)
    assert b == {'b': 1.0}
    for callbacks in (node._pre_set_parameters_callbacks, node._on_set_parameters_callbacks,
                      node._post_set_parameters_callbacks):
        assert sum(getattr(cb, '__self__', None) is guard for cb in callbacks) == 1
    assert node.set_parameters_atomically(
        [Parameter('a', value=2), Parameter('b', value=3)]
    ).successful
    assert seen == [('a', 2.0), ('b', 3.0)] and a == {'a': 2.0} and b == {'b': 3.0}


def test_parameters_of_other_mechanisms_pass_untouched(ctx):
    node = ctx()
    _declare(node)
    node.declare_parameter('other', 1.0)
    [res] = node.set_parameters([Parameter('other', value=7.0)])
    assert res.successful and node.get_parameter('other').value == 7.0
    [res] = node.set_parameters([Parameter('use_sim_time', value=True)])
    assert res.successful


@settings(max_examples=60, deadline=None)
@given(
    value=st.one_of(st.floats(width=64), st.integers(-5, 5), st.booleans(), st.text(max_size=2))
)
def test_set_of_a_double_is_accepted_exactly_when_valid(value):
    """Fuzz through the node (one context per example is too slow: one node for all examples)."""
    node = _FUZZ_NODE['node']
    seen = _FUZZ_NODE['seen']
    seen.clear()
    [res] = node.set_parameters([Parameter('gain', value=value)])
    valid = not isinstance(value, (bool, str)) and math.isfinite(float(value))
    assert res.successful == valid, (value, res.reason)
    if valid:
        assert seen == [('gain', float(value))]
    else:
        assert seen == [] and res.reason


_FUZZ_NODE = {}


@pytest.fixture(autouse=True, scope='module')
def _fuzz_node():
    context = Context()
    rclpy.init(context=context)
    node = Node('params_fuzz', context=context)
    seen = []
    declare_table(node, TABLE, on_change=lambda n, v: seen.append((n, v)))
    _FUZZ_NODE.update(node=node, seen=seen)
    yield
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def test_a_long_list_of_unknown_names_is_shortened(ctx):
    args = [a for i in range(12) for a in ('-p', f'zz{i:02d}:=1.0')]
    node = ctx(*args)
    with pytest.raises(ValueError) as info:
        _declare(node, strict=True)
    assert 'zz00, zz01' in str(info.value) and 'zz09 and 2 more' in str(info.value)
    assert 'zz10' not in str(info.value)


def _x0_times_gain(values):
    """A check over two parameters: |x0 * gain| <= 1."""
    product = values['x0'] * values['gain']
    return None if abs(product) <= 1.0 else f'x0 * gain = {product:g} exceeds 1'


def test_a_table_check_refuses_a_change_that_breaks_a_joint_limit(ctx):
    node = ctx()
    values, seen = _declare(node, check=_x0_times_gain)
    [res] = node.set_parameters([Parameter('gain', value=3.0)])    # 0.5 * 3 = 1.5
    assert not res.successful and 'x0 * gain = 1.5 exceeds 1' in res.reason
    assert values['gain'] == 2.0 and seen == []
    res = node.set_parameters_atomically([Parameter('x0', value=0.25),     # 0.25 * 3 = 0.75
                                          Parameter('gain', value=3.0)])
    assert res.successful, res.reason
    assert values['x0'] == 0.25 and values['gain'] == 3.0


def test_a_table_check_refuses_start_up_values_in_one_line(ctx):
    node = ctx('-p', 'gain:=4.0')
    with pytest.raises(ValueError, match="node 'params_test': x0 \\* gain = 2 exceeds 1"):
        _declare(node, check=_x0_times_gain)
