"""No command topic ever leaves its limit, whatever a node's numeric parameters are.

For each node that commands something, hypothesis draws a few of its numeric parameters from
the ranges its table declares (``irs_common.params.registered_tables()``: every installed
node's), builds the node's cores through the same ``*_config`` function the node calls, and
drives them with arbitrary inputs (NaN, inf, huge values included). A configuration the node
refuses at start-up (ValueError, a failed design) is counted as refused; every other one must
keep its command within the limit of the topic it publishes on:

* ``steering/command``: ``|steer| <= STEER_LIMIT`` (15 deg at the wheel) -- lateral_controller,
  chassis_controller, excitation (target steering);
* ``treadmill/drive``: ``0 <= V <= 12.7`` V (the belt's drive range) -- treadmill_regulator,
  excitation (target drive);
* ``wheels/torque_command``: ``|torque| <= torque_limit`` (the motor's, carried in the message);
* ``lateral/reference``: ``|y_ref| <= 1`` m -- reference_generator.

Each test counts the drawn configurations that reached the assertions and asserts on the count.
"""
import math

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from irs_common.params import registered_tables
from irs_models.constants import STEER_LIMIT

DRIVE_MAX = 12.7
WILD = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                 st.floats(min_value=-3.0, max_value=3.0))
TABLES = registered_tables()
# derandomized: the examples, and so how many reach the assertions (checked per test), are the
# same in every run
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def _table(executable):
    (table,) = [t for (_pkg, exe), t in TABLES.items() if exe == executable]
    return table


def _numeric(p):
    return isinstance(p.default, (int, float)) and not isinstance(p.default, bool)


def _value(p):
    low = -1e6 if p.low is None or math.isinf(p.low) else p.low
    high = 1e6 if p.high is None or math.isinf(p.high) else p.high
    if isinstance(p.default, int):
        return st.integers(int(math.ceil(low)), int(math.floor(high)))
    return st.one_of(st.sampled_from([low, high]), st.floats(low, high))


@st.composite
def drawn(draw, executable, names=None, max_changed=4, fixed=None, always=()):
    """The table's defaults with up to ``max_changed`` numeric parameters (of ``names``, or
    all) and every one of ``always`` drawn from their declared ranges; ``fixed`` overrides.
    """
    table = _table(executable)
    values = {p.name: p.default for p in table}
    numeric = [p for p in table if _numeric(p) and (names is None or p.name in names)]
    chosen = draw(st.lists(st.sampled_from(numeric), max_size=max_changed, unique_by=id))
    for p in chosen + [p for p in table if p.name in always]:
        values[p.name] = draw(_value(p))
    values.update(fixed or {})
    return values


def test_regulator_drive_within_the_belt_range():
    from irs_treadmill.regulator import BeltSpeedRegulator
    from irs_treadmill.regulator_params import regulator_config
    from irs_treadmill.safety import SafetyMonitor
    reached = []

    # a car ahead of the set point on a slow belt asks for the most voltage
    on_belt = st.tuples(st.floats(-1.0, 1.0), st.floats(0.0, 7.0), st.floats(-3.0, 3.0))
    pushing = st.tuples(st.floats(0.5, 1.0), st.floats(0.0, 0.5), st.floats(1.0, 3.0))

    @settings(SETTINGS, max_examples=200)
    @given(values=drawn('treadmill_regulator', max_changed=3,
                        always=('regulator.u_max', 'regulator.slew_rate')),
           inputs=st.lists(st.one_of(pushing, on_belt, st.tuples(WILD, WILD, WILD)),
                           min_size=5, max_size=60))
    def check(values, inputs):
        try:
            cfg = regulator_config(values)
            reg, safety = BeltSpeedRegulator(cfg.regulator), SafetyMonitor(cfg.safety)
        except ValueError:
            return
        dt = 1.0 / cfg.rate_hz
        for k, (x, belt, xdot) in enumerate(inputs):
            safety.update_position(x, 0.0, k * dt, now=k * dt)
            out = reg.update(x, belt, dt, xdot=xdot, enabled=safety.drive_permitted)
            volt = safety.gate(out.voltage)
            assert math.isfinite(volt) and 0.0 <= volt <= DRIVE_MAX, (values, volt)
        reached.append(1)
    check()
    assert len(reached) >= 20, len(reached)


def test_lateral_controller_steer_within_the_servo_limit():
    from irs_control.controller_factory import make_controller
    from irs_control.lateral_params import controller_config
    reached = []

    @SETTINGS
    @given(values=drawn('lateral_controller', max_changed=3),
           mode=st.sampled_from(['mrc', 'pi']),
           inputs=st.lists(st.tuples(WILD, WILD), min_size=5, max_size=60))
    def check(values, mode, inputs):
        values = {**values, 'mode': mode}
        try:
            controller = make_controller(controller_config(values)).controller
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            return
        for ref, y in inputs:
            u = controller.step_checked(ref, y).u_sat
            assert math.isfinite(u) and abs(u) <= STEER_LIMIT, (values, u)
        reached.append(1)
    check()
    assert len(reached) >= 20, len(reached)


def test_chassis_controller_torque_and_steer_within_limits():
    from irs_control.chassis_params import chassis_config
    from irs_control.torque_car_control import TorqueCarController
    reached = []

    @SETTINGS
    @given(values=drawn('chassis_controller'),
           inputs=st.lists(st.tuples(st.lists(WILD, min_size=4, max_size=4), WILD, WILD, WILD),
                           min_size=5, max_size=40))
    def check(values, inputs):
        try:
            cfg = chassis_config(values)
            core = TorqueCarController(cfg)
        except ValueError:
            return
        limit = values['torque_limit']
        for k, (omega, x, belt, r) in enumerate(inputs):
            stamp = 1_000_000 * (k + 1)
            core.update_pose(stamp, x, 0.0, belt)
            out = core.step(stamp, omega, r)
            torques = np.asarray(out.torques, float)
            assert np.all(np.isfinite(torques)) and np.all(np.abs(torques) <= limit + 1e-12)
            for steer in (out.front_steer, out.rear_steer):
                assert math.isfinite(steer) and abs(steer) <= STEER_LIMIT, (values, steer)
        reached.append(1)
    check()
    assert len(reached) >= 30, len(reached)


def test_excitation_output_within_its_target_limit():
    from irs_sysid.excitation_params import (TARGETS, excitation_problem, excitation_value,
                                             output_limit, signal_from_params)
    reached, refused = [], []

    @SETTINGS
    @given(target=st.sampled_from(sorted(TARGETS)),
           kind=st.sampled_from(['step', 'square', 'sine', 'constant', 'chirp']),
           data=st.data())
    def check(target, kind, data):
        values = data.draw(drawn('excitation', fixed={'target': target, 'signal.type': kind},
                                 max_changed=3))
        if excitation_problem(values) is not None:
            refused.append(1)
            return
        signal, bounds = signal_from_params(values), output_limit(values)
        own = STEER_LIMIT if target == 'steering' else DRIVE_MAX
        for t in np.linspace(0.0, 20.0, 201):
            v = excitation_value(signal, t, bounds)
            assert math.isfinite(v) and (abs(v) <= own if target == 'steering'
                                         else 0.0 <= v <= own), (values, v)
            assert v == float(signal(t)), 'an accepted signal needs no clipping'
        reached.append(1)
    check()
    assert len(reached) >= 15 and len(refused) >= 3, (len(reached), len(refused))


def test_reference_generator_within_one_metre():
    from irs_control.reference_params import reference_problem, reference_signal
    reached = []

    @SETTINGS
    @given(kind=st.sampled_from(['step', 'square', 'sine', 'constant', 'chirp']), data=st.data())
    def check(kind, data):
        values = data.draw(drawn('reference_generator', fixed={'signal.type': kind},
                                 always=('signal.amplitude',)))
        if reference_problem(values) is not None:
            return
        signal = reference_signal(values)
        for t in np.linspace(0.0, 20.0, 201):
            assert abs(signal(t)) <= 1.0 + 1e-12
        reached.append(1)
    check()
    assert len(reached) >= 20, len(reached)


def test_excitation_node_refuses_limits_beyond_its_target(ros, launch):
    """The graph check: the node exits with one line for a limit beyond the steering servo's,
    and refuses a run-time amplitude that would leave its bounds (the signal stays as it was).
    """
    from irs_bringup.processes import NodeSpec
    from irs_system_tests.output_lines import own_lines
    from irs_system_tests.service_calls import set_params

    bad = launch(NodeSpec('irs_sysid', 'excitation', params={'target': 'steering',
                                                             'limit': 1.0}))
    assert ros.spin_until(lambda: bad.poll() is not None, 30.0)
    assert bad.poll() == 2
    lines = own_lines(bad.output())      # (Fast DDS may log a transport problem of its own)
    assert len(lines) == 1 and 'limit 1 rad exceeds the limit of steering/command (0.2618 rad)' \
        in lines[0], lines
    launch(NodeSpec('irs_sysid', 'excitation', params={'target': 'steering',
                                                       'signal.type': 'sine',
                                                       'signal.amplitude': 0.1}))
    [res] = set_params(ros, 'excitation', signal__amplitude=5.0)
    assert not res.successful and 'beyond the output bounds' in res.reason, res.reason
    [res] = set_params(ros, 'excitation', signal__amplitude=0.2)
    assert res.successful, res.reason
