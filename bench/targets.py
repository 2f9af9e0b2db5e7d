"""The speed targets of the project (what a user waits for, and real time), each next to its
figure and its floor from one run of ``bench/run.py``. Printed at the end of every run that has
the sections a target needs; the rows go into the results JSON under ``targets``.

A target's floor is the same kind of work at its minimum on this machine in the same minutes:
the lean floor loop of ``bench/floor.py`` for the graph's lock-step and real-time figures; for
the offline cores, the steps/s their interpreted Python calls per step would allow if each cost
no more than a plain call with three float operations (:func:`waits.python_floor`), beside the
interpreted cores' own figure (the target's figure is the compiled cores'); for the waits, that
plain call rate. On a VM whose speed swings 2-5x within minutes, a figure is read against its
floor. Process-per-node lock-step also gets its CPU-bound ceiling (:func:`cpu_ceiling`): the
fastest its processes could run on the machine's cores, whatever the floor.
"""
import os

#: (key, what, target, unit, higher is better)
TARGETS = (
    ('lockstep_composed', 'lock-step Figure 10, composed', 5.0, 'x real time', True),
    ('lockstep_per_node', 'lock-step Figure 10, process per node', 1.0, 'x real time', True),
    ('offline', 'offline closed loop (all cores, Figure 10)', 50_000.0, 'steps/s', True),
    ('rt_composed_miss', 'real time composed, no SCHED_FIFO: misses', 0.5, '%', False),
    ('rt_composed_p99', 'real time composed, no SCHED_FIFO: p99 latency', 0.4, 'ms', False),
    ('rt_fifo_miss', 'real time composed, SCHED_FIFO: misses', 0.2, '%', False),
    ('rt_fifo_p99', 'real time composed, SCHED_FIFO: p99 latency', 0.3, 'ms', False),
    ('demo', 'make demo, clean clone (set-up + runs)', 120.0, 's', False),
    ('figures', 'make figures', 360.0, 's', False),
    ('test', 'make test, pytest only', 240.0, 's', False),
)


def _row(results: dict, section: str, name: str) -> dict | None:
    for row in results.get(section) or []:
        if isinstance(row, dict) and row.get('name') == name:
            return row
    return None


def _get(results, section, name, key):
    row = _row(results, section, name)
    return None if row is None else row.get(key)


def cpu_ceiling(cpu_per_step_us, hop_us, cpus: int) -> str:
    """Why a lock-step deployment can go no faster: the multiple of real time at which its
    processes would keep every core busy, ``x_max = cpus * 1000 us / (CPU per 1 ms step)``, and
    that CPU counted in the floor loop's hops (each a message delivered between processes).
    Empty without the figures.
    """
    if not cpu_per_step_us or cpu_per_step_us <= 0:
        return ''
    text = (f'CPU-bound ceiling {cpus * 1000.0 / cpu_per_step_us:.2f}x '
            f'({cpu_per_step_us / 1000:.2f} ms CPU per step on {cpus} cores')
    if hop_us:
        text += f' = {cpu_per_step_us / hop_us:.0f} floor hops'
    return text + ')'


def figures(results: dict) -> dict:
    """``{target key: (figure, floor text)}`` for the targets this run measured."""
    out = {}
    floor_ls = _get(results, 'floor', 'floor lean composed lockstep', 'steps_per_s')
    floor_ls3 = _get(results, 'floor', 'floor lean lockstep', 'steps_per_s')
    floor_rt = _row(results, 'floor', 'floor lean composed realtime')
    py = [r.get('iterations_per_s') for r in results.get('waits') or []
          if str(r.get('name', '')).startswith('python floor')]
    py_text = f'Python loop {min(py) / 1e6:.1f}-{max(py) / 1e6:.1f} M iterations/s' if py else ''
    x = _get(results, 'lockstep', 'lock-step Figure 10, composed (recorder too)', 'x_real_time')
    if x is not None:
        out['lockstep_composed'] = (x, f'lean composed loop {floor_ls / 1000:.1f}x'
                                    if floor_ls else '')
    per_node = _row(results, 'lockstep', 'lock-step Figure 10, process per node')
    if per_node is not None and per_node.get('x_real_time') is not None:
        floor_text = f'lean 3-process loop {floor_ls3 / 1000:.2f}x' if floor_ls3 else ''
        hop = _get(results, 'floor', 'floor lean lockstep', 'cpu_per_hop_us')
        ceiling = cpu_ceiling(per_node.get('cpu_total_per_step_us'), hop,
                              results.get('cpus') or os.cpu_count() or 1)
        if ceiling:
            floor_text += f'; {ceiling}'
        out['lockstep_per_node'] = (per_node['x_real_time'], floor_text)
    off = _row(results, 'offline', 'offline closed loop (all cores, Figure 10)')
    if off is not None:
        floor, calls = off.get('python_floor_calls_per_s'), off.get('calls_per_step')
        text = (f'interpreted: {calls:.0f} Python calls per step at the plain call rate '
                f'({floor / 1e6:.1f} M/s): {floor / calls:.0f} steps/s' if floor and calls else '')
        if off.get('interpreted_steps_per_s'):
            text += (f'; the interpreted cores ran {off["interpreted_steps_per_s"]:.0f} steps/s '
                     f'(cores of the figure: {off.get("cores")})')
        out['offline'] = (off['steps_per_s'], text)
    for key, name in (('rt_composed', 'realtime_figure10_composed'),
                      ('rt_fifo', 'realtime_figure10_composed SCHED_FIFO')):
        row = _row(results, 'realtime', name)
        if row is None:
            continue
        f_miss = f'lean composed loop {floor_rt["miss_pct"]:.2f} %' if floor_rt else ''
        f_p99 = f'lean composed loop {floor_rt["latency_p99_ms"]:.2f} ms' if floor_rt else ''
        out[f'{key}_miss'] = (row.get('miss_pct'), f_miss)
        out[f'{key}_p99'] = (row.get('latency_p99_ms'), f_p99)
    for key, prefix, field in (('demo', 'make demo', 'wall_s'), ('figures', 'figures', 'wall_s'),
                               ('test', 'make test', 'pytest_s')):
        for row in results.get('waits') or []:
            if str(row.get('name', '')).startswith(prefix):
                out[key] = (row.get(field), py_text)
    return out


def table(results: dict) -> tuple[str, list]:
    """The printed table and its rows (for the JSON)."""
    got = figures(results)
    lines = [f'{"target":48s} {"figure":>12s} {"asked":>10s}  met  floor (same run)']
    rows = []
    for key, what, target, unit, higher in TARGETS:
        if key not in got or got[key][0] is None:
            continue
        value, floor = got[key]
        met = value >= target if higher else value <= target
        rows.append({'target': key, 'what': what, 'figure': value, 'asked': target,
                     'unit': unit, 'met': met, 'floor': floor})
        asked = f'{">=" if higher else "<="} {target:g}'
        lines.append(f'{what:48s} {value:12.4g} {asked:>10s}  {"yes" if met else "no ":3s}  '
                     f'{floor}  [{unit}]')
    return '\n'.join(lines), rows
