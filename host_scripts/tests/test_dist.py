"""The distribution functions of stats.dist against scipy.stats on grids of
arguments, invalid ones included (the module exists so that no imu-allan
process has to import scipy.stats)."""

from __future__ import annotations

import numpy as np
from scipy import stats

from imu_allan.stats import dist

DF = np.array([0.3, 1.0, 2.0, 2.5, 7.0, 40.0, 1e3, 1e6, 0.0, -1.0])
P = np.array([0.0, 1e-9, 0.025, 0.05, 0.5, 0.95, 0.975, 1 - 1e-9, 1.0, -0.1, 1.1])
X = np.array([-1.0, 0.0, 1e-6, 0.3, 1.0, 3.84, 20.0, 1e3])


def _same(got, ref) -> None:
    got, ref = np.asarray(got, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    assert got.shape == ref.shape
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    ok = ~np.isnan(ref)
    np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-14, atol=0)


def test_chi2_quantiles_and_tails_are_scipy_stats() -> None:
    p, df = np.meshgrid(P, DF)
    _same(dist.chi2_ppf(p, df), stats.chi2.ppf(p, df))
    x, df2 = np.meshgrid(X, DF)
    _same(dist.chi2_sf(x, df2), stats.chi2.sf(x, df2))
    assert isinstance(dist.chi2_ppf(0.95, 3), float)
    assert dist.chi2_ppf(0.95, 1) == stats.chi2.ppf(0.95, 1)


def test_t_quantiles_are_scipy_stats() -> None:
    p, df = np.meshgrid(P, DF)
    _same(dist.t_ppf(p, df), stats.t.ppf(p, df))


def test_f_tails_are_scipy_stats() -> None:
    for dfd in (1.0, 3.5, 30.0, 0.0):
        x, dfn = np.meshgrid(X, DF)
        _same(dist.f_cdf(x, dfn, dfd), stats.f.cdf(x, dfn, dfd))
        _same(dist.f_sf(x, dfn, dfd), stats.f.sf(x, dfn, dfd))
