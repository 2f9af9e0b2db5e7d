"""The benchmark's target table (``bench/targets.py``): each target next to its floor, and the
CPU-bound ceiling that says why process-per-node lock-step stays below its target.
"""
import importlib.util
from pathlib import Path

import pytest
from hypothesis import given, strategies as st

_spec = importlib.util.spec_from_file_location(
    'bench_targets', Path(__file__).resolve().parents[1] / 'bench' / 'targets.py')
targets = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(targets)


def _results(cpu_per_step_us, x, hop_us=150.0, cpus=2):
    return {'cpus': cpus,
            'floor': [{'name': 'floor lean lockstep', 'steps_per_s': 2700.0,
                       'cpu_per_hop_us': hop_us}],
            'lockstep': [{'name': 'lock-step Figure 10, process per node', 'x_real_time': x,
                          'cpu_total_per_step_us': cpu_per_step_us}]}


@given(cpu=st.floats(1.0, 1e5), hop=st.floats(1.0, 1e4), cpus=st.integers(1, 64))
def test_the_ceiling_is_the_cores_over_the_cpu_per_step(cpu, hop, cpus):
    text = targets.cpu_ceiling(cpu, hop, cpus)
    assert text.startswith(f'CPU-bound ceiling {cpus * 1000.0 / cpu:.2f}x ')
    assert f'on {cpus} cores = {cpu / hop:.0f} floor hops)' in text


@pytest.mark.parametrize('cpu', [None, 0.0, -1.0])
def test_no_ceiling_without_a_cpu_figure(cpu):
    assert targets.cpu_ceiling(cpu, 150.0, 2) == ''


def test_the_per_node_row_names_its_floor_and_its_ceiling():
    text, rows = targets.table(_results(2800.0, 0.61))
    (row,) = [r for r in rows if r['target'] == 'lockstep_per_node']
    assert row['figure'] == 0.61 and row['met'] is False
    assert row['floor'] == ('lean 3-process loop 2.70x; CPU-bound ceiling 0.71x '
                            '(2.80 ms CPU per step on 2 cores = 19 floor hops)')
    assert row['floor'] in text
    (met,) = [r for r in targets.table(_results(1500.0, 1.2))[1]
              if r['target'] == 'lockstep_per_node']
    assert met['met'] is True and 'ceiling 1.33x' in met['floor']
