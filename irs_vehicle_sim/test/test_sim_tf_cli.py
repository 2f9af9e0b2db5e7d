"""Tests of the transfer-function CLI (irs_vehicle_sim.tf_cli)."""
import re

import numpy as np
import pytest

from irs_models.presets import get_preset
from irs_vehicle_sim.tf_cli import main


def _roots_line(text, title_fragment, key):
    block = text.split(title_fragment, 1)[1]
    line = next(ln for ln in block.splitlines() if ln.strip().startswith(key))
    inner = line.split('=', 1)[1].strip().strip('[]')
    return np.array([complex(v.strip()) for v in inner.split(',') if v.strip()])


def test_prints_gain_poles_zeros_with_and_without_actuator(capsys):
    assert main(['--preset', 'pontiac_6000ste']) == 0
    out = capsys.readouterr().out
    pre = get_preset('pontiac_6000ste')
    z, p, k = pre.zpk()
    poles0 = _roots_line(out, 'vehicle only:', 'poles')
    zeros0 = _roots_line(out, 'vehicle only:', 'zeros')
    np.testing.assert_allclose(np.sort_complex(poles0), np.sort_complex(p), atol=5e-3)
    np.testing.assert_allclose(np.sort_complex(zeros0), np.sort_complex(z), atol=5e-3)
    poles1 = _roots_line(out, 'Hz actuator lag', 'poles')
    assert len(poles1) == 5 and np.min(np.abs(poles1 + 2 * np.pi * 4.6)) < 5e-2
    m = re.search(r'high-frequency gain k = ([0-9.eE+-]+)', out)
    assert float(m.group(1)) == pytest.approx(k, rel=1e-4)


def test_speed_ds_axle_options(capsys):
    assert (
        main(
            ['--preset', 'irs_2wd', '--speed', '2.0', '--ds', '0.1', '--axle', 'rear',
             '--actuator-hz', '0']
        )
        == 0
    )
    cap = capsys.readouterr()
    assert 'V = 2 m/s, d_s = 0.1 m, input: rear steer' in cap.out
    assert 'no rear-steer actuator' in cap.err
    assert 'with 4.6 Hz actuator lag' not in cap.out and 'with 0 Hz' not in cap.out
    z, _, _ = get_preset('irs_2wd').zpk(speed=2.0, ds=0.1, axle='rear')
    zeros = _roots_line(cap.out, 'vehicle only:', 'zeros')
    np.testing.assert_allclose(np.sort_complex(zeros), np.sort_complex(z), rtol=1e-3)


def test_unknown_preset_clean_error(capsys):
    assert main(['--preset', 'batmobile']) == 2
    cap = capsys.readouterr()
    assert "unknown preset 'batmobile'" in cap.err
    for name in ('irs_2wd', 'irs_4ws', 'irs_iwt', 'ford_taurus_sho'):
        assert name in cap.err
    assert 'Traceback' not in cap.err + cap.out


def test_bad_speed_clean_error(capsys):
    assert main(['--preset', 'irs_4ws', '--speed', '-1']) == 2
    assert 'speed' in capsys.readouterr().err


def test_plots_saved_as_png(tmp_path, capsys):
    assert main(['--preset', 'irs_4ws', '--plots', str(tmp_path / 'plots')]) == 0
    for f in ('bode.png', 'step.png'):
        path = tmp_path / 'plots' / f
        assert path.is_file()
        data = path.read_bytes()
        assert len(data) > 1000 and data[:8] == b'\x89PNG\r\n\x1a\n'


def test_identified(capsys):
    assert main(['--preset', 'irs_4ws', '--identified']) == 0
    cap = capsys.readouterr()
    zeros = _roots_line(cap.out, 'Identified plant', 'zeros')
    poles = _roots_line(cap.out, 'Identified plant', 'poles')
    np.testing.assert_allclose(np.sort(zeros.real), [-4.8, -2.4], atol=1e-6)
    np.testing.assert_allclose(np.sort(poles.real), [-29, -20, -8, 0, 0], atol=1e-6)
