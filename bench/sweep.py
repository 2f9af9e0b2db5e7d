"""Benchmark of the sweep tool: points/s with 1 and 2 Dask workers, offline steps/s.

    ./irs exec python bench/sweep.py                  # 12 points of the actuator x speed sweep
    ./irs exec python bench/sweep.py --points 24 --duration 5

Parts (results printed and written to ``bench/results/sweep-<time>.json``):

- ``sweep``: the first ``--points`` points of ``config/sweeps/actuator_speed.yaml`` (with its
  duration or ``--duration``), run in this process (serial) and on a LocalCluster of 1 and of 2
  worker processes, each through ``run_sweep`` as the ``sweep`` command runs it (``--serial``
  for the first; results written as Parquet parts and merged). The cluster's start-up and the
  first imports are measured apart (one short point with every metric in each worker, and one
  short sweep in this process, before the clock starts): points/s is the steady rate, with the
  scenario scattered once. The overhead per point is what a point takes beyond its closed loop
  (``ClosedLoop.run`` of the same points, timed alone): serially the design, the rig's set-up,
  the metrics and the results' files; on the cluster a worker's seconds per point (workers x
  seconds / points) less the loop, so Dask's share is the cluster row's overhead less the serial
  one.
- ``offline``: steps/s of the offline closed loop (:class:`irs_bringup.offline_twin.lateral_loop
  .ClosedLoop`, every core of the graph, Figure 10 scenario) against the linear plant alone:
  the identified plant of Eq. 6 stepped by our core (:class:`irs_models.identified
  .IdentifiedPlant`), by ``scipy.signal.dlsim``, and ``--systems`` of them at once by
  :class:`irs_models.batch_lti.BatchLti` (system-steps/s), with the largest difference.

Speed is measured here, never asserted in tests; on a shared machine compare ratios within one
run (the load average before and after is in the JSON).
"""
import argparse
import datetime
import itertools
import os
from pathlib import Path
import sys
import tempfile
import time

HERE = Path(__file__).resolve().parent


def _prep(points: int, duration: float | None):
    from irs_studies.sweep.runner import iter_points, prepare
    from irs_studies.sweep.sweep_file import load_sweep
    sweep, path = load_sweep('actuator_speed')
    prep = prepare(sweep, path)
    if duration:
        prep.duration = duration
    # the sweep's first ``points`` points: those run_sweep(limit=points) runs on the cluster
    return prep, list(itertools.islice(iter_points(prep.sweep), points))


def _loop_seconds(prep, chosen) -> float:
    """Seconds the points' closed loops take alone (``ClosedLoop.run``; a refused point none)."""
    from irs_bringup.offline_twin.lateral_loop import ClosedLoop
    from irs_studies.sweep.point import REFUSALS, apply_overrides
    total = 0.0
    for p in chosen:
        try:
            loop = ClosedLoop(apply_overrides(prep.cfg, p['overrides']))
        except REFUSALS:
            continue
        t0 = time.perf_counter()
        loop.run(prep.duration)
        total += time.perf_counter() - t0
    return total


def sweep_rates(points: int, duration: float | None) -> list:
    from irs_studies.sweep.point import run_point
    from irs_studies.sweep.runner import make_client, run_sweep
    prep, chosen = _prep(points, duration)
    metrics = list(prep.sweep.metrics)
    quiet = dict(log=lambda s: None)
    rows = []
    # a short point first, here as in each cluster worker, with every metric: the first imports
    # (python-control, the Parquet writer) are not the rate
    full = prep.duration
    prep.duration = 0.01
    with tempfile.TemporaryDirectory() as d:
        run_sweep(prep, Path(d), serial=True, limit=1, **quiet)
    prep.duration = full
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        run_sweep(prep, Path(d), serial=True, limit=len(chosen), **quiet)
        dt = time.perf_counter() - t0
    loop_s = _loop_seconds(prep, chosen) / len(chosen)
    rows.append({'name': 'sweep serial (this process)', 'workers': 0, 'points': len(chosen),
                 'seconds': dt, 'points_per_s': len(chosen) / dt,
                 'loop_s_per_point': loop_s, 'overhead_s_per_point': dt / len(chosen) - loop_s})
    print(f"{rows[-1]['name']:44s} {rows[-1]['points_per_s']:8.3f} points/s "
          f'({1000 * dt / len(chosen):.0f} ms per point: the closed loop {1000 * loop_s:.0f} ms, '
          f"the rest {1000 * rows[-1]['overhead_s_per_point']:.0f} ms)", flush=True)
    for workers in (1, 2):
        t0 = time.perf_counter()
        client = make_client(workers)
        warm = client.map(run_point, [prep.cfg] * workers, [0.01] * workers,
                          chosen[:workers], [metrics] * workers, pure=False)
        client.gather(warm)
        start = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            run_sweep(prep, Path(d), client=client, limit=len(chosen), **quiet)
            dt = time.perf_counter() - t0
        client.close()       # closes its local cluster too
        per_worker = dt * workers / len(chosen)      # a worker's seconds per point
        rows.append({'name': f'sweep on a LocalCluster, {workers} worker(s)', 'workers': workers,
                     'points': len(chosen), 'seconds': dt,
                     'points_per_s': len(chosen) / dt, 'startup_s': start,
                     'overhead_s_per_point': per_worker - loop_s})
        print(f"{rows[-1]['name']:44s} {rows[-1]['points_per_s']:8.3f} points/s "
              f'({1000 * per_worker:.0f} ms per point and worker, the rest beyond the loop '
              f"{1000 * rows[-1]['overhead_s_per_point']:.0f} ms; cluster start-up and imports "
              f'{start:.1f} s)', flush=True)
    return rows


def offline(systems: int) -> list:
    import numpy as np
    from scipy import signal
    from irs_models.batch_lti import BatchLti
    from irs_models.identified import IdentifiedParams, identified_matrices
    from offline import offline_timings  # bench/offline.py: the loop and the core against dlsim
    o = offline_timings()
    n, steer, t_loop, t_core, t_ref = o['n'], o['steer'], o['t_loop'], o['t_core'], o['t_ref']
    gains = np.linspace(0.5, 2.0, systems) * IdentifiedParams().resolved_gain()
    batch = BatchLti.from_continuous(
        [identified_matrices(IdentifiedParams(gain=g))[:4] for g in gains], 0.001)
    t0 = time.perf_counter()
    yb, _ = batch.simulate(steer)
    t_batch = time.perf_counter() - t0
    i1 = int(np.argmin(np.abs(gains - IdentifiedParams().resolved_gain())))
    err_core = o['err']
    _, y1, _ = signal.dlsim((batch.Ad[i1], batch.Bd[i1], batch.C[i1], batch.D[i1], 0.001),
                            steer[:, None])
    err_batch = float(np.max(np.abs(yb[i1, :, 0] - y1[:, 0])))
    rows = [{'name': 'offline closed loop (all cores, Figure 10)', 'steps_per_s': n / t_loop},
            {'name': 'identified plant, our core stepped in Python', 'steps_per_s': n / t_core,
             'max_abs_difference_m': err_core},
            {'name': 'identified plant, scipy.signal.dlsim', 'steps_per_s': n / t_ref},
            {'name': f'{systems} identified plants at once, BatchLti (system-steps/s)',
             'steps_per_s': systems * n / t_batch, 'max_abs_difference_m': err_batch}]
    for r in rows:
        print(f"{r['name']:60s} {r['steps_per_s']:12.0f} steps/s", flush=True)
    print(f'    core vs dlsim: max |y_s difference| = {err_core:.2e} m; BatchLti vs dlsim '
          f'{err_batch:.2e} m', flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--points', type=int, default=12, help='sweep points per configuration')
    ap.add_argument('--duration', type=float, help='simulated seconds per point (default: the '
                    "sweep file's)")
    ap.add_argument('--systems', type=int, default=100, help='systems stepped at once')
    ap.add_argument('--only', nargs='+', choices=('sweep', 'offline'),
                    default=['sweep', 'offline'])
    ap.add_argument('--out', default=str(HERE / 'results'), help='folder for the JSON file')
    a = ap.parse_args(argv)
    res = {'started': datetime.datetime.now().isoformat(timespec='seconds'),
           'load_before': os.getloadavg(), 'cpus': os.cpu_count()}
    if 'sweep' in a.only:
        print('== sweep (actuator_speed)', flush=True)
        res['sweep'] = sweep_rates(a.points, a.duration)
    if 'offline' in a.only:
        print('== offline', flush=True)
        res['offline'] = offline(a.systems)
    from common import write_results     # bench/common.py
    write_results(res, a.out, prefix='sweep-')
    return 0


if __name__ == '__main__':
    sys.exit(main())
