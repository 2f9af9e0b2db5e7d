"""Real time at 1 kHz through the emulated link, next to the simulated rig in the same run.

    ./irs exec flock /tmp/irs_bench.lock python bench/run.py --only hil [--quick]

A section of ``bench/run.py`` (its run and row functions are passed in). Real-time runs of the
Figure 10 graph at SCHED_FIFO 50 (the lab's deployment), composed in one process and process
per node, each deployment on ``vehicle_sim`` (``realtime_figure10``) and on ``rig_hardware``
(``realtime_hil_figure10``: the emulated board free-running on its pty at SCHED_FIFO 60 with
1 Mbaud and 0.5 ms of USB latency per frame, the emulated drive on Modbus) back to back, so
that both see the same machine. Per run:

- host side (``rig/timing``, both rigs alike): deadline misses (the answer to a sample not in
  before the next one is handled), loop latency p50/p99/max (arm sample published -> steering
  command received by the rig), CPU per step;
- the hardware's own figures: from the board (its status file) the latency from taking the ADC
  sample to applying the servo pulse that answers it (p50/p99/max: the link both ways and the
  host) and the board's deadline misses (the answer not in force when sample k + 2 is taken,
  ``BoardEmulator.DEADLINE``), the emulator's late wake-ups; frames lost: samples the host
  never read (tick gaps), frames the emulated USB backlog dropped, frames thrown away (CRC)
  either way; latched faults.
"""
import json
from pathlib import Path

RUNS = ('realtime_figure10', 'realtime_hil_figure10')


def _board(run_dir) -> dict:
    path = Path(run_dir) / 'board.json'
    return json.loads(path.read_text()) if path.exists() else {}


def hil_row(label: str, r, realtime_row) -> dict:
    """One run's row (``realtime_row``'s figures, and the board's for the hardware run)."""
    row = realtime_row(label, r)
    board = _board(r.run_dir)
    if not board:
        return row
    t = r.timing
    b = board['timing']
    row['board'] = {
        'sample_to_servo_ms': {q: b[f'latency_{q}_ms'] for q in ('p50', 'p99', 'max')},
        'deadline_misses': b['deadline_misses'], 'deadline_miss_pct': b['miss_pct'],
        'loop_misses': board['loop_misses'], 'samples_sent': board['samples'],
        'samples_lost': int(t.get('lost_samples', 0)), 'link_dropped': board['link_dropped'],
        'bad_frames_to_host': int(t.get('bad_frames', 0)),
        'bad_frames_to_board': board['bad_host_frames'], 'commands_applied': board['commands'],
        'watchdog_trips': board['watchdog_trips'], 'faults': int(t.get('faults', 0))}
    x = row['board']
    print(f"    board: sample -> servo p50/p99/max {x['sample_to_servo_ms']['p50']:.2f}/"
          f"{x['sample_to_servo_ms']['p99']:.2f}/{x['sample_to_servo_ms']['max']:.1f} ms, "
          f"deadline (k + 2) misses {x['deadline_miss_pct']:.2f} %, late wake-ups "
          f"{x['loop_misses']}; frames: {x['samples_lost']} of {x['samples_sent']} samples "
          f"lost ({x['link_dropped']} dropped by the USB backlog), "
          f"{x['bad_frames_to_host']}/{x['bad_frames_to_board']} garbled (in/out); "
          f"{x['watchdog_trips']} board watchdog trips, {x['faults']} latched faults",
          flush=True)
    return row


def hil(seconds: float, run_experiment, realtime_row) -> list:
    """The four runs, ``seconds`` each; ``run_experiment(name, rt_priority, seconds,
    composed=...)`` and ``realtime_row(label, result)`` are bench/run.py's.
    """
    from common import domain
    rows = []
    for composed in (True, False):
        for name in RUNS:
            domain(60 + len(rows))
            r = run_experiment(name, 50, seconds, composed=composed)
            label = f"{name}{' composed' if composed else ''} SCHED_FIFO"
            rows.append(hil_row(label, r, realtime_row))
    return rows
