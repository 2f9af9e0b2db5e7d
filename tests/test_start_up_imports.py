"""The simulated rig starts without ``scipy.signal``.

The rig (vehicle_sim, the container that composes it, the board emulator) discretises its plant
with :func:`irs_models.zoh.zoh`; ``scipy.signal`` would cost about 0.8 s of CPU at every process
start. The lateral controller loads python-control, and with it ``scipy.signal``, only for a
start-up design check whose answer is not cached yet (:mod:`irs_control.design_check_cache`).
"""
import subprocess
import sys

import pytest


@pytest.mark.parametrize('module', ['irs_vehicle_sim.vehicle_sim_node', 'irs_bringup.container',
                                    'irs_hardware.emulator.board_main'])
@pytest.mark.parametrize('plant', ['identified', 'bicycle', 'two_track'])
def test_the_rig_starts_without_scipy_signal(module, plant):
    code = (f'import sys, {module}\n'
            'from irs_vehicle_sim.rig import RigConfig, RigSimulation\n'
            f"sim = RigSimulation(RigConfig.from_dict({{'plant': {plant!r}}}))\n"
            "print(sorted(m for m in sys.modules if m.startswith('scipy.signal')))")
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == '[]', out.stdout
