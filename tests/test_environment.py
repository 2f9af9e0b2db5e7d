"""The defaults that ``.venv/local_setup.sh`` (from ``env/venv_local_setup.sh.in``) sets, read
back from a shell started with an empty environment: the environment's Fast DDS profile file of
this tree and one OpenBLAS thread, each kept when the user has set their own.
"""
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
