"""Equivalent degrees of freedom and chi-squared intervals, against allantools.ci,
and the coverage of the intervals on simulated noise."""

from __future__ import annotations

import contextlib
import io
import itertools

import numpy as np
import pytest

allantools = pytest.importorskip("allantools")
from allantools import ci  # noqa: E402

from imu_allan.stats import allan, edf  # noqa: E402


def _ref(*args, **kw):
    with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"):
        try:
            return ci.edf_greenhall(*args, **kw)
        except (NotImplementedError, AssertionError, ZeroDivisionError):
            return None


def test_greenhall_against_allantools() -> None:
    compared = 0
    for alpha, d, m, N, ov, mod in itertools.product(
        [2, 1, 0, -1, -2, -3, -4],
        [1, 2, 3],
        [1, 2, 3, 8, 64, 1024],
        [10, 100, 1000, 100_000],
        [False, True],
        [False, True],
    ):
        if alpha + 2 * d <= 1:
            continue
        ref = _ref(alpha, d, m, N, overlapping=ov, modified=mod)
        if ref is None or not np.isfinite(ref) or ref <= 0:
            continue
        got = edf.edf_greenhall(alpha, d, m, N, overlapping=ov, modified=mod)
        assert got == pytest.approx(ref, rel=1e-9), (alpha, d, m, N, ov, mod)
        compared += 1
    assert compared > 900


def test_white_pm_with_few_estimates_sums_only_its_nonzero_terms() -> None:
    """White PM (alpha 2) where ceil(r) <= d takes Greenhall's direct sum, whose
    terms vanish but near j / S = 0..d: the few kept give allantools' value, which
    sums all J terms (J ~ 2m: 1.2e7 terms at 8 h x 1 kHz's longest octave)."""
    compared = 0
    for d, N, ov in itertools.product([1, 2, 3], [1000, 4097], [True, False]):
        for m in range(N // (d + 2) - 3, N // d, 7):
            got = edf.edf_greenhall(2, d, m, N, overlapping=ov)
            ref = _ref(2, d, m, N, overlapping=ov)
            if ref is None or not np.isfinite(ref) or not np.isfinite(got):
                continue
            assert got == pytest.approx(ref, rel=1e-9), (d, m, N, ov)
            compared += 1
    assert compared > 200


def test_stride_generalizes_overlapping() -> None:
    assert edf.edf_greenhall(0, 2, 64, 10_000, stride=1) == edf.edf_greenhall(0, 2, 64, 10_000, overlapping=True)
    assert edf.edf_greenhall(0, 2, 64, 10_000, stride=64) == edf.edf_greenhall(0, 2, 64, 10_000)
    mid = edf.edf_greenhall(0, 2, 64, 10_000, stride=8)
    assert edf.edf_greenhall(0, 2, 64, 10_000) < mid <= edf.edf_greenhall(0, 2, 64, 10_000, stride=1) * 1.001


@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
def test_simple_edf_against_allantools(alpha: int) -> None:
    for N, m in itertools.product([100, 1000, 10_000], [1, 4, 16]):
        assert edf.edf_simple(N, m, alpha) == pytest.approx(ci.edf_simple(N, m, alpha), rel=1e-12)


def test_chi2_interval_against_allantools() -> None:
    for dev, e in [(1.0, 3.0), (0.2, 17.5), (5.0, 1000.0)]:
        lo, hi = edf.chi2_interval(dev * dev, e, 0.95)
        rlo, rhi = ci.confidence_interval(dev, e, ci=0.95)
        assert np.sqrt(lo) == pytest.approx(rlo, rel=1e-12) and np.sqrt(hi) == pytest.approx(rhi, rel=1e-12)


@pytest.mark.parametrize("overlapping", [True, False])
def test_intervals_cover_the_truth(overlapping: bool) -> None:
    """95 % intervals from Greenhall's EDF hold the true AVAR of white noise
    (sigma^2 / m) in about 95 % of 400 runs."""
    n, m = 2048, 32
    rng = np.random.default_rng(11)
    x = rng.standard_normal((400, n))
    hits = 0
    e = edf.edf_greenhall(0, 2, m, n + 1, overlapping=overlapping)
    for row in x:
        v, _ = (allan.oavar if overlapping else allan.avar)(row, [m])
        lo, hi = edf.chi2_interval(v[0], e)
        hits += bool(lo <= 1.0 / m <= hi)
    assert 0.91 <= hits / 400 <= 0.985


def test_edf_points_interpolates_dense_grids() -> None:
    ms = allan.tau_grid("all", 2000)
    table = edf.edf_points(ms, 10_001, 1, alphas=(0,))
    direct = np.array([edf.edf_greenhall(0, 2, int(m), 10_001, overlapping=True) for m in ms[::97]])
    np.testing.assert_allclose(table[0][::97], direct, rtol=0.02)
