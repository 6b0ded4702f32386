"""The cache-blocked octave kernels (stats/kernels.py) behind allan.oavar/avar
on octave grids: against an extended-precision reference computed straight
from the definitions, against allantools, and with tiny tiles so that every
stage boundary and tile edge is crossed at small n."""

import numpy as np
import pytest

from imu_allan.stats import allan, kernels

allantools = pytest.importorskip("allantools")


def processes(n: int, seed: int = 5) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "white": rng.standard_normal(n) + 5.0,
        "walk": np.cumsum(rng.standard_normal(n)),
        "walk+white": np.cumsum(rng.standard_normal(n) * 0.01) + rng.standard_normal(n),
        "ramp+noise": np.linspace(0.0, 1000.0, n) + rng.standard_normal(n),
        "codes": rng.integers(480, 540, n),
    }


def reference(x: np.ndarray, overlapping: bool) -> np.ndarray:
    """Octave AVAR from the partial sums in long double (64-bit mantissa where
    the platform has it), mean removed: NIST SP 1065 eqs. 6 and 8 as written."""
    n = x.size
    xl = np.asarray(x, dtype=np.longdouble)
    X = np.concatenate(([np.longdouble(0)], np.cumsum(xl - xl.mean())))
    out = []
    for k in range(int(np.log2(n // 2)) + 1):
        m = 1 << k
        P = X if overlapping else X[::m]
        s = m if overlapping else 1
        d = P[2 * s :] - 2 * P[s:-s] + P[: -2 * s]
        out.append(float(np.sum(d * d) / (2 * m * m * d.size)))
    return np.array(out)


@pytest.fixture(params=["compiled", "numpy"])
def path(request, monkeypatch):
    """Each test runs on the compiled kernels (when built) and on the numpy fallback."""
    if request.param == "compiled" and not kernels.COMPILED:
        pytest.skip("the compiled kernels are not built (make ext)")
    if request.param == "numpy":
        monkeypatch.setattr(kernels, "_C", None)
    return request.param


def octave_grid(n: int) -> np.ndarray:
    return allan.tau_grid("octave", n // 2)


needs_longdouble = pytest.mark.skipif(
    np.finfo(np.longdouble).nmant < 60, reason="long double is no wider than float64 here"
)


@needs_longdouble
@pytest.mark.parametrize("n", [5, 1000, 4097, (1 << 16) - 1, (1 << 16) + 1, 100_003])
@pytest.mark.parametrize("overlapping", [True, False])
def test_octave_kernels_match_extended_precision_reference(n, overlapping, path):
    for name, x in processes(n).items():
        fn = allan.oavar if overlapping else allan.avar
        v, count = fn(x, octave_grid(n))
        ref = reference(x, overlapping)
        assert v.size == ref.size
        np.testing.assert_allclose(v, ref, rtol=1e-12, atol=0, err_msg=name)
        ms = octave_grid(n)
        assert list(count) == list(n - 2 * ms + 1 if overlapping else n // ms - 1)


@needs_longdouble
@pytest.mark.parametrize("n", [2, 3, 17, 129, 1023, 1025, 5000, 20_011])
def test_tiny_tiles_cross_every_stage_and_tile_edge(n, monkeypatch, path):
    monkeypatch.setattr(kernels, "OCTAVE_TILE", 1 << 7)
    monkeypatch.setattr(kernels, "OCTAVE_SPLIT", 1 << 4)
    x = processes(n, seed=n)["walk+white"]
    off = float(kernels.offset(x[: kernels.HEAD]))
    sums, terms = kernels.octave_oavar_sums(x, off)
    ms = 1 << np.arange(sums.size)
    np.testing.assert_allclose(sums / (2.0 * ms * ms * terms), reference(x, True), rtol=1e-12, atol=0)
    sums, pairs = kernels.octave_avar_sums(x, off, chunk=1 << 5)
    np.testing.assert_allclose(sums / (2.0 * ms * ms * pairs), reference(x, False), rtol=1e-12, atol=0)


@pytest.mark.parametrize("n", [4097, (1 << 16) - 1, (1 << 16) + 1, 100_003])
@pytest.mark.parametrize("name", ["white", "walk+white"])
def test_octave_kernels_match_allantools(n, name, path):
    """Where allantools is itself accurate (no strong trend: its phase is the raw
    cumulative sum, whose rounding grows with a walk or a ramp), 1e-12."""
    x = processes(n)[name]
    _, dev, _, ns = allantools.oadev(x, rate=1.0, data_type="freq", taus="octave")
    v, terms = allan.oavar(x, octave_grid(n))
    k = dev.size
    np.testing.assert_allclose(v[:k], dev**2, rtol=1e-12, atol=0)
    assert list(terms[:k]) == list(ns)
    _, dev, _, ns = allantools.adev(x, rate=1.0, data_type="freq", taus="octave")
    v, pairs = allan.avar(x, octave_grid(n))
    np.testing.assert_allclose(v[: dev.size], dev**2, rtol=1e-12, atol=0)


def test_trends_agree_with_allantools_to_its_own_rounding():
    """A walk and a ramp: allantools drifts from the exact value by ~1e-11 at
    1e5 samples (measured against the long double reference); we do not."""
    n = 100_003
    for name in ("walk", "ramp+noise"):
        x = processes(n)[name]
        _, dev, _, _ = allantools.oadev(x, rate=1.0, data_type="freq", taus="octave")
        v, _ = allan.oavar(x, octave_grid(n))
        np.testing.assert_allclose(v[: dev.size], dev**2, rtol=1e-9, atol=0, err_msg=name)


def test_integer_codes_and_float_codes_give_the_same_values(path):
    x = processes(30_001)["codes"]
    a, _ = allan.oavar(x, octave_grid(x.size))
    b, _ = allan.oavar(x.astype(np.float64), octave_grid(x.size))
    np.testing.assert_array_equal(a, b)


def test_octave_subset_and_too_long_m():
    x = processes(1000)["white"]
    full, _ = allan.oavar(x, octave_grid(1000))
    v, terms = allan.oavar(x, [4, 64, 1024])
    assert v[0] == full[2] and v[1] == full[6]
    assert np.isnan(v[2]) and terms[2] == 0
