r"""Small polynomial helpers for continuous-time pole-placement design.

All polynomials are 1-D ``numpy`` arrays of real coefficients, **highest power first**
(the ``numpy.polyval`` / ``control.tf`` convention): ``[1, 3, 2]`` is ``s**2 + 3 s + 2``.
Sums and products are numpy's own (``np.polyadd``, ``np.polysub``, ``np.polymul``); this module
holds what numpy does not do: validation, trimming, exact division, Diophantine equations.

The central routine is :func:`solve_diophantine`, which solves

.. math:: A(s) X(s) + B(s) Y(s) = C(s), \qquad \deg Y < \deg A,

(the minimum-degree solution in ``Y``) through a Sylvester-type linear system.

Bad coefficients: every entry point of the design path validates its polynomials with
:func:`require_polynomial` before any arithmetic (one ``ValueError`` naming the parameter for
NaN/inf, empty, non-numeric or all-zero coefficients), and :func:`trim` itself refuses
non-finite coefficients with a ``ValueError`` instead of failing inside numpy.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    'require_polynomial',
    'trim',
    'poly_from_roots',
    'poly_div_exact',
    'degree',
    'common_roots',
    'convolution_matrix',
    'solve_diophantine',
    'coeff_rel_error',
    'is_hurwitz',
    'DiophantineError',
]


class DiophantineError(ValueError):
    """Raised when the Diophantine equation has no solution of the requested form."""


def require_polynomial(name: str, p, monic: bool = False, hurwitz: bool = False) -> np.ndarray:
    """Validate the coefficient list ``p`` (highest power first) of parameter ``name``.

    Accepted: a non-empty, one-dimensional sequence of finite real numbers that are not all zero
    (leading zeros are trimmed); with ``monic`` the leading (trimmed) coefficient must be 1 (to
    1e-12), with ``hurwitz`` every root must have a negative real part (a stable polynomial).

    Returns
    -------
    numpy.ndarray
        ``trim(p)``.

    Raises
    ------
    ValueError
        With one sentence naming ``name``, what was expected and what was given.
    """
    expected = (f'{name} must be a non-empty list of finite polynomial coefficients, highest '
                'power first, not all zero')
    try:
        arr = np.asarray(p, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{expected}; got {p!r}.') from None
    if arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr)) or not np.any(arr != 0.0):
        raise ValueError(f'{expected}; got {p!r}.')
    arr = trim(arr)
    if monic and abs(arr[0] - 1.0) > 1e-12:
        raise ValueError(f'{name} must be monic (leading coefficient 1); got {arr.tolist()}.')
    if hurwitz and arr.size > 1 and not np.all(np.real(np.roots(arr)) < 0.0):
        raise ValueError(f'{name} must be stable (all roots with negative real part); got roots '
                         f'{np.roots(arr)} of {arr.tolist()}.')
    return arr


def trim(p, tol: float = 0.0) -> np.ndarray:
    """Remove leading coefficients whose magnitude is <= ``tol * max|p|``.

    Parameters
    ----------
    p : array_like
        Coefficients, highest power first.
    tol : float
        Relative tolerance; ``0`` removes exact zeros only.

    Returns
    -------
    numpy.ndarray
        Trimmed coefficients (``[0.0]`` for the zero polynomial).

    Raises
    ------
    ValueError
        A coefficient is NaN or infinite.
    """
    p = np.atleast_1d(np.asarray(p, dtype=float))
    if p.size == 0:
        return np.array([0.0])
    if not np.all(np.isfinite(p)):
        raise ValueError(f'Polynomial coefficients must be finite numbers; got {p.tolist()}.')
    scale = np.max(np.abs(p))
    if scale == 0.0:
        return np.array([0.0])
    nz = np.nonzero(np.abs(p) > tol * scale)[0]
    return p[nz[0]:].copy()


def degree(p) -> int:
    """Degree of ``p`` after removing exact leading zeros (zero polynomial: 0)."""
    return trim(p).size - 1


def poly_from_roots(roots, gain: float = 1.0) -> np.ndarray:
    """Real polynomial ``gain * prod(s - r_i)``.

    Complex roots must come in conjugate pairs; the imaginary round-off is discarded.
    An empty root list gives the constant ``[gain]``.
    """
    roots = np.atleast_1d(np.asarray(roots, dtype=complex))
    if roots.size == 0:
        return np.array([float(gain)])
    p = np.poly(roots)
    if np.max(np.abs(np.imag(p))) > 1e-8 * max(1.0, np.max(np.abs(p))):
        raise ValueError(
            'poly_from_roots expected complex roots in conjugate pairs so that the '
            f'polynomial is real; got roots {roots}.'
        )
    return gain * np.real(p)


def _align(a, b):
    a = np.atleast_1d(np.asarray(a, dtype=float))
    b = np.atleast_1d(np.asarray(b, dtype=float))
    n = max(a.size, b.size)
    return np.pad(a, (n - a.size, 0)), np.pad(b, (n - b.size, 0))


def poly_div_exact(num, den, rtol: float = 1e-8):
    """Divide ``num`` by ``den``; return ``(quotient, exact)``.

    ``exact`` is True when the remainder is below ``rtol`` times the size of ``num``
    (i.e. ``den`` divides ``num`` to numerical precision).
    """
    num = trim(num)
    den = trim(den)
    q, r = np.polydiv(num, den)
    scale = max(np.max(np.abs(num)), 1e-300)
    exact = bool(np.max(np.abs(r)) <= rtol * scale)
    return trim(q), exact


def common_roots(a, b, tol: float = 1e-6) -> list:
    """Roots of ``a`` that are also roots of ``b`` (within ``tol * max(1, |root|)``).

    Returns
    -------
    list of complex
        The common roots (one entry per matching root of ``a``).
    """
    ra = np.roots(trim(a)) if degree(a) > 0 else np.array([])
    rb = np.roots(trim(b)) if degree(b) > 0 else np.array([])
    out = []
    for r in ra:
        if rb.size and np.min(np.abs(rb - r)) <= tol * max(1.0, abs(r)):
            out.append(complex(r))
    return out


def convolution_matrix(p, ncols: int, nrows: int) -> np.ndarray:
    """Matrix ``M`` with ``M @ x == np.polymul(p, x)`` right-aligned in ``nrows`` rows.

    ``x`` has ``ncols`` coefficients (highest power first).
    """
    p = np.atleast_1d(np.asarray(p, dtype=float))
    M = np.zeros((nrows, ncols))
    for j in range(ncols):
        e = np.zeros(ncols)
        e[j] = 1.0
        v = np.convolve(p, e)
        if v.size > nrows:
            if np.any(v[: v.size - nrows] != 0):
                raise ValueError('convolution_matrix: product does not fit in nrows rows.')
            v = v[v.size - nrows:]
        M[nrows - v.size:, j] = v
    return M


def solve_diophantine(A, B, C, rtol: float = 1e-9):
    """Minimum-degree solution of ``A X + B Y = C`` with ``deg Y < deg A``.

    The unknown coefficients of ``X`` (degree ``deg C - deg A``) and ``Y`` (degree
    ``deg A - 1``) are stacked in a Sylvester-type system and solved by least squares
    with column scaling; the residual is then checked.

    Parameters
    ----------
    A, B, C : array_like
        Polynomials, highest power first. ``A`` and ``B`` must be coprime.
    rtol : float
        Allowed relative residual ``|A X + B Y - C| / |C|`` (max-norm on coefficients).

    Returns
    -------
    X, Y : numpy.ndarray
        Solution polynomials.

    Raises
    ------
    DiophantineError
        If ``deg C < deg A`` or no exact solution of that degree exists (e.g. the
        observer polynomial is of too low degree, or ``A`` and ``B`` share a root).

    Examples
    --------
    Double integrator ``A = s**2``, ``B = 1``, ``C = (s + 1)**3``:
    ``X = s + 3``, ``Y = 3 s + 1`` because ``s**2 (s + 3) + 3 s + 1 = s**3 + 3 s**2 + 3 s + 1``.
    """
    A, B, C = trim(A), trim(B), trim(C)
    nA, nB, nC = A.size - 1, B.size - 1, C.size - 1
    if nA < 1:
        raise DiophantineError('solve_diophantine expected deg A >= 1 (a dynamic plant).')
    nX = nC - nA
    if nX < 0:
        raise DiophantineError(
            f'deg C = {nC} is lower than deg A = {nA}; the desired closed-loop polynomial '
            'must have at least the degree of A (raise the observer degree).'
        )
    nY = nA - 1
    nrows = max(nC, nA + nX, nB + nY) + 1
    MA = convolution_matrix(A, nX + 1, nrows)
    MB = convolution_matrix(B, nY + 1, nrows)
    M = np.hstack([MA, MB])
    rhs = np.pad(C, (nrows - C.size, 0))
    # Equilibrate rows and columns, solve, then refine iteratively (coefficients span
    # ~1e0..1e7 in the paper case; plain lstsq leaves ~1e-9 relative errors).
    cs = np.max(np.abs(M), axis=0)
    cs[cs == 0] = 1.0
    Ms = M / cs
    rs = np.max(np.abs(Ms), axis=1)
    rs[rs == 0] = 1.0
    Ms = Ms / rs[:, None]
    sol = np.zeros(M.shape[1])
    for _ in range(3):
        r = (rhs - M @ sol) / rs
        d, *_ = np.linalg.lstsq(Ms, r, rcond=None)
        sol = sol + d / cs
    X, Y = sol[: nX + 1], sol[nX + 1:]
    res = M @ sol - rhs
    rel = np.max(np.abs(res)) / max(np.max(np.abs(C)), 1e-300)
    if not np.isfinite(rel) or rel > rtol:
        raise DiophantineError(
            'A X + B Y = C has no solution with deg X = deg C - deg A and deg Y < deg A '
            f'(relative residual {rel:.2e}); usually deg C is too low for deg B '
            '(choose an observer polynomial of higher degree) or A and B share a root.'
        )
    return X, Y


def coeff_rel_error(p, q) -> float:
    """Max relative coefficient error ``max|p - q| / max|q|`` after right alignment."""
    p, q = _align(trim(p), trim(q))
    return float(np.max(np.abs(p - q)) / max(np.max(np.abs(q)), 1e-300))


def is_hurwitz(p) -> bool:
    """True when all roots of ``p`` have strictly negative real part."""
    p = trim(p)
    if p.size == 1:
        return True
    return bool(np.all(np.real(np.roots(p)) < 0.0))
