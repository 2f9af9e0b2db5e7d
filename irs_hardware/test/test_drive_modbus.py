"""ModbusDrive's requests and close are serialised: a reset closing the client while the node's
drive thread has a request in flight waits for it (the request would otherwise fail with a bad
file descriptor, or close the reset's new connection under it).
"""
import errno
import threading

from irs_hardware.drive_modbus import ModbusDrive


class _Result:
    def isError(self):
        return False


class _Client:
    """A Modbus client whose request waits on ``go``; a close while it waits breaks it."""

    def __init__(self):
        self.connected = True
        self.in_request = threading.Event()
        self.go = threading.Event()
        self.closed_during_request = False
        self.busy = False

    def connect(self):
        self.connected = True
        return True

    def close(self):
        self.connected = False
        if self.busy:
            self.closed_during_request = True

    def write_register(self, address, value, device_id=1):
        self.busy = True
        self.in_request.set()
        self.go.wait(10.0)
        self.busy = False
        if self.closed_during_request:
            raise OSError(errno.EBADF, 'Bad file descriptor')
        return _Result()


def test_close_waits_for_a_request_in_flight():
    drive = ModbusDrive()
    drive.client = client = _Client()
    errors = []

    def request():
        try:
            drive.write_setpoint(100)
        except OSError as exc:          # DriveError is an IOError
            errors.append(exc)

    a = threading.Thread(target=request)
    a.start()
    assert client.in_request.wait(10.0)
    b = threading.Thread(target=drive.close)
    b.start()
    b.join(0.2)                         # the close must not get through while the request runs
    closed_early = not b.is_alive()
    client.go.set()
    a.join(10.0)
    b.join(10.0)
    assert not closed_early and errors == [] and not client.closed_during_request
    assert not client.connected         # and the close happened after the request
