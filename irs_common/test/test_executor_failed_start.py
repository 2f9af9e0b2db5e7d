"""An executor whose construction fails (the context shut down by a signal during start-up) is
collected without an error: Python would print its ``__del__``'s exception as a traceback, and
the signal tests forbid any traceback in a node's output.
"""
import gc
import sys

import pytest
import rclpy
from rclpy.context import Context

from irs_common.executor import LeanExecutor


def test_an_executor_that_failed_to_build_is_collected_quietly(monkeypatch):
    unraisable = []
    monkeypatch.setattr(sys, 'unraisablehook', unraisable.append)
    ctx = Context()
    rclpy.init(context=ctx)
    rclpy.shutdown(context=ctx)
    with pytest.raises(Exception, match='context is not valid'):
        LeanExecutor(context=ctx)
    gc.collect()
    assert unraisable == [], [f'{u.exc_type.__name__}: {u.exc_value}' for u in unraisable]
