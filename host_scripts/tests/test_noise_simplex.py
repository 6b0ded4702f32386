"""The fit's Nelder-Mead search is scipy.optimize's, step for step: on problems like the
fit's (one to five parameters, a few tens of evaluations, the evaluations often spent
before the tolerances are met) it returns the very point and value scipy's minimize
returns, and it finds a known minimum."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize

from imu_allan.noise.simplex import nelder_mead


def _problem(seed: int):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 6))
    A, c = rng.standard_normal((n, n)), rng.standard_normal(n)
    x0 = rng.standard_normal(n)
    if seed % 7 == 0:
        x0[0] = 0.0  # a zero start: scipy's simplex takes a fixed step there
    maxfev = int(rng.integers(2, 40)) * n

    def fun(x: np.ndarray) -> float:  # bumpy: the search reflects, expands, contracts, shrinks
        return float(np.sum(np.cos(3.0 * A @ x)) + (x - c) @ (x - c))

    return fun, x0, maxfev


@pytest.mark.parametrize("seed", range(60))
def test_search_matches_scipy_to_the_last_bit(seed):
    fun, x0, maxfev = _problem(seed)
    r = optimize.minimize(fun, x0, method="Nelder-Mead", options={"xatol": 1e-2, "fatol": 1e-3, "maxfev": maxfev})
    x, value = nelder_mead(fun, x0, 1e-2, 1e-3, maxfev)
    assert np.array_equal(x, r.x)
    assert value == r.fun


def test_search_finds_a_quadratic_minimum():
    centre = np.array([0.3, -1.2, 2.0])
    x, value = nelder_mead(lambda x: float((x - centre) @ (x - centre)), np.zeros(3), 1e-8, 1e-12, 2000)
    assert np.allclose(x, centre, atol=1e-6)
    assert value < 1e-11
