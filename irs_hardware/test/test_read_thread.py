"""The rig_hardware node's board-reading thread outlives whatever its driver raises.

``RigHardwareNode._read_loop`` runs here on a stand-in for the node (the attributes the loop
uses), no ROS graph: a driver that raises an unexpected exception (a bug, not the link) trips
the rig with that exception named, logs its traceback once, and the thread reads on.
"""
import threading
from types import SimpleNamespace

from irs_hardware.driver import LinkError
from irs_hardware.rig_hardware_node import RigHardwareNode


class FakeRig:
    """The parts of a HardwareRig the loop uses; its reads raise ``errors`` first."""

    def __init__(self, errors):
        self.errors, self.fault, self.trips = list(errors), '', []
        self.io = SimpleNamespace(read=self.read)
        self.cfg = SimpleNamespace(link_timeout=0.1, command_timeout=0.2)
        self.reads = 0

    @property
    def ok(self):
        return not self.fault

    def read(self, _wait):
        self.reads += 1
        if self.errors:
            raise self.errors.pop(0)
        return []

    def trip(self, reason, _now):
        self.fault = self.fault or reason
        self.trips.append(reason)

    def check_link(self, _now):
        return True


def _run(errors, passes=5):
    rig, logged = FakeRig(errors), []
    node = SimpleNamespace(running=True, generation=0, rig=rig, lock=threading.Lock(),
                           pending=[], p={'stall_grace': 0.0}, samples_ready=None,
                           get_logger=lambda: SimpleNamespace(error=logged.append),
                           _publish_status=lambda force=False: None,
                           _check_stale=lambda now: None)

    def read(wait):
        if rig.reads >= len(errors) + passes:
            node.running = False
        return FakeRig.read(rig, wait)
    rig.io.read = read
    RigHardwareNode._read_loop(node)
    return rig, logged


def test_an_unexpected_driver_error_trips_once_is_logged_once_and_the_thread_reads_on():
    rig, logged = _run([TypeError('argument must be an int'), TypeError('again')])
    assert rig.fault == "board read failed unexpectedly (TypeError('argument must be an int'))"
    assert len(rig.trips) == 2 and rig.reads > 2         # it went on reading
    assert len(logged) == 1 and 'Traceback' in logged[0] and 'TypeError' in logged[0], logged


def test_a_link_error_trips_without_a_traceback():
    rig, logged = _run([LinkError('board at /dev/x: read failed (gone)')])
    assert rig.fault == 'board at /dev/x: read failed (gone)' and logged == []
