"""What every identification command shares: running an experiment for its bag, saving a figure."""
from __future__ import annotations

from pathlib import Path

__all__ = ['run_experiment', 'save_figure']


def run_experiment(name_or_path, runs_dir: Path, deployment: str = 'default') -> Path:
    """Run one experiment through the graph (lock-step), placed in processes as ``deployment``
    says (:meth:`~irs_bringup.experiment.Experiment.deployed`); its bag directory.

    :class:`~irs_common.cli.RunFailed` (with the runner's reason) when the run did not
    complete; :class:`~irs_common.cli.Interrupted` when a signal stopped it.
    """
    from irs_common.cli import Interrupted, RunFailed
    from irs_bringup.experiment import load_experiment
    from irs_bringup.experiment_runner import ExperimentRunner

    exp = load_experiment(str(name_or_path)).deployed(deployment)
    res = ExperimentRunner(exp, runs_dir=Path(runs_dir), progress=False).run()
    if res.interrupted:
        raise Interrupted(res.interrupted)
    if not res.completed or res.bag_dir is None:
        raise RunFailed(f'{name_or_path} did not complete: {res.message}')
    return Path(res.bag_dir)


def save_figure(fig, path, dpi: int = 100) -> Path:
    """Lay out ``fig``, write it to ``path`` (parents created), close it; the path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
