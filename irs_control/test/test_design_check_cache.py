"""The design check's on-disk cache (``irs_control/design_check_cache.py``): an entry gives the
computed :class:`DesignCheck` to the bit, any changed input is a new entry, a bad entry is
computed again, and a controller started a second time does not import python-control.
"""
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from irs_control.controller_factory import (CONTROLLER_DEFAULTS, INPUT_CHECK_DEFAULTS,
                                            make_controller)
from irs_control.design_check import (DesignCheck, cached_check_design, check_controller,
                                      check_design)
from irs_control.design_check_cache import cache_key, from_json, to_json

DESIGNS = {'mrc': {'mode': 'mrc', 'include_actuator': True},
           'pi': {'mode': 'pi'},
           'mrc_unstable_on_irs_2wd': {'mode': 'mrc', 'include_actuator': False}}
PLANTS = {'mrc': 'identified', 'pi': 'identified', 'mrc_unstable_on_irs_2wd': 'irs_2wd'}


def _inputs(name):
    cfg = {**CONTROLLER_DEFAULTS, **INPUT_CHECK_DEFAULTS, **DESIGNS[name],
           'check_plant': PLANTS[name], 'check_delay': 0.017}
    spec = make_controller({k: v for k, v in cfg.items() if k in CONTROLLER_DEFAULTS})
    return cfg, spec


def _bits(check) -> str:
    return to_json(check)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv('IRS_CACHE_DIR', str(tmp_path))
    monkeypatch.delenv('IRS_DESIGN_CACHE', raising=False)
    return tmp_path / 'design_check'


@pytest.mark.parametrize('name', list(DESIGNS))
def test_an_entry_gives_the_computed_check_to_the_bit(cache, name):
    cfg, spec = _inputs(name)
    first = check_controller(cfg, spec.controller, spec.design)      # computed, written
    entries = list(cache.glob('*.json'))
    assert len(entries) == 1
    second = check_controller(cfg, spec.controller, spec.design)     # read
    assert _bits(second) == _bits(first)
    assert second.stable == first.stable and second.summary() == first.summary()
    assert (name == 'mrc_unstable_on_irs_2wd') != first.stable
    # the entry is what is read: a changed entry changes the answer
    doc = entries[0].read_text().replace(first.plant, 'edited')
    entries[0].write_text(doc)
    assert check_controller(cfg, spec.controller, spec.design).plant == 'edited'


def test_every_input_is_part_of_the_key():
    cfg, spec = _inputs('mrc')
    B, A = [1.0, 2.0], [1.0, 3.0, 2.0]
    R, S = spec.design.R, spec.design.S
    ss = spec.controller.linear_state_space()
    base = cache_key(B, A, R, S, ss, 0.001, 'identified', 0.017)
    assert cache_key(B, A, R, S, ss, 0.001, 'identified', 0.017) == base
    one_ulp = [np.nextafter(B[0], 2.0), B[1]]
    ss2 = [m.copy() for m in ss]
    ss2[0].flat[0] = np.nextafter(ss2[0].flat[0], np.inf)
    changed = [cache_key(one_ulp, A, R, S, ss, 0.001, 'identified', 0.017),
               cache_key(B, A, R, S, ss2, 0.001, 'identified', 0.017),
               cache_key(B, A, R, S, ss, 0.002, 'identified', 0.017),
               cache_key(B, A, R, S, ss, 0.001, 'irs_2wd', 0.017),
               cache_key(B, A, R, S, ss, 0.001, 'identified', 0.0)]
    assert len(set(changed) | {base}) == len(changed) + 1


def test_a_bad_entry_is_computed_again_and_written_again(cache):
    cfg, spec = _inputs('pi')
    good = check_controller(cfg, spec.controller, spec.design)
    [entry] = cache.glob('*.json')
    for text in ('', '{"plant": 3}', 'not json', '{}'):
        entry.write_text(text)
        assert _bits(check_controller(cfg, spec.controller, spec.design)) == _bits(good)
        assert from_json(entry.read_text(), DesignCheck) is not None   # rewritten whole


def test_off_or_unwritable_the_check_still_answers(tmp_path, monkeypatch):
    cfg, spec = _inputs('pi')
    monkeypatch.setenv('IRS_CACHE_DIR', str(tmp_path))
    monkeypatch.setenv('IRS_DESIGN_CACHE', '0')
    assert check_controller(cfg, spec.controller, spec.design).stable
    assert not (tmp_path / 'design_check').exists()
    blocker = tmp_path / 'file'
    blocker.write_text('')                  # a file where the directory would go
    monkeypatch.setenv('IRS_CACHE_DIR', str(blocker))
    monkeypatch.delenv('IRS_DESIGN_CACHE')
    assert check_controller(cfg, spec.controller, spec.design).stable


_FLOAT = st.floats(allow_nan=True, allow_infinity=True) | st.just(-0.0)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(_FLOAT, _FLOAT), min_size=1, max_size=6),
       st.lists(st.tuples(_FLOAT, _FLOAT), min_size=1, max_size=6),
       st.none() | st.lists(st.tuples(_FLOAT, _FLOAT), min_size=1, max_size=6),
       st.lists(_FLOAT, min_size=6, max_size=6), st.text(max_size=20))
def test_json_keeps_every_float(poles, zpoles, delayed, floats, plant):
    def arr(pairs):
        return None if pairs is None else np.array([complex(a, b) for a, b in pairs], complex)
    check = DesignCheck(plant, arr(poles), arr(zpoles), *floats[:4], delay=floats[4],
                        delay_margin=floats[5], delayed_discrete_poles=arr(delayed))
    back = from_json(to_json(check), DesignCheck)     # every float as float.hex
    assert to_json(back) == to_json(check) and back.plant == plant
    assert [float(v).hex() for v in back.poles.view(float)] == \
        [float(v).hex() for v in check.poles.view(float)]


def test_a_second_start_of_a_design_does_not_import_python_control(tmp_path):
    """What the cache is for: the controller's start without python-control's import."""
    code = (
        'import sys\n'
        'from irs_control.controller_factory import CONTROLLER_DEFAULTS, make_controller\n'
        'from irs_control.design_check import check_controller\n'
        'from irs_control.controller_factory import INPUT_CHECK_DEFAULTS\n'
        "cfg = {**CONTROLLER_DEFAULTS, **INPUT_CHECK_DEFAULTS, 'mode': 'mrc',\n"
        "       'include_actuator': True, 'check_plant': 'identified', 'check_delay': 0.017}\n"
        'spec = make_controller({k: v for k, v in cfg.items() if k in CONTROLLER_DEFAULTS})\n'
        'chk = check_controller(cfg, spec.controller, spec.design)\n'
        "print('control' in sys.modules, chk.stable)\n")
    env = {**os.environ, 'IRS_CACHE_DIR': str(tmp_path)}
    env.pop('IRS_DESIGN_CACHE', None)
    runs = [subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                           text=True, timeout=120) for _ in range(2)]
    assert [r.stdout.split() for r in runs] == [['True', 'True'], ['False', 'True']], \
        [r.stderr[-500:] for r in runs]


def test_check_design_itself_is_not_cached(cache):
    """Callers of check_design get the computation; only check_controller reads entries."""
    cfg, spec = _inputs('pi')
    B, A = [363.394 * 29.0], np.polymul([1.0, 29.0], [1.0, 0.0, 0.0, 0.0])
    R, S = np.array([1.0, 0.0]), np.array([cfg['kp'], cfg['ki']])
    ss = spec.controller.linear_state_space()
    direct = check_design(B, A, R, S, ss, 0.001, 'x', 0.017)
    assert not cache.exists()
    assert _bits(cached_check_design(B, A, R, S, ss, 0.001, 'x', 0.017)) == _bits(direct)
    assert len(list(cache.glob('*.json'))) == 1
