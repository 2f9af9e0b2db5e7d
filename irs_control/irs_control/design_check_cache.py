r"""The start-up design check's answers kept on disk (no rclpy).

:func:`~.design_check.check_design` needs python-control, whose import (with ``scipy.signal``
and matplotlib) is 1.4-2 s of the 2-2.6 s a ``lateral_controller`` takes to start on the 2-core
VM, paid again at every start of the same design. Its answer is a function of its inputs only:
the loop's polynomials ``B, A, R, S``, the controller's discrete state space, the sample period,
the plant's name and the transport delay, computed by python-control, scipy and numpy. So
:func:`~.design_check.cached_check_design` keeps each answer (:func:`store`) in a JSON file
named by the SHA-256 of

- every input, floats written exactly (``float.hex``);
- the versions of python-control, scipy and numpy (from their installed metadata, without
  importing them);
- the source of :mod:`.design_check` and of this module,

and reads it back (:func:`load`) at the next start with the same inputs: the same
:class:`~.design_check.DesignCheck`, every float to the bit
(``irs_control/test/test_design_check_cache.py``). This module does not import
:mod:`.design_check`: the class comes in as an argument.

Directory: ``$IRS_CACHE_DIR/design_check``, else ``$XDG_CACHE_HOME/irs/design_check``, else
``~/.cache/irs/design_check``. ``IRS_DESIGN_CACHE=0`` turns the cache off. A missing,
unreadable or malformed entry is computed again and written again; a directory that cannot be
written only loses the speed-up. A file is written to a temporary name and renamed, so a process
never reads half an entry, and two processes that start the same design at once write the same
bytes.
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

__all__ = ['cache_dir', 'cache_key', 'load', 'store', 'to_json', 'from_json']

#: Libraries whose results the answer depends on (their versions are part of the key).
LIBRARIES = ('control', 'scipy', 'numpy')
_FLOATS = ('gain_margin', 'phase_margin', 'wcg', 'wcp', 'delay', 'delay_margin')
_ARRAYS = ('poles', 'discrete_poles', 'delayed_discrete_poles')


def cache_dir() -> Path | None:
    """Where entries go; ``None`` when ``IRS_DESIGN_CACHE=0``."""
    if os.environ.get('IRS_DESIGN_CACHE', '1').strip() == '0':
        return None
    base = os.environ.get('IRS_CACHE_DIR')
    if base:
        return Path(base) / 'design_check'
    xdg = os.environ.get('XDG_CACHE_HOME') or os.path.join(os.path.expanduser('~'), '.cache')
    return Path(xdg) / 'irs' / 'design_check'


def _hex_array(a) -> list:
    return [float(v).hex() for v in np.asarray(a, float).ravel()] + [list(np.shape(a))]


def cache_key(B, A, R, S, controller_ss, dt, plant, delay) -> str:
    """SHA-256 (hex) of the inputs, the libraries' versions and the check's source."""
    versions = []
    for name in LIBRARIES:
        try:
            versions.append(metadata.version(name))
        except metadata.PackageNotFoundError:
            versions.append('')
    here = Path(__file__).resolve().parent
    sources = [hashlib.sha256((here / f).read_bytes()).hexdigest()
               for f in ('design_check.py', 'design_check_cache.py')]
    doc = {'B': _hex_array(B), 'A': _hex_array(A), 'R': _hex_array(R), 'S': _hex_array(S),
           'ss': [_hex_array(m) for m in controller_ss], 'dt': float(dt).hex(),
           'plant': str(plant), 'delay': float(delay).hex(), 'versions': versions,
           'sources': sources}
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def to_json(check) -> str:
    """A :class:`~.design_check.DesignCheck` as JSON, every float exact (``float.hex``)."""
    doc = {'plant': check.plant}
    for name in _FLOATS:
        doc[name] = float(getattr(check, name)).hex()
    for name in _ARRAYS:
        value = getattr(check, name)
        doc[name] = None if value is None else [
            [float(z.real).hex(), float(z.imag).hex()] for z in np.asarray(value, complex)]
    return json.dumps(doc, sort_keys=True)


def from_json(text: str, cls):
    """The ``cls`` (:class:`~.design_check.DesignCheck`) :func:`to_json` wrote (``ValueError``
    if the text is not one).
    """
    try:
        doc = json.loads(text)
        kwargs = {name: float.fromhex(doc[name]) for name in _FLOATS}
        for name in _ARRAYS:
            pairs = doc[name]
            kwargs[name] = None if pairs is None else np.array(
                [complex(float.fromhex(re), float.fromhex(im)) for re, im in pairs], complex)
        if kwargs['poles'] is None or kwargs['discrete_poles'] is None:
            raise ValueError('poles missing')
        return cls(plant=str(doc['plant']), **kwargs)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f'not a design-check entry: {exc}') from None


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix='.tmp-', suffix='.json')
    try:
        with os.fdopen(fd, 'w') as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _path(key: str) -> Path | None:
    directory = cache_dir()
    return None if directory is None else directory / f'{key}.json'


def load(key: str, cls):
    """The entry of ``key`` as a ``cls``; ``None`` when the cache is off or the entry missing,
    unreadable or malformed.
    """
    path = _path(key)
    if path is None:
        return None
    try:
        return from_json(path.read_text(), cls)
    except (OSError, ValueError):
        return None


def store(key: str, check) -> None:
    """Write ``check`` as the entry of ``key`` (nothing when the cache is off or the directory
    cannot be written).
    """
    path = _path(key)
    if path is None:
        return
    try:
        _write(path, to_json(check))
    except OSError:
        pass
