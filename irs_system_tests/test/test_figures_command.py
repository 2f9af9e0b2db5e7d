"""``figures`` (what ``make figures`` runs) with a real part: the graph run, the identification
from its bag, the paper's figure and ``figures.json``. The treadmill part runs the 8.5 s
``sysid_treadmill_short`` here instead of its 56 s ``sysid_treadmill`` (the only change), so
that the command is smoke-tested end to end in the suite.
"""
import json
import math

from irs_studies import paper_figures
from irs_sysid import common, treadmill_cli


def test_figures_treadmill_part_end_to_end(tmp_path, monkeypatch, capsys):
    ran = []

    def short_run(name, runs_dir, **kw):
        ran.append(name)
        return common.run_experiment('sysid_treadmill_short', runs_dir, **kw)
    monkeypatch.setattr(treadmill_cli, 'run_experiment', short_run)
    monkeypatch.chdir(tmp_path)
    assert paper_figures.main(['--runs-dir', 'fig', '--only', 'treadmill']) == 0
    assert ran == ['sysid_treadmill']
    out = capsys.readouterr().out
    assert 'numbers: fig/figures.json; figures: fig/img' in out, out
    numbers = json.loads((tmp_path / 'fig' / 'figures.json').read_text())
    assert set(numbers) == {'treadmill'}
    got = numbers['treadmill']
    print(json.dumps(got, indent=1))
    png = tmp_path / 'fig' / 'img' / 'figure5_treadmill.png'
    assert png.stat().st_size > 20_000
    for key in ('pole_a', 'gain_b', 'delay', 'b_over_j', 'f_over_b'):
        value, ci, configured = (got[f'treadmill_{key}{s}'] for s in ('', '_ci95', '_configured'))
        assert math.isfinite(value) and ci > 0, (key, value, ci)
        assert abs(value - configured) <= max(3 * ci, 0.05 * abs(configured)), (key, got)
