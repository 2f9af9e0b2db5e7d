"""The board emulator's command line: rig parameters from files and -p, refused in one line."""
import pytest

from irs_hardware.emulator.board_main import board_from_args, main


def test_overrides_take_either_assignment_and_come_after_the_files(tmp_path):
    f = tmp_path / 'rig.yaml'
    f.write_text('vehicle_sim:\n  ros__parameters:\n    clock_mode: lockstep\n    x0: 0.2\n'
                 '    u0: 1.0\n')
    board = board_from_args(['--link', str(tmp_path / 'l'), '--rig-params', str(f),
                             '-p', 'plant:=two_track', '-p', 'u0=1.3'])
    cfg = board.sim.config
    assert cfg.plant == 'two_track' and cfg.u0 == 1.3 and cfg.x0 == 0.2


@pytest.mark.parametrize('item,says', [
    ('plnt:=two_track', "'plnt' is not a parameter of the rig (did you mean plant?)"),
    ('clock_mode=lockstep', "'clock_mode' is not a parameter of the rig"),
    ('plant', 'expected key=value (or key:=value)'),
    ('=3', 'expected key=value (or key:=value)'),
])
def test_a_bad_override_is_one_line_naming_it(tmp_path, capsys, item, says):
    assert main(['--link', str(tmp_path / 'l'), '-p', item]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'board_emulator: -p {item!r}: ') and err.count('\n') == 1, err
    assert says in err, err
    assert not (tmp_path / 'l').exists()
