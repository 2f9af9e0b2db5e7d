"""Treadmill identification (irs_sysid.treadmill_fit) on data it shares no code with.

The data: :func:`sysid_generators.belt_run`, Eq. 1-2 integrated by ``solve_ivp`` and measured
by an encoder written there (77.9 um of belt per count, differenced over 10 samples of 1 ms,
published one sample late), with white or Ornstein-Uhlenbeck noise added or none. Each
parameter is held to ``Z_TEST`` = 4 standard deviations of what the data's noise allows:
``predicted_covariance`` at the true values, from the generator's Jacobian at the samples the
fit uses (each step's and coast's start speed a nuisance parameter, as in the fit) and the
noise's covariance there -- the encoder's quantisation (a uniform error of the counted travel,
differenced over the window: once thinned to one sample per window, variance ``2 q^2/12`` and
lag-one covariance ``-q^2/12``, ``q = count / (window dt)``) plus the added noise. Each check is
also run on a deliberately wrong fit (a test-only 0.5 % error in one model term) and must fail.
"""
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.linalg import block_diag, toeplitz

from irs_sysid import treadmill_fit as tf
from irs_sysid.treadmill_cli import belt_params_of, installed_rig_params
from irs_sysid.treadmill_fit import driver_profile, fit_coast, fit_drive, segments, \
    simulate_belt
from irs_control.reference import Schedule
from irs_vehicle_sim.belt import MPH, BeltParams, TreadmillBelt
from sysid_generators import Z_TEST, Belt, belt_run, ou_covariance, ou_noise, \
    predicted_covariance

DT = 1e-3
DECIMATE = 10                 # the fits' default: one sample per encoder window
EXPERIMENTS = Path(__file__).resolve().parents[2] / 'irs_bringup' / 'config' / 'experiments'
#: settled at 0.5 V, steps up to 1.5, 3 and 4 V held 2 s, the drive cut: a coast to rest
SCHEDULE = [(0.0, 0.5), (1.0, 1.5), (3.0, 3.0), (5.0, 4.0), (7.0, 0.0)]


def _run_end(belt, schedule):
    """The schedule's end: the last coast down to 0.1 m/s and 1 s more (Eq. 1's t_stop)."""
    v = belt.b / belt.a * schedule[-2][1]
    return schedule[-1][0] + belt.delay + math.log((v + belt.k) / (0.1 + belt.k)) / belt.c + 1.0


class Case:
    """One belt and schedule: its data without noise, and the fits' samples and Jacobians."""

    def __init__(self, belt=Belt(), schedule=SCHEDULE):
        self.belt, self.schedule = belt, schedule
        self.t_end = _run_end(belt, schedule)
        self.t, self.v, self.u = belt_run(belt, schedule, self.t_end)
        self.v_exact = belt_run(belt, schedule, self.t_end, quantise=False)[1]
        t, sch = self.t, schedule
        ups = [i for i in range(1, len(sch)) if sch[i][1] > sch[i - 1][1]]
        cut = next(i for i in range(1, len(sch)) if sch[i][1] <= 0.0 < sch[i - 1][1])
        ends = [s for s, _ in sch[1:]] + [self.t_end]
        # the samples fit_drive and fit_coast use (their documented defaults)
        self.drive_idx = [np.flatnonzero((t >= sch[i][0] - 0.05) & (t < min(ends[i], sch[i][0]
                          + 2.0)))[::DECIMATE] for i in ups]
        m = np.flatnonzero((t >= sch[cut][0] + 0.15) & (self.v_exact > 0.1))
        self.coast_idx = [m[:np.argmax(np.diff(m) > 1) + 1 if np.any(np.diff(m) > 1)
                            else m.size][::DECIMATE]]
        self.ups, self.cut = ups, cut

    def _exact(self, **changes):
        b = Belt(**{**self.belt.__dict__, **changes})
        return belt_run(b, self.schedule, self.t_end, quantise=False)[1]

    def _level_columns(self, which, idx_sets):
        """d v / d(level before step or coast i), on that step's or coast's samples only: the
        start speed each fit leaves free.
        """
        cols = []
        for j, i in enumerate(which):
            h = 1e-4
            up, down = list(self.schedule), list(self.schedule)
            up[i - 1] = (up[i - 1][0], up[i - 1][1] + h)
            down[i - 1] = (down[i - 1][0], down[i - 1][1] - h)
            d = (belt_run(self.belt, up, self.t_end, quantise=False)[1]
                 - belt_run(self.belt, down, self.t_end, quantise=False)[1]) / (2 * h)
            cols.append(np.concatenate([d[ix] if jj == j else np.zeros(ix.size)
                                        for jj, ix in enumerate(idx_sets)]))
        return cols

    def _noise(self, idx_sets, tau, sigma):
        q = self.belt.count / (self.belt.window * DT)
        blocks = []
        for ix in idx_sets:
            c = np.zeros(ix.size)
            c[0], c[1] = 2 * q * q / 12, -q * q / 12
            blocks.append(toeplitz(c) + ou_covariance(ix.size, DECIMATE * DT, tau, sigma))
        return block_diag(*blocks)

    def drive_sd(self, tau=0.0, sigma=0.0):
        """Standard deviations of (a, b, measured delay) the noise allows."""
        lag = self.belt.measured_delay(DT) - self.belt.delay

        def model(th):
            v = self._exact(a=th[0], b=th[1], delay=th[2] - lag)
            return np.concatenate([v[ix] for ix in self.drive_idx])
        cov = predicted_covariance(
            model, [self.belt.a, self.belt.b, self.belt.measured_delay(DT)],
            self._noise(self.drive_idx, tau, sigma), self._level_columns(self.ups,
                                                                          self.drive_idx))
        return np.sqrt(np.diag(cov))[:3]

    def coast_sd(self, tau=0.0, sigma=0.0):
        """Standard deviations of (B/J, F/B) the noise allows."""
        def model(th):
            return self._exact(c=th[0], k=th[1])[self.coast_idx[0]]
        cov = predicted_covariance(model, [self.belt.c, self.belt.k],
                                   self._noise(self.coast_idx, tau, sigma),
                                   self._level_columns([self.cut], self.coast_idx))
        return np.sqrt(np.diag(cov))[:2]

    def truth(self):
        return np.array([self.belt.a, self.belt.b, self.belt.measured_delay(DT), self.belt.c,
                         self.belt.k])


NAMES = ('pole a', 'gain b', 'delay T_d', 'B/J', 'F/B')


def check(found, truth, sd, names=NAMES):
    """Every estimate within Z_TEST standard deviations of the truth."""
    bad = [f'{n}: {f:.6g} against {t:.6g}, error {f - t:+.3g} = {(f - t) / s:+.1f} sd '
           f'(tolerance {Z_TEST:g} sd = {Z_TEST * s:.3g})'
           for n, f, t, s in zip(names, found, truth, sd) if not abs(f - t) <= Z_TEST * s]
    assert not bad, '; '.join(bad)


def identify(case, v):
    d, c = fit_drive(case.t, v, case.u), fit_coast(case.t, v, case.u)
    return np.array([d.a, d.b, d.delay, c.b_over_j, c.f_over_b]), d, c


@pytest.fixture(scope='module')
def default_case():
    return Case()


@pytest.fixture(scope='module')
def default_sd(default_case):
    return np.r_[default_case.drive_sd(), default_case.coast_sd()]


def test_quantised_encoder_speed_identified_within_its_noise(default_case, default_sd):
    """The rig's case (encoder quantisation, no other noise): every parameter within 4 sd,
    and those sd as small as the docs say the identification is (0.1 % for B/J and F/B, 0.25 %
    for a and b, 1 ms of delay), so that a regression beyond them is caught.
    """
    found, d, c = identify(default_case, default_case.v)
    truth = default_case.truth()
    print('error / sd:', np.round((found - truth) / default_sd, 2), 'sd:', default_sd)
    check(found, truth, default_sd)
    assert np.all(Z_TEST * default_sd / truth < [0.0025, 0.0025, 0.02, 0.001, 0.001])
    assert len(d.steps) == 3 and len(c.coasts) == 1
    # each 95 % interval is finite and within 3x of the predicted one
    ci = np.array([d.a_ci, d.b_ci, d.delay_ci, c.b_over_j_ci, c.f_over_b_ci])
    assert np.all((ci > 0.0) & (ci < 3 * 1.96 * default_sd)), ci / (1.96 * default_sd)


@pytest.mark.parametrize('tau', [0.0, 0.2])
def test_noisy_speed_identified_within_its_noise(default_case, tau):
    """5 mm/s of white or slow (tau = 0.2 s) noise on the encoder speed."""
    v = default_case.v + ou_noise(np.random.default_rng(11), default_case.t.size, DT, tau, 0.005)
    sd = np.r_[default_case.drive_sd(tau, 0.005), default_case.coast_sd(tau, 0.005)]
    found, _, _ = identify(default_case, v)
    check(found, default_case.truth(), sd)


def test_a_wrong_drive_fit_fails_the_check(default_case, default_sd, monkeypatch):
    """A drive fit whose model pole is 0.5 % off (test-only) is caught."""
    right = tf._step_response
    monkeypatch.setattr(tf, '_step_response',
                        lambda p, steps, t: right((p[0] * 1.005, *p[1:]), steps, t))
    found, _, _ = identify(default_case, default_case.v)
    with pytest.raises(AssertionError, match='pole a'):
        check(found, default_case.truth(), default_sd)


def test_a_wrong_coast_fit_fails_the_check(default_case, default_sd, monkeypatch):
    """A coast fit whose model decays 0.3 % too fast (test-only) is caught."""
    right = tf._coast_model
    monkeypatch.setattr(tf, '_coast_model',
                        lambda lnv0, c, k, coasts: right(lnv0, c * 1.003, k, coasts))
    found, _, _ = identify(default_case, default_case.v)
    with pytest.raises(AssertionError, match='B/J'):
        check(found, default_case.truth(), default_sd)


@pytest.mark.parametrize('f_over_b', [0.270 / 0.158, 0.270 * 0.0508])
def test_whichever_friction_reading_is_configured_is_recovered(f_over_b):
    """The paper's F/B read as F/J = 0.270 m/s^2 (F/B = 1.709 m/s) and as 0.270 rad/s of a
    2 in roller (0.0137 m/s); the default reading (0.270 m/s) is the case above.
    """
    case = Case(Belt(k=f_over_b))
    found, _, c = identify(case, case.v)
    check(found[3:], case.truth()[3:], case.coast_sd(), NAMES[3:])


def test_other_belt_parameters_are_recovered_too():
    """Not tuned to the defaults: another gain, pole, delay and friction."""
    case = Case(Belt(a=6.0, b=3.1, delay=0.02, c=0.25, k=0.5),
                [(0.0, 1.0), (1.0, 2.0), (3.0, 4.0), (5.0, 0.0)])
    found, _, _ = identify(case, case.v)
    check(found, case.truth(), np.r_[case.drive_sd(), case.coast_sd()])


def test_segments_are_classified():
    t = np.arange(8) * 1.0
    u = np.array([0, 0, 3, 3, 2.5, 0, 0, 1.0])
    assert [(s.start, s.kind) for s in segments(t, u)] == [
        (0.0, 'hold'), (2.0, 'up'), (4.0, 'down'), (5.0, 'coast'), (7.0, 'up')]


def test_no_step_or_no_coast_is_a_clear_error():
    t = np.arange(1000) * DT
    with pytest.raises(ValueError, match='no step up'):
        fit_drive(t, np.zeros_like(t), np.zeros_like(t))
    with pytest.raises(ValueError, match='no coast-down'):
        fit_coast(t, np.zeros_like(t), np.where(t > 0.5, 2.0, 0.0))


@pytest.mark.parametrize('name', ['sysid_treadmill', 'sysid_treadmill_short'])
def test_experiment_driver_profile_follows_the_predicted_belt_speed(name):
    """The driver keeps the car level with the belt: its profile is within 5 mm/s of the
    belt speed the model predicts for the file's schedule with the installed rig.yaml.
    """
    doc = yaml.safe_load((EXPERIMENTS / f'{name}.yaml').read_text())
    exc = doc['nodes']['excitation']['params']
    drv = doc['nodes']['driver']['params']
    s = Schedule(exc['signal.times'], exc['signal.values'], 0.0)
    t = np.arange(int(round(doc['duration'] / DT)) + 1) * DT
    v = simulate_belt([s(x) for x in t], DT, belt_params_of(installed_rig_params()))
    profile = np.interp(t, drv['profile.times'], drv['profile.speeds'])
    assert np.max(np.abs(profile - v)) < 0.005
    # the car drifts less than 10 cm at any time of the run (belt travel: tens of metres; the
    # car has about 1 m to either belt end)
    assert np.max(np.abs(np.cumsum(profile - v) * DT)) < 0.10


def test_driver_profile_is_within_its_tolerance():
    t = np.linspace(0.0, 10.0, 1001)
    v = 1.0 - np.exp(-t)
    tp, vp = driver_profile(t, v, tol=0.002)
    assert np.max(np.abs(np.interp(t, tp, vp) - v)) <= 0.002 + 1e-12
    assert len(tp) < 100


def test_15_mph_is_reached_at_the_drive_limit():
    """The paper's top speed, 15 mph, with Eq. 2 at the drive limit: rig default, rig.yaml and
    the treadmill regulator's configuration agree on the limit, and it reaches 6.7056 m/s.
    """
    root = Path(__file__).resolve().parents[2]
    rig = yaml.safe_load((root / 'irs_vehicle_sim/config/rig.yaml').read_text())
    reg = yaml.safe_load((root / 'irs_treadmill/config/treadmill.yaml').read_text())
    u_rig = rig['vehicle_sim']['ros__parameters']['belt']['u_max']
    u_reg = reg['treadmill_regulator']['ros__parameters']['regulator']['u_max']
    assert u_rig == u_reg == BeltParams().u_max
    p = BeltParams()
    assert p.v_top == pytest.approx(15 * MPH)
    assert p.u_max * p.dc_gain >= p.v_top          # Eq. 2 in steady state
    belt = TreadmillBelt(p)
    for _ in range(5000):                          # 5 s at the limit voltage
        belt.step(p.u_max, DT)
    assert belt.speed == pytest.approx(15 * MPH, abs=1e-9)
    assert math.isclose(belt.measured_speed, 15 * MPH, abs_tol=p.speed_resolution(DT))
