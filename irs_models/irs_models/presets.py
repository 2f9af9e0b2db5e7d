"""Named vehicle presets (``config/presets.yaml``) and the pole/zero fitting tool.

Pure Python; no rclpy.

Presets
-------
``irs_2wd``, ``irs_4ws``, ``irs_iwt``
    The three IRS 1:10 cars.  Geometry/mass are *assumed* (typical 1:10 touring chassis), the
    tyre and inertia numbers are the best fit, inside plausible bounds, to the paper's Eq. (6).
``full_size_sedan``, ``compact_sedan``, ``pontiac_6000ste``, ``ford_taurus_sho``
    Full-size comparison vehicles fitted to Eqs. (7)-(10).

Every preset in the YAML stores its parameters, the speed ``V`` and sensor distance ``ds`` it was
fitted at, and the published target poles/zeros, so tests can recompute the error.

:func:`fit_preset` adjusts (m, I_z, l_f, l_r, C_f, C_r) inside bounds so that the bicycle
model's quadratic pole and zero factors (Eq. 5 without the s^2 integrators) match the published
roots. The presets exist so that the rig, the studies and the similitude comparison name their
cars instead of repeating numbers (docs/vehicle_presets.md).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
import functools
import itertools
import math
import os

import numpy as np
import yaml

from .bicycle import BicycleParams, zpk

__all__ = [
    'Preset',
    'FitResult',
    'PARAM_NAMES',
    'default_presets_path',
    'load_presets',
    'list_presets',
    'get_preset',
    'fit_preset',
    'root_errors',
    'parse_roots',
    'vehicle_roots',
]

#: The six model parameters the fit adjusts, in order.
PARAM_NAMES = ('mass', 'yaw_inertia', 'lf', 'lr', 'c_f', 'c_r')


def default_presets_path() -> str:
    """Path of ``config/presets.yaml`` (source tree, else the ament share directory)."""
    here = os.path.dirname(os.path.abspath(__file__))
    cand = os.path.join(os.path.dirname(here), 'config', 'presets.yaml')
    if os.path.isfile(cand):
        return cand
    try:  # installed package
        from ament_index_python.packages import get_package_share_directory

        share = os.path.join(get_package_share_directory('irs_models'), 'config', 'presets.yaml')
        if os.path.isfile(share):
            return share
    except Exception:  # pragma: no cover - only without the source tree
        pass
    return cand


def parse_roots(values) -> np.ndarray:
    """Parse a YAML list of roots (numbers or strings like ``'-2.51+5.40j'``) to complex."""
    out = []
    for v in values:
        if isinstance(v, str):
            out.append(complex(v.replace(' ', '').replace('i', 'j')))
        else:
            out.append(complex(v))
    return np.array(out, dtype=complex)


def vehicle_roots(roots, tol: float = 1e-9) -> np.ndarray:
    """Drop the (exact) integrators at the origin."""
    r = np.asarray(roots, dtype=complex)
    return r[np.abs(r) > tol]


def root_errors(fitted, target) -> np.ndarray:
    """Relative error ``|f - t| / |t|`` per target root, best one-to-one pairing.

    Both arrays must have the same length (<= 6; brute force over permutations).
    """
    f = np.asarray(fitted, dtype=complex)
    t = np.asarray(target, dtype=complex)
    if f.shape != t.shape:
        raise ValueError(
            f'fitted and target root sets must have the same size, got {f.size} and {t.size}.'
        )
    if t.size == 0:
        return np.zeros(0)
    best = None
    for perm in itertools.permutations(range(f.size)):
        e = np.abs(f[list(perm)] - t) / np.maximum(np.abs(t), 1e-12)
        if best is None or e.max() < best.max():
            best = e
    return best


@dataclass
class Preset:
    """One named vehicle preset."""

    name: str
    params: BicycleParams
    speed: float
    ds: float
    description: str = ''
    kind: str = 'full_size'  # 'scale' or 'full_size'
    features: dict = field(default_factory=dict)
    target: dict | None = None  # {'poles': [...], 'zeros': [...], 'source': str, ...}
    fit: dict | None = None  # stored fit metadata (bounds, reported residual, ...)

    @property
    def target_poles(self) -> np.ndarray:
        return parse_roots(self.target['poles']) if self.target else np.zeros(0, complex)

    @property
    def target_zeros(self) -> np.ndarray:
        return parse_roots(self.target['zeros']) if self.target else np.zeros(0, complex)

    def zpk(self, speed=None, ds=None, axle='front', actuator_pole=None):
        """Zeros, poles, gain at the preset's (or the given) speed and ds."""
        return zpk(self.params, self.speed if speed is None else speed,
                   self.ds if ds is None else ds, axle, actuator_pole)

    def errors(self):
        """(pole_errors, zero_errors) of the model vs the stored target, integrators excluded."""
        z, p, _ = self.zpk()
        return (root_errors(vehicle_roots(p), vehicle_roots(self.target_poles)),
                root_errors(z, self.target_zeros))


@functools.lru_cache(maxsize=8)
def _parsed(path: str, mtime_ns: int, size: int):
    """The YAML document of ``path`` as it is at (``mtime_ns``, ``size``)."""
    with open(path, 'r', encoding='utf-8') as fh:
        return yaml.safe_load(fh)


def load_presets(path: str | None = None) -> dict:
    """Load all presets from YAML. Returns ``{name: Preset}``.

    The file is parsed once per process for each (path, modification time, size): a rig looks
    its car up several times as it is built (18 ms per parse), and a sweep builds one per
    point. Every call returns new ``Preset`` objects built from a copy of the parsed document,
    so a caller may change what it gets.
    """
    path = path or default_presets_path()
    st = os.stat(path)
    data = copy.deepcopy(_parsed(os.path.abspath(path), st.st_mtime_ns, st.st_size))
    if not isinstance(data, dict) or 'presets' not in data:
        raise ValueError(f"{path} must contain a top-level 'presets' mapping.")
    out = {}
    for name, d in data['presets'].items():
        try:
            params = BicycleParams(**d['params'])
            out[name] = Preset(
                name=name,
                params=params,
                speed=float(d['speed']),
                ds=float(d['ds']),
                description=str(d.get('description', '')),
                kind=str(d.get('kind', 'full_size')),
                features=dict(d.get('features', {})),
                target=d.get('target'),
                fit=d.get('fit'),
            )
        except (KeyError, TypeError) as exc:
            raise ValueError(
                f'preset {name!r} in {path} is missing or has a bad field: {exc}.'
            ) from exc
    return out


def list_presets(path: str | None = None) -> list:
    """Sorted preset names."""
    return sorted(load_presets(path))


def get_preset(name: str, path: str | None = None) -> Preset:
    """Preset by name; ``KeyError`` with the list of valid names otherwise."""
    presets = load_presets(path)
    if name not in presets:
        raise KeyError(f"unknown preset {name!r}; available presets: {', '.join(sorted(presets))}")
    return presets[name]


# --------------------------------------------------------------------------------------------
# fitting
# --------------------------------------------------------------------------------------------
@dataclass
class FitResult:
    """Result of :func:`fit_preset`."""

    params: dict  # the six fitted parameters
    poles: np.ndarray  # fitted vehicle poles (integrators excluded)
    zeros: np.ndarray
    pole_errors: np.ndarray  # relative error per target pole
    zero_errors: np.ndarray
    coef_residual: np.ndarray  # relative residuals of [a1, a0, b1, b0]
    at_bounds: list  # names of parameters that ended on a bound
    success: bool

    @property
    def max_error(self) -> float:
        """Largest relative pole/zero error."""
        return float(
            max(np.max(self.pole_errors, initial=0.0), np.max(self.zero_errors, initial=0.0))
        )


def _monic_quadratic(roots):
    r = np.asarray(roots, dtype=complex)
    if r.size != 2:
        raise ValueError(f'expected exactly 2 non-zero target roots, got {r.size}: {r}.')
    c = np.real_if_close(np.poly(r), tol=1e6)
    if np.iscomplexobj(c):
        raise ValueError(f'target roots {r} must be real or a complex-conjugate pair.')
    return np.asarray(c[1:], dtype=float)


def _model_coeffs(x, speed, ds):
    m, iz, lf, lr, cf, cr = x
    V = speed
    L = lf + lr
    a1 = (cf + cr) / (m * V) + (cf * lf**2 + cr * lr**2) / (iz * V)
    a0 = cf * cr * L**2 / (m * iz * V**2) + (cr * lr - cf * lf) / iz
    je = iz + m * lf * ds
    b1 = cr * L * (lr + ds) / (V * je)
    b0 = cr * L / je
    return np.array([a1, a0, b1, b0])


#: Fits whose least-squares costs differ by less than this are equally good (residuals of
#: 1e-10 relative): :func:`fit_preset` then takes the one nearest the nominal.
TIE_COST = 1e-20


def fit_preset(target_poles, target_zeros, speed: float, ds: float, bounds: dict,
               x0: dict | None = None, reg: float = 1e-3, track: float = 1.0,
               wheel_radius: float = 0.3, rear_steer: bool = False,
               objective: str = 'coeffs') -> FitResult:
    """Fit (m, I_z, l_f, l_r, C_f, C_r) to published front-steer poles/zeros.

    Parameters
    ----------
    target_poles, target_zeros : sequence of complex
        Published poles (integrators at 0 are ignored) and zeros of Y_s/delta_f.  Exactly two
        non-zero poles and two zeros.
    speed, ds : float
        Forward speed [m/s] and sensor distance [m] the targets refer to.
    bounds : dict
        ``{name: (lo, hi)}`` for every name in :data:`PARAM_NAMES`; ``lo == hi`` fixes it.
    x0 : dict, optional
        Nominal/start values (default: geometric mean of the bounds).  Also the regularisation
        centre.
    reg : float
        Weight of the log-space pull towards ``x0`` (resolves the scale freedom).
    objective : {'coeffs', 'roots'}
        ``'coeffs'`` (default): relative residuals of the monic quadratic coefficients (smooth;
        exact when an exact match exists).  ``'roots'``: relative complex root errors
        ``(f - t)/|t|`` with best pairing -- better when no exact match exists (scale car).
    track, wheel_radius, rear_steer :
        Passed through to the :class:`BicycleParams` used to evaluate the fit.

    Returns
    -------
    FitResult

    Notes
    -----
    :func:`fit_preset` adjusts (m, I_z, l_f, l_r, C_f, C_r) inside bounds so that the monic
    quadratic factors of the bicycle model (Eq. 5 with the s^2 integrators removed)::

        den:  s^2 + a1 s + a0,   a1 = (C_f + C_r)/(m V) + (C_f l_f^2 + C_r l_r^2)/(I_z V)
                                 a0 = C_f C_r L^2/(m I_z V^2) + (C_r l_r - C_f l_f)/I_z
        num:  s^2 + b1 s + b0,   b1 = C_r L (l_r + d_s) / (V (I_z + m l_f d_s))
                                 b0 = C_r L / (I_z + m l_f d_s)

    match those built from the target roots (``a1 = -(p1 + p2)``, ``a0 = p1 p2``, etc.).  The
    coefficient residuals are relative, and a weak log-space regularisation towards the nominal
    parameters removes the one-parameter scale freedom (poles and zeros are unchanged if m, I_z,
    C_f and C_r are all multiplied by the same factor) so the answer is unique and near the
    nominal. Since ``b1 / b0 = (l_r + d_s) / V``, the *zeros alone* fix ``l_r + d_s`` for a given
    speed.
    """
    from scipy.optimize import least_squares

    tp = vehicle_roots(parse_roots(target_poles))
    tz = parse_roots(target_zeros)
    a_t = _monic_quadratic(tp)
    b_t = _monic_quadratic(tz)
    tgt = np.concatenate([a_t, b_t])
    missing = [n for n in PARAM_NAMES if n not in bounds]
    if missing:
        raise ValueError(f'bounds must give (lo, hi) for every parameter; missing {missing}.')
    lo = np.array([float(bounds[n][0]) for n in PARAM_NAMES])
    hi = np.array([float(bounds[n][1]) for n in PARAM_NAMES])
    if np.any(lo <= 0) or np.any(hi < lo):
        raise ValueError('bounds must satisfy 0 < lo <= hi for every parameter.')
    if x0 is None:
        xn = np.sqrt(lo * hi)
    else:
        xn = np.array([float(x0[n]) for n in PARAM_NAMES])
    xn = np.clip(xn, lo, hi)
    free = hi > lo
    log_lo, log_hi, log_n = np.log(lo), np.log(hi), np.log(xn)

    def full(z):
        lx = log_n.copy()
        lx[free] = z
        return np.exp(lx)

    if objective not in ('coeffs', 'roots'):
        raise ValueError(f"objective must be 'coeffs' or 'roots', got {objective!r}.")

    def root_res(c):
        out = []
        for (c1, c0), t in ((c[:2], tp), (c[2:], tz)):
            f = np.roots([1.0, c1, c0]).astype(complex)
            best_r = None
            for perm in itertools.permutations(range(2)):
                e = (f[list(perm)] - t) / np.abs(t)
                if best_r is None or np.sum(np.abs(e) ** 2) < np.sum(np.abs(best_r) ** 2):
                    best_r = e
            out.extend([best_r.real, best_r.imag])
        return np.concatenate(out)

    def resid(z):
        x = full(z)
        c = _model_coeffs(x, speed, ds)
        r = (c - tgt) / np.abs(tgt) if objective == 'coeffs' else root_res(c)
        return np.concatenate([r, reg * (z - log_n[free])])

    # a few starts (nominal + corners-ish) for robustness; deterministic. Poles and zeros do
    # not always fix the vehicle: two exact fits can exist (e.g. I_z = 2400 and 1810 kg m^2
    # for the same poles and zeros, with a 3 % different gain, test_models_presets.py), and
    # which start finds which is a matter of rounding. Of the fits equally good (cost within
    # TIE_COST), the one nearest the nominal x0 (in log space) is taken.
    starts = [log_n[free]]
    for frac in (0.25, 0.75):
        starts.append(log_lo[free] + frac * (log_hi[free] - log_lo[free]))
    sols = [least_squares(resid, z0, bounds=(log_lo[free], log_hi[free]), xtol=1e-14,
                          ftol=1e-14, gtol=1e-14, max_nfev=20000) for z0 in starts]
    low = min(sol.cost for sol in sols)
    best = min((sol for sol in sols if sol.cost <= low + TIE_COST),
               key=lambda sol: float(np.sum((sol.x - log_n[free]) ** 2)))
    x = full(best.x)
    pdict = dict(zip(PARAM_NAMES, (float(v) for v in x)))
    bp = BicycleParams(track=track, wheel_radius=wheel_radius, rear_steer=rear_steer, **pdict)
    z, p, _ = zpk(bp, speed, ds)
    p = vehicle_roots(p)
    pe = root_errors(p, tp)
    ze = root_errors(z, tz)
    coef = (_model_coeffs(x, speed, ds) - tgt) / np.abs(tgt)
    tol = 1e-6
    at_b = [n for n, v, a, b, f in zip(PARAM_NAMES, x, lo, hi, free)
            if f and (abs(math.log(v / a)) < tol or abs(math.log(v / b)) < tol)]
    return FitResult(params=pdict, poles=p, zeros=z, pole_errors=pe, zero_errors=ze,
                     coef_residual=coef, at_bounds=at_b, success=bool(best.success))


def _fmt(r):
    r = complex(r)
    if abs(r.imag) < 1e-12:
        return f'{r.real:.4g}'
    return f'{r.real:.4g}{r.imag:+.4g}j'


def refit_all(path: str | None = None, verbose: bool = True) -> dict:
    """Re-run every stored fit (bounds/nominal/targets from the YAML) and print a table.

    This is the "fitting script": ``python -m irs_models.presets``.  It does not write the
    YAML; copy the numbers by hand so the file keeps its comments.
    """
    path = path or default_presets_path()
    with open(path, 'r', encoding='utf-8') as fh:
        data = yaml.safe_load(fh)
    results = {}
    for name, d in data['presets'].items():
        fit = d.get('fit')
        tgt = d.get('target')
        if not fit or not tgt or 'bounds' not in fit:
            continue
        res = fit_preset(tgt['poles'], tgt['zeros'], float(d['speed']), float(d['ds']),
                         fit['bounds'], x0=fit.get('nominal'),
                         objective=fit.get('objective', 'coeffs'), track=d['params']['track'],
                         wheel_radius=d['params']['wheel_radius'],
                         rear_steer=d['params']['rear_steer'])
        results[name] = res
        if verbose:
            print(
                f'{name}: V={d["speed"]} ds={d["ds"]}  max rel err={res.max_error:.4f}  at '
                f'bounds={res.at_bounds}'
            )
            print('   ' + '  '.join(f'{k}={v:.6g}' for k, v in res.params.items()))
            print(
                '   poles '
                + ', '.join(_fmt(v) for v in res.poles)
                + '   zeros '
                + ', '.join(_fmt(v) for v in res.zeros)
            )
            print('   pole err ' + np.array2string(res.pole_errors, precision=4) + '  zero err '
                  + np.array2string(res.zero_errors, precision=4))
    return results


if __name__ == '__main__':  # pragma: no cover
    refit_all()
