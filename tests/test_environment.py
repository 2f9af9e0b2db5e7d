"""The defaults that ``.venv/local_setup.sh`` (from ``env/venv_local_setup.sh.in``) sets, read
back from a shell started with an empty environment: the environment's Fast DDS profile file of
this tree and one OpenBLAS thread, each kept when the user has set their own; the wheels'
libraries on the loader's path, so that a Python process starts once (the wheels'
``ros_wheels_bootstrapper.pth`` executes the interpreter again otherwise); and ``./irs run``
finding executables in the shell as the ament index does, and naming what it cannot find.
"""
import os
from pathlib import Path
import subprocess

from irs_common.dds_profile import writer_heartbeat_period

ROOT = Path(__file__).resolve().parents[1]
SETUP = ROOT / '.venv' / 'local_setup.sh'


def _sourced(**preset) -> dict:
    """The two variables after sourcing the set-up in ``env -i`` with ``preset`` set first."""
    names = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'OPENBLAS_NUM_THREADS')
    script = f'. "{SETUP}"; ' + '; '.join(f'printf "%s\\n" "${{{n}}}"' for n in names)
    out = subprocess.run(['env', '-i', *[f'{k}={v}' for k, v in preset.items()], 'bash', '-c',
                          script], capture_output=True, text=True, check=True).stdout
    return dict(zip(names, out.splitlines()))


def test_the_setup_names_this_trees_fast_dds_profile_and_one_openblas_thread():
    got = _sourced()
    assert Path(got['FASTRTPS_DEFAULT_PROFILES_FILE']) == ROOT / 'env' / 'fastdds_profiles.xml'
    assert Path(got['FASTRTPS_DEFAULT_PROFILES_FILE']).is_file()
    assert writer_heartbeat_period(got) == 0.05
    assert got['OPENBLAS_NUM_THREADS'] == '1'


def test_a_users_own_settings_are_kept():
    got = _sourced(FASTRTPS_DEFAULT_PROFILES_FILE='/etc/my_profile.xml', OPENBLAS_NUM_THREADS='4')
    assert got == {'FASTRTPS_DEFAULT_PROFILES_FILE': '/etc/my_profile.xml',
                   'OPENBLAS_NUM_THREADS': '4'}


def _interpreter_starts(env: dict) -> int:
    """How many interpreters a ``python -c pass`` under ``env`` started: each imports
    ``encodings`` once, before the start-up hooks (``-X importtime`` lists it).
    """
    out = subprocess.run(['python', '-X', 'importtime', '-c', 'pass'], env=env,
                         capture_output=True, text=True, check=True)
    return sum(1 for line in out.stderr.splitlines() if line.rstrip().endswith('| encodings'))


def test_a_python_process_of_the_environment_starts_once_and_loads_the_ros_libraries():
    env = dict(os.environ)
    assert env.get('_ROS_WHEELS_BOOTSTRAP_COMPLETE') == '1'
    assert _interpreter_starts(env) == 1
    # without the guard the wheels' .pth starts the interpreter a second time
    assert _interpreter_starts({k: v for k, v in env.items()
                          if k != '_ROS_WHEELS_BOOTSTRAP_COMPLETE'}) == 2
    code = ('import rclpy; rclpy.init(); n = rclpy.create_node("env_probe"); '
            'print(n.get_name()); n.destroy_node(); rclpy.shutdown()')
    out = subprocess.run(['python', '-c', code], env=env, capture_output=True, text=True)
    assert (out.returncode, out.stdout.strip()) == (0, 'env_probe'), out.stderr[-2000:]


def test_sourcing_twice_puts_the_libraries_on_the_path_once():
    script = f'. "{SETUP}"; . "{SETUP}"; printf "%s" "$LD_LIBRARY_PATH"'
    out = subprocess.run(['env', '-i', 'bash', '-c', script], capture_output=True, text=True,
                         check=True).stdout.split(':')
    venv_lib = str(ROOT / '.venv' / 'lib')
    assert out[0] == venv_lib and out.count(venv_lib) == 1
    assert any(p.endswith('ros_rclpy.libs') for p in out), out


def _irs_run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([str(ROOT / 'irs'), 'run', *args], capture_output=True, text=True,
                          timeout=120)


def test_irs_run_starts_the_indexed_executable_and_names_what_it_cannot_find():
    from irs_bringup.executables import package_executables
    found = _irs_run('irs_bag', 'bag', '--help')
    assert found.returncode == 0 and found.stdout.startswith('usage: bag '), found
    wrong = _irs_run('irs_bag', 'nope')
    assert wrong.returncode == 2 and wrong.stderr == (
        f"irs: no executable 'nope' in package 'irs_bag'; it has: "
        f"{', '.join(package_executables('irs_bag'))}\n"), wrong
    missing = _irs_run('no_such_package', 'x')
    assert missing.returncode == 2, missing
    assert missing.stderr.startswith("irs: package 'no_such_package' is not in the ament index")
