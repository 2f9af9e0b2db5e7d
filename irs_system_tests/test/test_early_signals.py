"""A signal in a command's first start-up steps ends it cleanly (irs_common.node_main, cli).

A node process (``run_nodes``), a command (``run_cli``) and the container install their signal
guard first; from then on a first SIGINT raises ``Interrupted``. The script sends itself SIGINT
inside one of the steps that follow the guard's first handler, as ``ros2 run``'s Ctrl-C (or a
test's signal under a CPU hog) may, and the process must exit with its code for a signal,
without a traceback and without going on.
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
            if name == 'install':       # between the handlers of SIGINT and SIGTERM
                args[0]._old = {signal.SIGINT: signal.signal(signal.SIGINT, args[0]._handle)}
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.01)        # the guard's Python handler runs here
            result = original(*args, **kwargs)
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)
            return result
        setattr(owner, name, step)

    entry, where = sys.argv[1], sys.argv[2]
    interrupt_in(cli.SignalGuard if where == 'install' else node_main, where)

    def make():
        print('went on', flush=True)
        raise SystemExit(3)

    if entry == 'run_nodes':
        raise SystemExit(node_main.run_nodes([make]))
    if entry == 'run_cli':
        raise SystemExit(cli.run_cli('probe', lambda argv: make(), []))
    from irs_bringup import container
    raise SystemExit(container.main(['no-such-spec.yaml']))
""")


@pytest.mark.parametrize('entry, where, code', [
    ('run_nodes', 'install', 0),
    ('run_nodes', 'register_stack_dump', 0),
    ('run_nodes', 'set_realtime_priority', 0),
    ('run_cli', 'install', 130),
    ('container', 'install', 0),
])
def test_a_signal_in_the_first_start_up_steps_exits_without_a_traceback(entry, where, code):
    done = subprocess.run([sys.executable, '-c', SCRIPT, entry, where], capture_output=True,
                          text=True, timeout=60, env=dict(os.environ, ROS_DOMAIN_ID='0'))
    assert done.returncode == code, done.stderr
    assert 'Traceback' not in done.stderr and 'error' not in done.stderr, done.stderr
    assert 'went on' not in done.stdout and 'FATAL' not in done.stderr
