"""The servo's first-order fit against the amplitude: the paper's 4.6 Hz at 5-8 deg of steer.

Stepped sines on the actuator core (radio frame, dead zone, minimum drive, slew limit, linkage,
play), fitted with a first order and a dead time that know nothing of the model.  Two fits:
:mod:`irs_vehicle_sim.servo_fit` (least squares on the complex log ratio) and, here, an
independent one (``scipy.optimize.curve_fit`` on magnitude and phase of a response taken by FFT
over whole periods).
"""
import math

import numpy as np
import pytest
from scipy.optimize import curve_fit

from irs_vehicle_sim import servo_fit as sf
from irs_vehicle_sim.actuator import PRESETS, ActuatorParams, SteeringActuator

DT = 1e-3
ANCHOR_AMPLITUDES = (5.0, 6.0, 7.3, 8.0)


def fft_response(params, amplitude, freqs, seed=0):
    """Response at ``freqs`` by the FFT bin of 4 whole periods after 2 (not servo_fit's code)."""
    out = []
    for f in freqs:
        act = SteeringActuator(params, seed=seed)
        n_per = int(round(1.0 / (f * DT)))
        k = np.arange(6 * n_per)
        u = amplitude * np.sin(2 * np.pi * f * k * DT)
        y = np.array([act.step(c, DT) for c in u])
        # y[k] is the angle at t_{k+1}: shift the command by one sample to compare like times
        seg_u, seg_y = u[2 * n_per + 1:] , y[2 * n_per:-1]
        U, Y = np.fft.rfft(seg_u), np.fft.rfft(seg_y)
        b = int(np.argmax(np.abs(U)))
        out.append(Y[b] / U[b])
    return np.array(out)


def curve_fit_pole(freqs, h):
    """Pole [Hz] of K p/(jw + p) e^{-jwT} by curve_fit on stacked log-magnitude and phase."""
    w = 2 * np.pi * np.asarray(freqs)
    data = np.concatenate([np.log(np.abs(h)), np.unwrap(np.angle(h))])

    def model(_, logk, pole_hz, delay):
        g = np.exp(logk) * (2 * np.pi * pole_hz) / (1j * w + 2 * np.pi * pole_hz) \
            * np.exp(-1j * w * delay)
        return np.concatenate([np.log(np.abs(g)), np.unwrap(np.angle(g))])

    (_, pole, _), _ = curve_fit(model, None, data, p0=[0.0, 3.0, 0.02])
    return pole


def test_fit_recovers_a_known_first_order_and_delay():
    f = np.array(sf.FREQUENCIES_HZ)
    w = 2 * np.pi * f
    h = 0.97 * 30.0 / (1j * w + 30.0) * np.exp(-1j * w * 0.019)
    fit = sf.fit_first_order(f, h)
    assert fit.pole_hz == pytest.approx(30.0 / (2 * np.pi), rel=1e-9)
    assert fit.delay == pytest.approx(0.019, rel=1e-9) and fit.gain == pytest.approx(0.97)
    assert curve_fit_pole(f, h) == pytest.approx(30.0 / (2 * np.pi), rel=1e-6)


def test_first_order_fit_is_the_papers_4p6_hz_at_5_to_8_deg():
    rows = sf.amplitude_table(amplitudes_deg=ANCHOR_AMPLITUDES)
    poles = [fit.pole_hz for _, fit in rows]
    print('poles at 5, 6, 7.3, 8 deg [Hz]:', np.round(poles, 3))
    for (a, fit) in rows:
        assert abs(fit.pole_hz - sf.ANCHOR_HZ) <= sf.ANCHOR_TOL_HZ, (a, fit)
        assert 0.012 < fit.delay < 0.025 and 0.98 < fit.gain < 1.01
    # the independent fit at Figure 10's 7.3 deg agrees, and is in the band too
    f = np.geomspace(0.5, 10.0, 10)
    own = curve_fit_pole(f, fft_response(ActuatorParams(), math.radians(7.3), f))
    assert abs(own - sf.ANCHOR_HZ) <= sf.ANCHOR_TOL_HZ
    assert own == pytest.approx(poles[2], rel=0.03)


def test_amplitude_dependence_of_fig6_kept():
    rows = dict(sf.amplitude_table(amplitudes_deg=(1.0, 15.0)))
    small, full = rows[1.0].pole_hz, rows[15.0].pole_hz
    assert 6.0 <= small <= 7.5          # the top of the paper's 1-7 Hz, small-signal
    assert 1.0 <= full <= 3.0            # slew limited at full command
    assert full < sf.ANCHOR_HZ - sf.ANCHOR_TOL_HZ < sf.ANCHOR_HZ + sf.ANCHOR_TOL_HZ < small


def test_the_earlier_calibration_misses_the_anchor():
    old = ActuatorParams(**PRESETS['servo_7hz'])
    rows = sf.amplitude_table(old, (5.0, 8.0))
    assert all(fit.pole_hz < sf.ANCHOR_HZ - sf.ANCHOR_TOL_HZ for _, fit in rows)


def test_cli_prints_the_table(capsys):
    assert sf.main(['--amplitudes', '7.3']) == 0
    out = capsys.readouterr().out
    assert out.startswith('| amplitude [deg] | pole [Hz]') and 'anchor 4.6 +- 0.3 Hz: yes' in out
