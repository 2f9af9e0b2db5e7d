"""What ``experiment run --offline`` leaves: a run folder of its own, as a graph run has.

    <runs>/<name>-offline-<YYYYmmdd-HHMMSS>[-n]/
        traces.parquet   every array of the offline loop, one column each, by time step
        metrics.json     a few numbers of the run (below), the experiment and the duration
        plots/*.png      the per-run plots (:func:`irs_bag.plots.plot_series`) of the series a
                         graph run's bag gives, drawn from the offline arrays

The ``-offline`` in the name keeps an offline run apart from the graph's runs of the same
experiment. Columns: outputs have N + 1 samples, commands N (the last row holds NaN); an
``(N, k)`` array is ``k`` columns ``<name>_0 .. <name>_<k-1>``. Metrics of the lateral loop:
``ise`` = sum((y_s - reference)^2) dt [m^2 s], ``max_abs_error`` [m], ``final_y_s`` [m],
``peak_steer_cmd`` [rad]; of the torque car's loop: ``final_x_belt`` [m], ``final_u`` [m/s],
``peak_yaw_rate`` [rad/s]; both: ``samples``, ``fault`` (the car left the belt).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

#: offline array -> plot label of irs_bag.plots.SERIES (the same quantity as the bag's topic)
PLOT_LABELS = {
    'y_s': 'y_s ground truth', 'y_measured': 'y_s sensed', 'reference': 'reference',
    'steer_cmd': 'command front', 'front_steer': 'command front',
    'steer_achieved': 'servo achieved front', 'belt_speed': 'belt speed (encoder)',
    'drive_voltage': 'drive voltage', 'x': 'x ground truth', 'y': 'y ground truth',
}


def columns(res: dict) -> dict:
    """The loop's arrays as equal-length 1-D columns (module docstring)."""
    n = len(res['time'])
    out = {}
    for key, value in res.items():
        a = np.asarray(value)
        a = a.astype(float) if a.dtype == bool else a
        a = a.reshape(len(a), -1)
        pad = np.full((n - len(a), a.shape[1]), np.nan)
        a = np.vstack([a, pad]) if len(a) < n else a[:n]
        if a.shape[1] == 1:
            out[key] = a[:, 0]
        else:
            out.update({f'{key}_{i}': a[:, i] for i in range(a.shape[1])})
    return out


def metrics(res: dict, dt: float) -> dict:
    """The numbers of the module docstring (floats; NaN where a series is missing)."""
    def finite(x):
        x = np.asarray(x, dtype=float)
        return x[np.isfinite(x)]
    m = {'samples': int(len(res['time'])), 'fault': bool(np.any(res.get('fault', False)))}
    if 'y_s' in res:
        err = finite(np.asarray(res['y_s']) - np.asarray(res['reference']))
        steer = finite(res.get('steer_cmd', []))
        m.update(ise=float(np.sum(err ** 2) * dt), max_abs_error=float(np.max(np.abs(err)))
                 if len(err) else math.nan, final_y_s=float(res['y_s'][-1]),
                 peak_steer_cmd=float(np.max(np.abs(steer))) if len(steer) else math.nan)
    if 'x_belt' in res:
        yaw = finite(res['yaw_rate'])
        m.update(final_x_belt=float(res['x_belt'][-1]), final_u=float(res['u'][-1]),
                 peak_yaw_rate=float(np.max(np.abs(yaw))) if len(yaw) else math.nan)
    return m


def write_run(res: dict, exp, run_dir: Path, plots: bool = True, log=print) -> list[Path]:
    """Traces, metrics and (``plots``) the plots of the offline run ``res`` of ``exp`` into
    ``run_dir``; the written paths.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq
    run_dir.mkdir(parents=True, exist_ok=True)      # made by make_run_dir, or here
    written = [run_dir / 'traces.parquet', run_dir / 'metrics.json']
    cols = columns(res)
    pq.write_table(pa.table(cols), written[0])
    t = np.asarray(res['time'])
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.0
    numbers = {k: None if isinstance(v, float) and not math.isfinite(v) else v
               for k, v in metrics(res, dt).items()}
    doc = {'experiment': exp.name, 'experiment_file': str(exp.path or ''), 'mode': 'offline',
           'duration': exp.duration, 'metrics': numbers}
    written[1].write_text(json.dumps(doc, indent=1) + '\n')
    if plots:
        from irs_bag.plots import plot_series
        from irs_bag.run_info import run_info_from_metadata

        from ..experiment import node_parameters
        data = {PLOT_LABELS[k]: (t[:len(v)], np.asarray(v, dtype=float))
                for k, v in res.items() if k in PLOT_LABELS and np.ndim(v) == 1}
        params = {n.name: node_parameters(n) for n in exp.nodes}    # the graph's, as its bag's
        info = run_info_from_metadata(run_dir.name, {
            'experiment_name': exp.name, 'node_parameters': json.dumps(params, default=str)})
        written += plot_series(data, run_dir / 'plots', info)
    for path in written:
        log(f'[experiment] wrote {path}')
    return written
