"""A signal during a node process's first start-up steps ends it cleanly (irs_common.node_main).

``run_nodes`` installs its signal guard first; from then on a first SIGINT raises
``Interrupted``. The script sends itself SIGINT inside one of the steps that follow the
guard's installation, as ``ros2 run``'s Ctrl-C (or a test's signal under a CPU hog) may, and
the process must exit 0 without a traceback and without building its node.
"""
import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import os, signal, sys, time
    from irs_common import cli, node_main

    def interrupt_in(owner, name):
        original = getattr(owner, name)
        def step(*args, **kwargs):
            result = original(*args, **kwargs)
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)       # the guard's Python handler runs here
            return result
        setattr(owner, name, step)

    where = sys.argv[1]
    if where == 'install':
        interrupt_in(cli.SignalGuard, 'install')
    else:
        interrupt_in(node_main, where)

    def make():
        print('node built', flush=True)
        raise SystemExit(3)

    raise SystemExit(node_main.run_nodes([make]))
""")


@pytest.mark.parametrize('where', ['install', 'register_stack_dump', 'set_realtime_priority'])
def test_a_signal_in_the_first_start_up_steps_exits_0_without_a_traceback(where):
    done = subprocess.run([sys.executable, '-c', SCRIPT, where], capture_output=True, text=True,
                          timeout=60, env=dict(os.environ, ROS_DOMAIN_ID='0'))
    assert done.returncode == 0, done.stderr
    assert 'Traceback' not in done.stderr, done.stderr
    assert 'node built' not in done.stdout
