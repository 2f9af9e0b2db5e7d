"""design_cli prints both designs and writes plots."""
from irs_control.design_cli import format_poly, main


def test_cli_prints_designs(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    for key in ('with_actuator', 'without_actuator', 'R   =', 'S   =', 'T   =', 'Ao  =',
                'B+  =', 'B-  =', 'closed-loop poles'):
        assert key in out
    assert '2580.48' in out  # R(0) of the design with the actuator
    assert out.count("design check: closed loop on plant 'identified' stable with the 17 ms "
                     'delay') == 2 and 'delay margin +' in out


def test_cli_design_check_refuses_on_irs_2wd(capsys):
    assert main(['--check-plant', 'irs_2wd']) == 0
    out = capsys.readouterr().out
    assert out.count("design check (REFUSED): closed loop on plant 'irs_2wd' UNSTABLE") == 2


def test_cli_reconstruction_and_plots(tmp_path, capsys):
    assert main(['--reconstruction', '--plots', str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert '[chosen]' in out
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ['bode_with_actuator.png', 'bode_without_actuator.png',
                     'step_with_actuator.png', 'step_without_actuator.png']
    assert all(p.stat().st_size > 1000 for p in tmp_path.iterdir())


def test_format_poly():
    assert format_poly([1, -2, 3]) == '1 s^2 - 2 s + 3'
