"""IRS_TRACE through an experiment: the composed graph's process writes its timeline, with the
recorder's chunk ends in it, and ``python -m irs_common.loop_trace`` summarises it.
"""
import os
import subprocess
import sys

import numpy as np

from irs_bringup.executables import resolve_executable


def test_a_traced_composed_run_writes_its_timeline_with_the_bags_chunks(tmp_path):
    env = dict(os.environ, IRS_TRACE=str(tmp_path / 'trace'))
    res = subprocess.run([resolve_executable('irs_bringup', 'experiment'), 'run',
                          'figure10_mrc_with_actuator', '--duration', '2', '--runs-dir', 'runs'],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    [path] = tmp_path.glob('trace.*.npz')          # one process: the composed graph
    assert f'[experiment] loop trace: {path} (python -m irs_common.loop_trace {path})' \
        in res.stdout
    with np.load(path) as data:
        spins, chunks = data['spins'], data['chunks']
        assert len(spins) > 100 and not data['truncated']
        assert (spins[:, 0] <= spins[:, 2]).all() and (spins[:, 2] <= spins[:, 3]).all()
        # the recorder's bag in chunks of at most 512 messages: 14 topics x 2,000 steps
        assert len(chunks) >= 20 and chunks[:, 3].max() <= 512
        assert chunks[:, 3].sum() > 20_000
        assert (chunks[:, 0] <= chunks[:, 1]).all() and (chunks[:, 1] <= chunks[:, 2]).all()
        assert bool(data['sim_time'])          # lock-step: the waits are not judged
        assert '/vehicle_sim' in [str(n) for n in data['nodes']]
    out = subprocess.run([sys.executable, '-m', 'irs_common.loop_trace', str(path)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f'{path} (/') and 'bag chunk ends: ' in out.stdout
    assert 'simulated time: the waits are not judged' in out.stdout


def test_a_trace_prefix_in_a_missing_folder_is_refused_in_one_line(tmp_path):
    env = dict(os.environ, IRS_TRACE=str(tmp_path / 'no' / 'trace'))
    res = subprocess.run([resolve_executable('irs_sensing', 'arm_pose_estimator')],
                         cwd=tmp_path, capture_output=True, text=True, timeout=60, env=env)
    assert res.returncode == 2, res.stderr
    assert 'Traceback' not in res.stderr
    [fatal] = [line for line in res.stderr.splitlines() if '[FATAL]' in line]
    assert 'IRS_TRACE=' in fatal and 'does not exist' in fatal
