"""Sweep heat maps: colour scale from the points that did not diverge, diverged points crossed
out, 0/1 metrics in two colours, a one-line title (matplotlib objects read back, no pixels).
"""
import numpy as np
import pytest


def _rows(ise, stable):
    """One row per cell of a 3 x 2 grid (x = gain, y = delay) from two 2 x 3 lists."""
    rows = []
    for j, delay in enumerate((0.0, 0.05)):
        for i, gain in enumerate((0.5, 1.0, 2.0)):
            rows.append({'gain': gain, 'delay': delay, 'seed': 0, 'error': '',
                         'ise': ise[j][i], 'stable': stable[j][i], 'off_belt': 0.0})
    return rows


@pytest.fixture
def figures(monkeypatch):
    """The figures heatmap() makes, kept open to be read back."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    made = []
    monkeypatch.setattr(plt, 'close', lambda fig: made.append(fig))
    return made


def test_diverged_points_do_not_set_the_colour_scale(tmp_path, figures):
    from irs_studies.sweep.plots import heatmap
    from irs_studies.sweep.sweep_file import PlotModel
    rows = _rows([[0.005, 0.01, 0.02], [0.03, 0.04, 1e6]], [[1, 1, 1], [1, 1, 0]])
    plot = PlotModel(kind='heatmap', x='gain', y='delay', metric='ise', log=True)
    heatmap(rows, plot, {'ise': 'm^2 s', 'stable': '0/1'}, tmp_path / 'h.png', 'sw: ise')
    fig = figures[0]
    mesh = fig.axes[0].collections[0]
    assert mesh.norm.vmin == pytest.approx(0.005)
    assert 0.04 <= mesh.norm.vmax <= 0.05          # a decade at least, never up to 1e6
    assert tuple(mesh.cmap.get_over()[:3]) != tuple(mesh.cmap(1.0)[:3])   # beyond: marked
    crosses = [ln for ln in fig.axes[0].get_lines() if len(ln.get_xdata()) == 2]
    assert len(crosses) == 2                                    # one X over the diverged cell
    assert all(abs(np.mean(ln.get_xdata()) - 2) < 1e-9 for ln in crosses)
    assert fig.get_suptitle() == 'sw: ise' and 'crossed: diverged' in fig._supxlabel.get_text()


def test_binary_metric_in_two_colours(tmp_path, figures):
    from irs_studies.sweep.plots import heatmap
    from irs_studies.sweep.sweep_file import PlotModel
    rows = _rows([[0.0] * 3] * 2, [[1, 1, 0], [1, 0, 0]])
    plot = PlotModel(kind='boundary', x='gain', y='delay', metric='stable', threshold=0.5)
    heatmap(rows, plot, {'stable': '0/1'}, tmp_path / 's.png', 'sw: stable')
    mesh = figures[0].axes[0].collections[0]
    assert mesh.cmap.N == 2 and list(mesh.norm.boundaries) == [-0.5, 0.5, 1.5]
    colours = {tuple(c) for c in mesh.get_facecolors()}
    assert len(colours) == 2
    bar = figures[0].axes[-1]
    assert [t.get_text() for t in bar.get_yticklabels()] == ['0 (no)', '1 (yes)']


def test_the_summary_tells_refused_points_from_points_not_run_and_from_a_nan_metric():
    from types import SimpleNamespace
    from irs_studies.sweep.plots import summary_markdown
    rows = _rows([[0.005, float('nan'), 0.02], [0.03, 0.04, 0.05]], [[1, 1, 1], [1, 1, 1]])
    rows[2]['error'] = 'RstDesignError: not designable'     # gain 2.0, delay 0.0: refused
    rows[2]['ise'] = float('nan')
    del rows[4]                                              # gain 1.0, delay 0.05: not run
    sweep = SimpleNamespace(name='sw', description='a test sweep', plots=[], metrics=['ise'],
                            axes=[SimpleNamespace(name='gain'), SimpleNamespace(name='delay')])
    text = summary_markdown(rows, sweep, {'ise': 'm^2 s'})
    table = [ln for ln in text.splitlines() if ln.startswith('| 0')]
    assert table == ['| 0 | 0.005 | nan | refused |', '| 0.05 | 0.03 |  | 0.05 |']
    assert '5 points, 1 refused by the cores' in text
    assert '- RstDesignError: not designable' in text
