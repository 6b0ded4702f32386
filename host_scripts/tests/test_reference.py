"""The float64 reference against allantools (an independent implementation)."""
import allantools
import numpy as np
import pytest

from imu_allan.reference import octave_avar


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_octave_avar_matches_allantools_adev(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 50_000 + seed * 1234
    x = np.rint(512 + 3 * rng.standard_normal(n) + np.cumsum(0.01 * rng.standard_normal(n)))
    fs = 100.0
    rows = octave_avar(x, 14)
    taus = np.array([r.m / fs for r in rows])
    t, ad, _, ns = allantools.adev(x, rate=fs, data_type="freq", taus=taus)
    assert np.allclose(t, taus)
    for r, a, count in zip(rows, ad, ns):
        assert r.pairs == count
        assert abs(np.sqrt(r.avar) - a) <= 1e-12 * a


def test_short_streams_have_no_pairs() -> None:
    rows = octave_avar([5, 6, 7], 3)
    assert [r.pairs for r in rows] == [2, 0, 0]
    assert rows[0].avar == pytest.approx(((1.0) ** 2 + (1.0) ** 2) / 4)
    assert np.isnan(rows[1].avar)
