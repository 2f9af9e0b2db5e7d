"""Offline speed: the offline twin of the Figure 10 graph, and the identified plant against
``scipy.signal.dlsim``. A section of ``bench/run.py``; ``bench/sweep.py`` uses the timings.
"""
import time


#: Runs of the offline loop per measurement; its figure is the fastest (as ``timeit`` reports
#: the best of its repeats): on this machine single 8 s runs of one tree differ by 10-15 %.
LOOP_RUNS = 3


def offline_timings() -> dict:
    """The offline Figure 10 closed loop (the fastest of ``LOOP_RUNS`` runs, each from a new
    loop), then the identified plant alone on its achieved steer: our core stepped in Python
    against ``scipy.signal.dlsim``. Returns the steps, the times [s] (``t_loops``: every run of
    the loop), the steer and the largest |y_s| difference [m] (also used by ``bench/sweep.py``).
    """
    import numpy as np
    from scipy import signal
    from irs_bringup.offline_twin.lateral_loop import ClosedLoop
    from irs_bringup.experiment import load_experiment
    from irs_bringup.offline_twin.from_experiment import loop_config_from_experiment
    from irs_models.identified import IdentifiedPlant
    exp = load_experiment('figure10_mrc_with_actuator')
    t_loops = []
    for _ in range(LOOP_RUNS):
        loop = ClosedLoop(loop_config_from_experiment(exp))
        t0 = time.perf_counter()
        run = loop.run(exp.duration)
        t_loops.append(time.perf_counter() - t0)
    t_loop = min(t_loops)
    n = int(round(exp.duration / 0.001))
    steer = np.nan_to_num(np.asarray(run.get('steer_achieved', run.get('steer_cmd')), float))[:n]
    plant = IdentifiedPlant()
    t0 = time.perf_counter()
    ys_core = np.empty(n)
    for k in range(n):
        ys_core[k] = plant.y_s
        plant.step(float(steer[k]), 0.0, 0.001)
    t_core = time.perf_counter() - t0
    Ad, Bd = plant.discrete(0.001)
    t0 = time.perf_counter()
    _, ys_ref, _ = signal.dlsim((Ad, Bd, plant.C, plant.D, 0.001), steer[:, None])
    t_ref = time.perf_counter() - t0
    return {'n': n, 'steer': steer, 't_loop': t_loop, 't_loops': t_loops, 't_core': t_core,
            't_ref': t_ref,
            'err': float(np.max(np.abs(ys_core - ys_ref[:, 0])))}


def calls_per_step(duration: float = 0.5) -> float:
    """Python function calls per step of the offline Figure 10 loop (cProfile's count over
    ``duration`` s of simulated time; a count, not a time, so load does not change it).
    """
    import cProfile
    import pstats
    from irs_bringup.experiment import load_experiment
    from irs_bringup.offline_twin.from_experiment import loop_config_from_experiment
    from irs_bringup.offline_twin.lateral_loop import ClosedLoop
    exp = load_experiment('figure10_mrc_with_actuator')
    loop = ClosedLoop(loop_config_from_experiment(exp))
    prof = cProfile.Profile()
    prof.runcall(loop.run, duration)
    return pstats.Stats(prof).total_calls / (duration / loop.dt)


_INTERPRETED = """
import json, sys
sys.path.insert(0, 'bench')
from offline import calls_per_step, offline_timings
from irs_common import native_cores
o = offline_timings()
print(json.dumps({'status': native_cores.status, 'n': o['n'], 't_loops': o['t_loops'],
                  'calls_per_step': calls_per_step()}))
"""


def interpreted_timings() -> dict:
    """:func:`offline_timings`' loop runs and :func:`calls_per_step` with the interpreted cores
    (a process with ``IRS_PURE_PYTHON=1``; cProfile counts only interpreted calls).
    """
    import json
    import os
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, '-c', _INTERPRETED], cwd=root, check=True, text=True,
                         capture_output=True, env=dict(os.environ, IRS_PURE_PYTHON='1'))
    return json.loads(out.stdout.strip().splitlines()[-1])


def offline() -> list:
    from irs_common import native_cores
    from waits import python_floor      # bench/waits.py
    floor = python_floor()
    o = offline_timings()
    pure = interpreted_timings()
    calls = pure['calls_per_step']
    n, t_loop, t_core, t_ref, err = o['n'], o['t_loop'], o['t_core'], o['t_ref'], o['err']
    print(f'    Python floor {floor / 1e6:.1f} M calls/s (a call and three float operations); '
          f'the interpreted loop makes {calls:.0f} calls per step: {floor / calls:.0f} steps/s at '
          f'that rate', flush=True)
    pure_runs = [pure['n'] / t for t in pure['t_loops']]
    print(f'    cores: {native_cores.status}; interpreted ({pure["status"]}): '
          f'{max(pure_runs):.0f} steps/s (runs: {", ".join(f"{r:.0f}" for r in pure_runs)})',
          flush=True)
    rows = [{'name': 'offline closed loop (all cores, Figure 10)', 'steps_per_s': n / t_loop,
             'steps_per_s_each_run': [n / t for t in o['t_loops']],
             'cores': native_cores.status,
             'interpreted_steps_per_s': max(pure_runs),
             'interpreted_steps_per_s_each_run': pure_runs,
             'python_floor_calls_per_s': floor, 'calls_per_step': calls},
            {'name': 'identified plant, our core stepped in Python', 'steps_per_s': n / t_core},
            {'name': 'identified plant, scipy.signal.dlsim (vectorised reference)',
             'steps_per_s': n / t_ref, 'max_abs_difference_m': err}]
    for r in rows:
        print(f"{r['name']:60s} {r['steps_per_s']:12.0f} steps/s", flush=True)
    each = ', '.join(f'{x:.0f}' for x in rows[0]['steps_per_s_each_run'])
    print(f"    the loop's {LOOP_RUNS} runs: {each} steps/s; the fastest is its figure",
          flush=True)
    print(f'    core vs dlsim: max |y_s difference| = {err:.2e} m', flush=True)
    return rows
