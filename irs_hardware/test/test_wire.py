"""The wire between the emulator processes: a reader in another process never sees a value the
writer did not write (no torn or zeroed slot while it is rewritten).
"""
import multiprocessing as mp
import time

from irs_hardware.emulator.wire import DRIVE_VOLTAGE, Wire


def _writer(path, stop):
    wire = Wire(path)
    k = 0
    while not stop.is_set():
        wire.set(DRIVE_VOLTAGE, 2.2478787753138696 if k % 2 else 2.271850700200924)
        k += 1


def test_a_reader_sees_only_written_values(tmp_path):
    wire = Wire(tmp_path / 'wire')
    wire.set(DRIVE_VOLTAGE, 2.271850700200924)
    ctx = mp.get_context('spawn')
    stop = ctx.Event()
    writer = ctx.Process(target=_writer, args=(tmp_path / 'wire', stop))
    writer.start()
    try:
        seen, reads = set(), 0
        # the writer's start (a spawned interpreter importing numpy) takes seconds on a loaded
        # machine: read until it has written (at most 60 s), then 2 s more while it writes
        start_deadline, deadline = time.monotonic() + 60.0, None
        while deadline is None or time.monotonic() < deadline:
            seen.add(wire.get(DRIVE_VOLTAGE))
            reads += 1
            if deadline is None and (len(seen) > 1 or time.monotonic() > start_deadline):
                deadline = time.monotonic() + 2.0
    finally:
        stop.set()
        writer.join(timeout=10)
    assert seen <= {2.2478787753138696, 2.271850700200924}, (sorted(seen)[:5], reads)
    assert len(seen) == 2, 'the writer ran'
