"""The node's parameters judged together (``hardware_problem``, ``declare_table(check=...)``)."""
import pytest
import yaml

from irs_hardware.hardware_params import NODE_PARAMS, hardware_problem
from irs_hardware.paths import resolve


def test_the_defaults_and_the_shipped_file_fit_together():
    assert hardware_problem({}) is None
    shipped = yaml.safe_load(resolve('pkg://irs_hardware/config/hardware.yaml').read_text())
    assert hardware_problem(shipped['rig_hardware']['ros__parameters']) is None


@pytest.mark.parametrize('values, words', [
    ({'clock_mode': 'fast'}, "clock_mode must be 'realtime' or 'lockstep'"),
    ({'board_watchdog': 0.0015}, 'board_watchdog = 0.0015 s is shorter than two samples'),
    ({'link_timeout': 0.004, 'dt': 0.005}, 'link_timeout = 0.004 s is shorter than two'),
    ({'drive_keepalive': 0.5, 'drive_comm_timeout': 0.5}, 'drive_keepalive = 0.5 s is not '
     'shorter than drive_comm_timeout = 0.5 s'),
    ({'drive_period': 0.2, 'drive_comm_timeout': 0.1, 'drive_keepalive': 0.05},
     'drive_period = 0.2 s is not shorter than drive_comm_timeout'),
    ({'stall_grace': 0.004}, "stall_grace = 0.004 s: 0 (no board keeper) or more than the "
     "keeper's 5 ms"),
    ({'stall_grace': 0.5}, 'stall_grace = 0.5 s is not shorter than drive_comm_timeout = 0.5 s'),
    ({'wheel_torque_limit': 0.5, 'wheel_torque_reject': 0.4}, 'wheel_torque_reject = 0.4 N m '
     'is below wheel_torque_limit = 0.5 N m'),
])
def test_values_that_do_not_fit_are_one_sentence(values, words):
    assert words in hardware_problem(values)


def test_no_communication_loss_stop_allows_any_keepalive():
    assert hardware_problem({'drive_comm_timeout': 0.0, 'drive_keepalive': 60.0}) is None
    assert hardware_problem({'drive_comm_timeout': 0.0, 'stall_grace': 5.0}) is None
    assert hardware_problem({'stall_grace': 0.0}) is None
    assert {p.name for p in NODE_PARAMS} >= {'drive_comm_timeout', 'drive_keepalive'}
