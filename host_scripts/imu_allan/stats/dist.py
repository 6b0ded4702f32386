"""The few distribution functions the statistics use, from scipy.special.

scipy.stats would give the same numbers (its chi2, t and F call these very
functions), but importing it parses every distribution's docstring: about
0.7 s of CPU in each ``imu-allan`` process, for five functions. Each one
here is the formula scipy.stats applies inside its argument checks; invalid
arguments (a non-positive degree of freedom, a probability outside 0..1)
give nan, as there.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy import special

Z95 = 1.959963984540054
"""The standard normal's 97.5 % point: a two-sided 95 % interval is +- Z95 sd."""


def _valid(df: ArrayLike, p: ArrayLike | None = None) -> np.ndarray:
    ok = np.asarray(df, dtype=np.float64) > 0
    if p is not None:
        q = np.asarray(p, dtype=np.float64)
        ok = ok & (q >= 0) & (q <= 1)
    return ok


def _out(values: np.ndarray, ok: np.ndarray) -> np.ndarray | float:
    out = np.where(ok, values, np.nan)
    return float(out) if out.ndim == 0 else out


def chi2_ppf(p: ArrayLike, df: ArrayLike) -> np.ndarray | float:
    """Chi-squared quantile: the x with P(X <= x) = p, X ~ chi2(df)."""
    p, df = np.asarray(p, dtype=np.float64), np.asarray(df, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return _out(2.0 * special.gammaincinv(df / 2.0, p), _valid(df, p))


def chi2_sf(x: ArrayLike, df: ArrayLike) -> np.ndarray | float:
    """Chi-squared survival function P(X > x), X ~ chi2(df)."""
    x, df = np.asarray(x, dtype=np.float64), np.asarray(df, dtype=np.float64)
    return _out(np.where(x < 0, 1.0, special.chdtrc(df, np.maximum(x, 0.0))), _valid(df))


def t_ppf(p: ArrayLike, df: ArrayLike) -> np.ndarray | float:
    """Student's t quantile."""
    p, df = np.asarray(p, dtype=np.float64), np.asarray(df, dtype=np.float64)
    q = np.where(p == 0, -np.inf, np.where(p == 1, np.inf, special.stdtrit(df, p)))  # the support's ends
    return _out(q, _valid(df, p))


def f_cdf(x: ArrayLike, dfn: ArrayLike, dfd: ArrayLike) -> np.ndarray | float:
    """F distribution's P(X <= x)."""
    x = np.asarray(x, dtype=np.float64)
    ok = _valid(dfn) & _valid(dfd)
    return _out(np.where(x < 0, 0.0, special.fdtr(dfn, dfd, np.maximum(x, 0.0))), ok)


def f_sf(x: ArrayLike, dfn: ArrayLike, dfd: ArrayLike) -> np.ndarray | float:
    """F distribution's P(X > x)."""
    x = np.asarray(x, dtype=np.float64)
    ok = _valid(dfn) & _valid(dfd)
    return _out(np.where(x < 0, 1.0, special.fdtrc(dfn, dfd, np.maximum(x, 0.0))), ok)
