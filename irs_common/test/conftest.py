"""Fixtures of irs_common's tests."""
import pytest
import rclpy
from rclpy.context import Context


@pytest.fixture
def context():
    """A fresh, initialised rclpy context, shut down after the test."""
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)
