"""Anti-windup choice (back_calculation vs clip) and the start-up design check (no rclpy)."""
import math

import numpy as np
import pytest

from irs_control.controller_factory import (CONTROLLER_DEFAULTS, check_controller_params,
                                            make_controller, INPUT_CHECK_DEFAULTS)
from irs_control.design_check import (check_controller, check_plant_polynomials,
                                      require_stable)
from irs_control.discrete_pi import DiscretePiController
from irs_control.discrete_rst import DiscreteRstController, anti_windup_mode
from irs_control.paper_design import paper_mrc_design

DESIGNS = {'mrc_with_actuator': {'mode': 'mrc', 'include_actuator': True},
           'mrc_without_actuator': {'mode': 'mrc', 'include_actuator': False},
           'pi': {'mode': 'pi'}}


# --------------------------------------------------------------------------- anti-windup
def test_anti_windup_names_and_the_older_bool_spelling():
    assert anti_windup_mode(True) == 'back_calculation'
    assert anti_windup_mode(False) == 'clip'
    assert anti_windup_mode('clip') == 'clip'
    with pytest.raises(ValueError, match='anti_windup must be one of back_calculation, clip'):
        anti_windup_mode('conditional')
    with pytest.raises(ValueError, match='anti_windup'):
        check_controller_params({**CONTROLLER_DEFAULTS, **INPUT_CHECK_DEFAULTS,
                                 'anti_windup': 'none'})
    for mode in ('back_calculation', 'clip'):
        for name, cfg in DESIGNS.items():
            ctl = make_controller({**cfg, 'anti_windup': mode}).controller
            assert ctl.anti_windup_mode == mode, name


def _drive(ctl, n, ref, y=0.0):
    return [ctl.step(ref, y) for _ in range(n)]


def test_rst_clip_integrates_beyond_the_limit_back_calculation_does_not():
    d = paper_mrc_design(True)
    clip = DiscreteRstController(d, anti_windup='clip')
    aw = DiscreteRstController(d, anti_windup='back_calculation')
    free = DiscreteRstController(d, u_min=-1e6, u_max=1e6)   # never saturates: the linear law
    # A 0.3 m reference error held for 0.5 s at y = 0: far beyond the 15 deg limit.
    oc, oa, of = _drive(clip, 500, 0.3), _drive(aw, 500, 0.3), _drive(free, 500, 0.3)
    assert all(o.saturated for o in oc) and oa[0].saturated
    # clip: the state is exactly the unsaturated law's (it winds up with it) ...
    np.testing.assert_array_equal(clip.state, free.state)
    assert oc[-1].u_unsat == of[-1].u_unsat
    assert oc[-1].u_unsat > 5 * clip.u_max
    # ... back-calculation keeps the requested steer near what is applied.
    assert abs(oa[-1].u_unsat) < 1.5 * aw.u_max
    assert not np.allclose(aw.state, clip.state)


def test_rst_choices_agree_bit_for_bit_in_the_linear_range():
    d = paper_mrc_design(True)
    a, b = DiscreteRstController(d, anti_windup='clip'), DiscreteRstController(d)
    for k in range(2000):
        y = 0.004 * math.sin(0.01 * k)
        oa, ob = a.step(0.005, y), b.step(0.005, y)
        assert not oa.saturated and oa.u_sat == ob.u_sat


def test_pi_clip_integrates_beyond_the_limit_back_calculation_does_not():
    clip = DiscretePiController(anti_windup='clip', dt=1e-3)
    aw = DiscretePiController(anti_windup='back_calculation', dt=1e-3)
    e, n = 0.2, 20000         # 0.2 m error for 20 s = 12 T_t: kp e = 1 rad > 0.2618 rad
    _drive(clip, n, e)
    _drive(aw, n, e)
    assert clip.integral == pytest.approx(clip.ki * e * n * clip.dt, rel=1e-9)
    # back-calculation equilibrium ki e = (u - v)/Tt: I = v - kp e + ki e Tt
    assert aw.integral == pytest.approx(aw.u_max - aw.kp * e + aw.ki * e * aw.tracking_time,
                                        abs=1e-3)


# --------------------------------------------------------------------------- design check
def _check(name, plant, **extra):
    cfg = {**CONTROLLER_DEFAULTS, **INPUT_CHECK_DEFAULTS, **DESIGNS[name], 'check_plant': plant,
           **extra}
    spec = make_controller({k: v for k, v in cfg.items() if k in CONTROLLER_DEFAULTS})
    return cfg, spec, check_controller(cfg, spec.controller, spec.design)


def _char_roots(cfg, spec):
    """Closed-loop poles computed independently: roots of A R + B S."""
    B, A = check_plant_polynomials(cfg['check_plant'], cfg['actuator_pole'], cfg['plant_gain'],
                                   cfg['speed'], cfg['ds'])
    if spec.design is None:
        R, S = [1.0, 0.0], [cfg['kp'], cfg['ki']]
    else:
        R, S = spec.design.R, spec.design.S
    return np.roots(np.polyadd(np.polymul(A, R), np.polymul(B, S)))


@pytest.mark.parametrize('name', list(DESIGNS))
def test_paper_designs_are_stable_on_eq6(name):
    cfg, spec, chk = _check(name, 'identified')
    assert chk.stable, chk.summary()
    roots = _char_roots(cfg, spec)
    assert chk.max_real == pytest.approx(np.max(roots.real), abs=1e-6)
    # the sampled loop: its slowest pole is the continuous one mapped by z = exp(s dt)
    assert chk.max_abs_z == pytest.approx(math.exp(chk.max_real * cfg['dt']), abs=2e-5)
    assert chk.phase_margin > 20.0
    assert 'stable' in chk.summary() and 'UNSTABLE' not in chk.summary()


def test_mrc_with_actuator_on_eq6_places_the_designed_poles():
    cfg, spec, chk = _check('mrc_with_actuator', 'identified')
    d = spec.design
    want = np.roots(np.polymul(np.polymul(d.Am, d.Ao), d.B_plus))
    np.testing.assert_allclose(np.sort_complex(chk.poles), np.sort_complex(want), atol=1e-5)


@pytest.mark.parametrize('name,expect_real', [('mrc_with_actuator', 0.61),
                                              ('mrc_without_actuator', 1.09)])
def test_paper_mrc_designs_are_unstable_on_irs_2wd(name, expect_real):
    """Issue 12: rightmost real parts +0.61 (with the actuator) and +1.09 (without)."""
    cfg, spec, chk = _check(name, 'irs_2wd')
    assert not chk.stable
    assert chk.max_real == pytest.approx(np.max(_char_roots(cfg, spec).real), abs=1e-6)
    assert chk.max_real == pytest.approx(expect_real, abs=0.02)
    assert chk.max_abs_z > 1.0          # the sampled loop agrees
    assert chk.phase_margin < 0.0
    with pytest.raises(ValueError) as exc:
        require_stable(cfg, spec.controller, spec.design, 'MRC design')
    msg = str(exc.value)
    assert '\n' not in msg and "'irs_2wd' UNSTABLE" in msg and 'allow_unstable_design' in msg
    assert f'{chk.max_real:+.3g}' in msg
    # its gain margin is below 1, and for an unstable loop that is no lower margin
    assert chk.gain_margin < 1.0 and f'gain margin {chk.gain_margin:.3g},' in chk.summary()
    assert 'unstable below' not in chk.summary()
    _chk, warning, ok = require_stable({**cfg, 'allow_unstable_design': True}, spec.controller,
                                       spec.design)
    assert not ok and 'running anyway' in warning


def test_pi_is_stable_on_irs_2wd_and_unknown_plants_are_refused():
    _cfg, _spec, chk = _check('pi', 'irs_2wd')
    assert chk.stable, chk.summary()
    with pytest.raises(ValueError, match='check_plant'):
        _check('pi', 'no_such_car')


def test_crossover_frequencies_are_where_the_margins_are_read():
    """wcp is the gain crossover (|L| = 1, phase margin), wcg the phase crossover (-180 deg)."""
    import control
    import numpy as np

    from irs_control.design_check import check_design

    B, A = [10.0], [1.0, 3.0, 2.0, 0.0]           # L = 10 / (s (s + 1) (s + 2)): both crossings
    static = (np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), -np.ones((1, 1)))
    res = check_design(B, A, [1.0], [1.0], static, 1e-3)
    L = control.tf(B, A)
    assert abs(abs(control.evalfr(L, 1j * res.wcp)) - 1.0) < 1e-9
    assert abs(np.degrees(np.angle(control.evalfr(L, 1j * res.wcg))) + 180.0) < 1e-6


# --------------------------------------------------------------------------- delay margin
def test_a_design_stable_without_the_delay_is_refused_with_it():
    """PI kp = 15 on irs_2wd: phase margin 9.8 deg at the crossover, tolerates 10.4 ms of delay;
    the rig's 17 ms makes it unstable (the check without the delay passes it).
    """
    import control

    cfg, spec, chk = _check('pi', 'irs_2wd', kp=15.0, check_delay=0.017)
    free = check_controller({**cfg, 'check_delay': 0.0}, spec.controller, spec.design)
    assert free.stable and free.stable_without_delay and free.delay_margin > 0.0
    assert chk.stable_without_delay and not chk.stable
    # the margin is the phase margin over the crossover, less the delay (read from the Bode)
    B, A = check_plant_polynomials('irs_2wd', cfg['actuator_pole'], 0.0, cfg['speed'], cfg['ds'])
    L = control.tf(B, A) * control.tf([15.0, 3.0], [1.0, 0.0])
    phase = np.angle(control.evalfr(L, 1j * chk.wcp))
    assert abs(abs(control.evalfr(L, 1j * chk.wcp)) - 1.0) < 1e-9
    assert chk.delay_margin == pytest.approx((math.pi + phase) / chk.wcp - 0.017, rel=1e-9)
    assert -0.010 < chk.delay_margin < 0.0
    # the sampled loop with the delay as whole samples agrees: unstable with 17 ms, stable with
    # 2 ms less than the tolerated delay, unstable with 2 ms more
    assert chk.max_abs_z_delayed > 1.0 and free.max_abs_z_delayed < 1.0
    tolerated = free.delay_margin
    for extra, stable in ((-0.002, True), (0.002, False)):
        c = check_controller({**cfg, 'check_delay': tolerated + extra}, spec.controller, None)
        assert (c.max_abs_z_delayed < 1.0) == stable and c.stable == stable, extra
    with pytest.raises(ValueError) as exc:
        require_stable(cfg, spec.controller, spec.design, 'PI design')
    msg = str(exc.value)
    print(msg)
    assert '\n' not in msg and msg.startswith("PI design: closed loop on plant 'irs_2wd' "
                                              'UNSTABLE with the 17 ms transport delay')
    assert f'delay margin {1000 * chk.delay_margin:+.3g} ms' in msg
    assert 'check_delay' in msg and 'allow_unstable_design' in msg


@pytest.mark.parametrize('name', list(DESIGNS))
def test_paper_designs_on_eq6_keep_a_delay_margin(name):
    cfg, _spec, chk = _check(name, 'identified')
    assert chk.delay == 0.017 and chk.stable
    assert chk.delay_margin > 0.05                      # 87-200 ms beyond the 17 ms
    assert 'delay margin +' in chk.summary()


def test_check_delay_is_validated():
    with pytest.raises(ValueError, match='check_delay must be >= 0'):
        make_controller({'check_delay': -0.01})
    with pytest.raises(ValueError, match='check_delay must be a finite number'):
        make_controller({'check_delay': math.nan})


def test_summary_of_a_loop_unstable_only_as_sampled_names_its_z_and_continuous_poles():
    """Continuous poles all in the left half plane, a sampled pole outside |z| = 1: the line
    gives the sampled loop's |z| and the continuous loop's rightmost poles.
    """
    from irs_control.design_check import DesignCheck
    check = DesignCheck('full_size_sedan', poles=np.array([-0.293, -1.5 + 2.0j, -1.5 - 2.0j]),
                        discrete_poles=np.array([1.000136, 0.99]), gain_margin=0.998,
                        phase_margin=0.284, wcg=1.0, wcp=1.0, delay=0.017,
                        delay_margin=-math.inf)
    assert not check.stable and not check.stable_without_delay
    text = check.summary()
    assert "plant 'full_size_sedan' UNSTABLE as sampled: |z| max 1.000136" in text, text
    assert 'rightmost poles -0.293, -1.5 +- 2j rad/s' in text and 'none' not in text, text


def test_a_p_controller_has_no_integrator_pole_and_winds_up_no_integral():
    """PI with ki = 0 is a P controller: the check closes kp alone (no pole at s = 0, no
    discrete pole at z = 1), and a saturation leaves no integral behind (back-calculation
    would wind one up and keep it as a steer offset).
    """
    cfg, spec, chk = _check('pi', 'identified', kp=0.5, ki=0.0)
    assert chk.stable, chk.summary()
    assert np.all(np.abs(chk.discrete_poles) < 1.0) and np.max(chk.poles.real) < 0.0
    B, A = check_plant_polynomials('identified', cfg['actuator_pole'], cfg['plant_gain'],
                                   cfg['speed'], cfg['ds'])
    roots = np.roots(np.polyadd(A, 0.5 * np.asarray(B)))    # A + kp B
    assert np.allclose(np.sort_complex(roots), np.sort_complex(chk.poles))
    c = spec.controller
    for _ in range(500):
        assert c.step(1.0, 0.0).saturated        # kp e = 0.5 rad beyond the steer limit
    assert c.integral == 0.0 and c.step(0.0, 0.0).u_sat == 0.0
    from irs_control.design_check import check_design
    as_pi = check_design(B, A, [1.0, 0.0], [0.5, 0.0], (np.eye(1), np.zeros((1, 1)), np.eye(1),
                                                        -0.5 * np.eye(1)), cfg['dt'])
    assert not as_pi.stable and np.isclose(as_pi.max_real, 0.0)    # the integrator's pole at 0


def test_a_stable_loop_with_a_gain_margin_below_one_is_called_conditionally_stable():
    from irs_control.design_check import DesignCheck
    check = DesignCheck('identified', poles=np.array([-2.0, -3.0 + 1.0j, -3.0 - 1.0j]),
                        discrete_poles=np.array([0.998, 0.997]), gain_margin=0.5,
                        phase_margin=40.0, wcg=3.0, wcp=5.0, delay=0.0, delay_margin=0.1)
    assert check.stable
    assert 'gain margin 0.5 (a lower margin: unstable below that factor of the gain)' \
        in check.summary(), check.summary()
