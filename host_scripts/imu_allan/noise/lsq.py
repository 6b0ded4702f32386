"""The least squares of the noise fits (terms.py's IEEE 952 fit and the whole-curve fit):
the Cholesky factor of the estimates' covariance, unconstrained least squares and the
non-negative one, each on unit-norm columns (the terms' columns differ in scale by up to 1e20)."""

from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
from scipy import optimize


def _cholesky(S: np.ndarray) -> np.ndarray:
    d = np.sqrt(S.reshape(-1)[:: S.shape[0] + 1])
    C = S / (d[:, None] * d[None, :])
    for jitter in (0.0, 1e-9, 1e-6, 1e-3, 1e-2):
        try:
            return np.linalg.cholesky(C + jitter * np.eye(C.shape[0]) if jitter else C) * d[:, None]
        except np.linalg.LinAlgError:
            continue
    w, V = np.linalg.eigh(C)  # last resort: clip the spectrum
    C2 = (V * np.maximum(w, 1e-3)) @ V.T
    return np.linalg.cholesky(C2) * d[:, None]


def _least_squares(X: np.ndarray, y: Optional[np.ndarray] = None) -> tuple[Optional[np.ndarray], np.ndarray]:
    """Unconstrained least squares min |X c - y| (c None without y) and the inverse of X'X,
    computed on unit-norm columns: the terms' columns differ in scale by up to 1e20."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    inv = np.linalg.pinv(Xs.T @ Xs)
    c = None if y is None else (inv @ (Xs.T @ y)) / scale
    return c, inv / np.outer(scale, scale)


def _nnls(Aw: np.ndarray, yw: np.ndarray, ub: Optional[np.ndarray] = None) -> np.ndarray:
    """min |Aw c - yw| with 0 <= c (<= ub, the caps that keep each term's line under the curve)."""
    scale = np.sqrt(np.add.reduce(Aw * Aw, axis=0))  # the columns' norms (numpy.linalg.norm's sum)
    norms = scale.tolist()  # the few norms as floats: cheaper to test than numpy's reductions
    if 0.0 in norms:
        scale[scale == 0] = 1.0
    if ub is None or not np.any(np.isfinite(ub)):
        maxiter = 50 * max(Aw.shape[1], 1)
        # finite norms: Aw finite (a norm overflowing sends a finite Aw to scipy's own call, the same solve)
        if _NNLS is not None and all(map(math.isfinite, norms)) and all(map(math.isfinite, yw.tolist())):
            c, _, info = _NNLS(np.ascontiguousarray(Aw / scale), np.ascontiguousarray(yw, dtype=np.float64), maxiter)
            if info != 3:  # else scipy's own call, which says so
                return c / scale
        c, _ = optimize.nnls(Aw / scale, yw, maxiter=maxiter)
        return c / scale
    hi = np.where(np.isfinite(ub), ub * scale, np.inf)
    r = optimize.lsq_linear(
        Aw / scale,
        yw,
        bounds=(np.zeros(hi.size), np.maximum(hi, 1e-300)),
        method="bvls",
    )
    return np.clip(r.x, 0.0, hi) / scale


def _nnls_kernel() -> Optional[Callable]:
    """scipy.optimize.nnls's own solver without its argument checks, which cost twice the
    solve on the fit's problems (twenty points, a few columns; the fit solves thousands):
    where scipy has it (1.15 on) and it answers a problem as scipy.optimize.nnls does, else
    None (that function then)."""
    try:
        from scipy.optimize._nnls import _nnls as kernel

        A = np.array([[1.0, 0.0, 2.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0], [2.0, 0.0, 1.0]])
        b = np.array([2.0, -1.0, 1.0, 3.0])
        x, rnorm, info = kernel(A, b, 150)
        ok = np.array_equal(x, optimize.nnls(A, b, maxiter=150)[0]) and info != 3
    except Exception:  # a scipy without it, or with another form of it
        return None
    return kernel if ok else None


_NNLS = _nnls_kernel()
