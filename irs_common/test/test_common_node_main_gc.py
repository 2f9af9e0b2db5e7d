"""run_nodes freezes the start-up objects before it spins (irs_common.node_main)."""
import os
import subprocess
import sys
import textwrap

from irs_system_tests.domains import claim_domain

SCRIPT = textwrap.dedent("""
    import gc, os, signal
    import rclpy.node
    from irs_common.node_main import run_nodes

    def make():
        node = rclpy.node.Node('gc_probe')
        def tick():
            print('frozen', gc.get_freeze_count(), flush=True)
            os.kill(os.getpid(), signal.SIGINT)        # a clean stop, as Ctrl-C
        node.create_timer(0.01, tick)
        return node

    raise SystemExit(run_nodes([make]))
""")


def test_objects_built_before_spinning_are_frozen():
    domain, lock = claim_domain(os.getpid() + 7)      # a domain of its own, held while it runs
    try:
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        done = subprocess.run([sys.executable, '-c', SCRIPT], capture_output=True, text=True,
                              timeout=60, env=env)
    finally:
        lock.close()
    assert done.returncode == 0, done.stderr
    counts = [int(line.split()[1]) for line in done.stdout.splitlines()
              if line.startswith('frozen')]
    # rclpy, numpy-free node: tens of thousands of objects (modules, classes, functions)
    assert counts and counts[0] > 10_000, done.stdout
