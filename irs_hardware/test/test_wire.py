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
        seen, reads, deadline = set(), 0, time.monotonic() + 3.0
        while time.monotonic() < deadline:
            seen.add(wire.get(DRIVE_VOLTAGE))
            reads += 1
    finally:
        stop.set()
        writer.join(timeout=10)
    assert seen <= {2.2478787753138696, 2.271850700200924}, (sorted(seen)[:5], reads)
    assert len(seen) == 2, 'the writer ran'
