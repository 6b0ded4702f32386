"""The Nelder-Mead search of the whole-curve fit (curve._optimize): scipy.optimize's own
algorithm (``minimize(method="Nelder-Mead")`` without bounds, callback or adaptive
coefficients; Nelder and Mead 1965, Gao and Han 2012's defaults rho = 1, chi = 2,
psi = sigma = 1/2), step for step and with the same arithmetic, so that it returns the
very point scipy returns, without the wrappers scipy runs at every step (an
intermediate result object, a callback check, a copy of each point): on the fit's
problems (two to five parameters, each step one least-squares solve of a few
microseconds' arithmetic) they cost about a tenth of the search."""

from __future__ import annotations

from typing import Callable

import numpy as np

_RHO, _CHI, _PSI, _SIGMA = 1, 2, 0.5, 0.5
_NONZDELT, _ZDELT = 0.05, 0.00025


class _Spent(Exception):
    """The evaluations allowed are spent (scipy's _MaxFuncCallError)."""


def nelder_mead(
    fun: Callable[[np.ndarray], float], x0: np.ndarray, xatol: float, fatol: float, maxfev: int
) -> tuple[np.ndarray, float]:
    """(x, f(x)) of the best vertex, as scipy.optimize.minimize(fun, x0, method="Nelder-Mead",
    options={"xatol", "fatol", "maxfev"}) gives them (its x and fun).  ``fun`` must not
    change the array it is given (scipy hands it a copy)."""
    x0 = np.asarray(np.atleast_1d(x0), dtype=np.float64).flatten()
    n = len(x0)
    sim = np.empty((n + 1, n), dtype=x0.dtype)
    sim[0] = x0
    for k in range(n):
        y = np.array(x0, copy=True)
        y[k] = (1 + _NONZDELT) * y[k] if y[k] != 0 else _ZDELT
        sim[k + 1] = y
    fsim = np.full((n + 1,), np.inf, dtype=float)
    calls = [0]

    def f(x: np.ndarray) -> float:
        if calls[0] >= maxfev:
            raise _Spent
        calls[0] += 1
        return fun(x)

    try:
        for k in range(n + 1):
            fsim[k] = f(sim[k])
    except _Spent:
        pass
    ind = np.argsort(fsim)
    sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)
    while calls[0] < maxfev:
        try:
            if np.max(np.ravel(np.abs(sim[1:] - sim[0]))) <= xatol and np.max(np.abs(fsim[0] - fsim[1:])) <= fatol:
                break
            _step(f, sim, fsim, n)
        except _Spent:
            pass
        ind = np.argsort(fsim)
        sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)
    return sim[0], float(np.min(fsim))


def _step(f: Callable[[np.ndarray], float], sim: np.ndarray, fsim: np.ndarray, n: int) -> None:
    """One step of the search (reflect, expand, contract or shrink), sim and fsim in place."""
    xbar = np.add.reduce(sim[:-1], 0) / n
    xr = (1 + _RHO) * xbar - _RHO * sim[-1]
    fxr = f(xr)
    if fxr < fsim[0]:
        xe = (1 + _RHO * _CHI) * xbar - _RHO * _CHI * sim[-1]
        fxe = f(xe)
        sim[-1], fsim[-1] = (xe, fxe) if fxe < fxr else (xr, fxr)
        return
    if fxr < fsim[-2]:
        sim[-1], fsim[-1] = xr, fxr
        return
    if fxr < fsim[-1]:  # contraction outside
        xc = (1 + _PSI * _RHO) * xbar - _PSI * _RHO * sim[-1]
        fxc = f(xc)
        if fxc <= fxr:
            sim[-1], fsim[-1] = xc, fxc
            return
    else:  # inside
        xcc = (1 - _PSI) * xbar + _PSI * sim[-1]
        fxcc = f(xcc)
        if fxcc < fsim[-1]:
            sim[-1], fsim[-1] = xcc, fxcc
            return
    for j in range(1, n + 1):  # shrink towards the best vertex
        sim[j] = sim[0] + _SIGMA * (sim[j] - sim[0])
        fsim[j] = f(sim[j])
