"""Start-up: what a node process costs before it runs, and how long a graph takes to connect.
A section of ``bench/run.py`` (``--only startup``); each figure is measured with the
environment's setting and with the library's default, alternating sample by sample so that both
see the same phase of the machine.

- **A node's start-up** (:func:`node_startup`): the CPU and wall time from the interpreter's
  start to the node built, for each Figure 10 node, with ``OPENBLAS_NUM_THREADS`` as the
  environment sets it (1) and unset (OpenBLAS's default: a thread per core). Each sample is a
  fresh process (``python -c``) that imports the node's module, calls ``rclpy.init`` and builds
  the node, then reports its own ``getrusage`` CPU (the interpreter's start included) and the
  wall time since it began. OpenBLAS (numpy's and scipy's copies) starts its thread pool at
  import; with one thread it starts none. A third set unsets ``_ROS_WHEELS_BOOTSTRAP_COMPLETE``,
  which the environment sets: the ROS wheels' ``ros_wheels_bootstrapper.pth`` then executes the
  interpreter once more at its start, as it does outside the environment.
- **Graph up** (:func:`graph_up`): ``experiment run figure10_pi --duration 1 --no-plots``,
  process per node and composed, with the environment's Fast DDS profile
  (``env/fastdds_profiles.xml``: participant announcements every 0.5 s) and with Fast DDS's
  defaults (an empty profile: every 3 s): the wall time from the command's start to its
  ``graph up`` line, to its ``completed`` line, and to its exit.
"""
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

#: (package, executable) of the Figure 10 graph's nodes.
NODES = (('irs_vehicle_sim', 'vehicle_sim'), ('irs_sensing', 'arm_pose_estimator'),
         ('irs_control', 'lateral_controller'), ('irs_treadmill', 'treadmill_regulator'),
         ('irs_control', 'reference_generator'), ('irs_bag', 'recorder'))

_CHILD = """
import json, resource, sys, time
t0 = float(sys.argv[1])
import importlib, rclpy
node_class = getattr(importlib.import_module(sys.argv[2]), sys.argv[3])
rclpy.init()
node = node_class()
r = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({'cpu_s': r.ru_utime + r.ru_stime, 'wall_s': time.time() - t0}))
node.destroy_node()
rclpy.shutdown()
"""


def _sample(module: str, cls: str, env: dict, cwd: str) -> dict:
    """One fresh process's figures (its first line of output; the recorder adds its own)."""
    out = subprocess.run([sys.executable, '-c', _CHILD, repr(time.time()), module, cls],
                         env=env, cwd=cwd, capture_output=True, text=True, check=True, timeout=60)
    return json.loads(out.stdout.splitlines()[0])


def startup(repeats: int = 7, graph_repeats: int = 4) -> list:
    """The section's rows: :func:`node_startup`, then :func:`graph_up`."""
    return node_startup(repeats) + graph_up(graph_repeats)


def node_startup(repeats: int = 7) -> list:
    """One row per node and environment: the median and range of ``repeats`` samples."""
    base = dict(os.environ)
    envs = {'environment (OPENBLAS_NUM_THREADS=%s)' % base.get('OPENBLAS_NUM_THREADS', 'unset'):
            base,
            "OpenBLAS's default (a thread per core)":
            {k: v for k, v in base.items() if k != 'OPENBLAS_NUM_THREADS'},
            "the ROS wheels' re-exec at start (its guard unset)":
            {k: v for k, v in base.items() if k != '_ROS_WHEELS_BOOTSTRAP_COMPLETE'}}
    rows = []
    cwd = tempfile.mkdtemp(prefix='irs_bench_startup_')     # the recorder's empty bags go here
    from irs_bringup.container import component_class    # the node classes' entry points
    for package, exe in NODES:
        node_class = component_class(package, exe)
        module, cls = node_class.__module__, node_class.__name__
        samples = {name: [] for name in envs}
        for _ in range(repeats):
            for name, env in envs.items():
                samples[name].append(_sample(module, cls, env, cwd))
        for name, got in samples.items():
            cpu = [s['cpu_s'] for s in got]
            wall = [s['wall_s'] for s in got]
            rows.append({'name': f'start-up {exe}, {name}', 'node': exe, 'environment': name,
                         'cpu_s_median': statistics.median(cpu),
                         'cpu_s_range': [min(cpu), max(cpu)],
                         'wall_s_median': statistics.median(wall),
                         'wall_s_range': [min(wall), max(wall)]})
            print(f'{exe:20s} {name:42s} CPU {statistics.median(cpu):.2f} s '
                  f'({min(cpu):.2f}-{max(cpu):.2f}), wall {statistics.median(wall):.2f} s '
                  f'({min(wall):.2f}-{max(wall):.2f})', flush=True)
    shutil.rmtree(cwd, ignore_errors=True)
    return rows


#: A Fast DDS profile file that sets nothing: Fast DDS's own defaults.
_EMPTY_PROFILE = ('<?xml version="1.0" encoding="UTF-8" ?>\n'
                  '<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"/>\n')


def _graph_sample(deployment: str, env: dict, runs_dir: str) -> dict:
    """One ``experiment run``: seconds from its start to ``graph up``, ``completed``, exit."""
    t0 = time.monotonic()
    times = {}
    from irs_bringup.executables import resolve_executable
    cmd = [resolve_executable('irs_bringup', 'experiment'), 'run', 'figure10_pi', deployment,
           '--duration', '1', '--no-plots', '--runs-dir', runs_dir]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    for line in proc.stdout:
        for key in ('graph up', 'completed'):
            if key in line:
                times.setdefault(key, time.monotonic() - t0)
    if proc.wait() != 0 or len(times) != 2:
        raise RuntimeError(f'experiment run figure10_pi {deployment} failed '
                           f'(exit {proc.returncode})')
    return {'graph_up_s': times['graph up'], 'completed_s': times['completed'],
            'exit_s': time.monotonic() - t0}


def graph_up(repeats: int = 4) -> list:
    """One row per deployment and Fast DDS profile: medians and ranges of ``repeats`` runs."""
    base = dict(os.environ)
    tmp = tempfile.mkdtemp(prefix='irs_bench_graph_up_')
    empty = os.path.join(tmp, 'empty_profile.xml')
    with open(empty, 'w') as f:
        f.write(_EMPTY_PROFILE)
    envs = {'environment (%s)' % os.path.basename(base.get('FASTRTPS_DEFAULT_PROFILES_FILE',
                                                           'no profile')): base,
            "Fast DDS's defaults": dict(base, FASTRTPS_DEFAULT_PROFILES_FILE=empty)}
    rows = []
    for deployment in ('--process-per-node', '--composed'):
        samples = {name: [] for name in envs}
        for _ in range(repeats):
            for name, env in envs.items():
                samples[name].append(_graph_sample(deployment, env, tmp))
        for name, got in samples.items():
            row = {'name': f'graph up, figure10_pi {deployment[2:]}, {name}',
                   'deployment': deployment[2:], 'environment': name}
            for key in ('graph_up_s', 'completed_s', 'exit_s'):
                vals = [g[key] for g in got]
                row[key + '_median'] = statistics.median(vals)
                row[key + '_range'] = [min(vals), max(vals)]
            rows.append(row)
            print(f"{deployment[2:]:16s} {name:42s} graph up {row['graph_up_s_median']:.2f} s "
                  f"({row['graph_up_s_range'][0]:.2f}-{row['graph_up_s_range'][1]:.2f}), "
                  f"completed {row['completed_s_median']:.2f} s, "
                  f"exit {row['exit_s_median']:.2f} s",
                  flush=True)
    shutil.rmtree(tmp, ignore_errors=True)
    return rows


if __name__ == '__main__':
    startup()
