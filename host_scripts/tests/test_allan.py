"""Allan-family statistics against allantools (<= 1e-9 relative), against the
published NBS/NIST SP 1065 test values, and the streaming engine against
the in-memory computation and the device's exact integers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

allantools = pytest.importorskip("allantools")

from imu_allan.stats import allan  # noqa: E402
from imu_allan.stats.reference import OctaveCascade  # noqa: E402

REL = 1e-9


def _data(kind: str, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if kind == "white":
        return rng.standard_normal(n) * 3.0 + 1e3
    if kind == "walk":
        return np.cumsum(rng.standard_normal(n)) + 0.5 * rng.standard_normal(n)
    if kind == "codes":  # integer ADC codes with a random walk, the exact-integer path
        return np.clip(
            np.rint(500 + 2 * rng.standard_normal(n) + np.cumsum(0.05 * rng.standard_normal(n))), 0, 1023
        ).astype(np.uint16)
    raise ValueError(kind)


def _ours(stat: str, x: np.ndarray, ms: np.ndarray) -> np.ndarray:
    fn = {"adev": allan.avar, "oadev": allan.oavar, "mdev": allan.mvar, "ohdev": allan.ohvar}[stat]
    v, _ = fn(x, ms)
    return np.sqrt(v)


@pytest.mark.parametrize("kind", ["white", "walk", "codes"])
@pytest.mark.parametrize("stat", ["adev", "oadev", "mdev", "ohdev"])
@pytest.mark.parametrize("taus", ["octave", "decade", "log", "all"])
def test_against_allantools(kind: str, stat: str, taus: str) -> None:
    n = 2000 if taus == "all" else 20_000
    x = _data(kind, n, hash((kind, stat, taus)) % 1000)
    ms = allan.tau_grid(taus, allan.max_m("oavar" if stat in ("adev", "oadev") else "mvar", n))
    ms = ms[ms <= n // 4]  # where allantools reports every statistic
    t, ref, _, _ = getattr(allantools, stat)(x.astype(np.float64), rate=1.0, data_type="freq", taus=ms.astype(float))
    got = _ours(stat, x, np.round(t).astype(np.int64))
    assert got.size == ref.size > 3
    np.testing.assert_allclose(got, ref, rtol=REL)


def test_engine_octave_equals_allantools_and_in_memory() -> None:
    x = _data("walk", 50_001, 3)
    r = allan.octave_oavar(x)
    t, ref, _, ns = allantools.oadev(x, rate=2.0, data_type="freq", taus=r.ms / 2.0)
    np.testing.assert_allclose(np.sqrt(r.oavar[:, 0]), ref, rtol=REL)
    assert np.array_equal(r.terms, ns)
    v, pairs = allan.avar(x, r.ms)
    np.testing.assert_allclose(r.avar[:, 0], v, rtol=1e-12)
    assert np.array_equal(r.pairs, pairs)
    taus, dev = allan.oadev_octave(x, fs=2.0)
    np.testing.assert_allclose(dev, ref, rtol=REL)
    np.testing.assert_allclose(taus, t)


@settings(max_examples=25, deadline=None)
@given(
    st.integers(3, 5000),
    st.lists(st.integers(1, 900), min_size=1, max_size=8),
    st.integers(0, 2**31 - 1),
    st.sampled_from([4, 16, 64]),
)
def test_engine_does_not_depend_on_the_cut(n: int, cuts: list[int], seed: int, block: int) -> None:
    """Any block size and any cut of the stream give the same numbers (integers: bit for bit)."""
    rng = np.random.default_rng(seed)
    x = rng.integers(0, 1024, (2, n)).astype(np.uint16)
    whole = allan.OctaveEngine(2, exact_max=None)
    whole.push(x)
    a = whole.finish()
    eng = allan.OctaveEngine(2, exact_max=None, block=block)
    pos = 0
    for c in cuts * (n // max(sum(cuts), 1) + 1):
        if pos >= n:
            break
        eng.push(x[:, pos : pos + c])
        pos += c
    eng.push(x[:, pos:])
    b = eng.finish()
    assert np.array_equal(a.ms, b.ms) and np.array_equal(a.terms, b.terms)
    assert np.array_equal(a.oavar, b.oavar) and np.array_equal(np.isnan(a.avar), np.isnan(b.avar))
    assert np.array_equal(a.avar[~np.isnan(a.avar)], b.avar[~np.isnan(b.avar)])


def test_engine_non_overlapping_is_the_devices_statistic() -> None:
    """Integer codes: the engine's non-overlapping AVAR is the device's acc / (2 m^2 pairs)."""
    x = _data("codes", 40_000, 5)[None, :]
    r = allan.octave_oavar(x)
    cas = OctaveCascade(16, 1)
    cas.push(x.astype(np.int64))
    acc = cas.acc()
    for k, m in enumerate(r.ms):
        dev = acc[k][0] / (2 * int(m) ** 2 * int(cas.pairs()[k, 0]))
        assert r.pairs[k] == cas.pairs()[k, 0]
        assert abs(r.avar[k, 0] / dev - 1) < 1e-14


def test_streaming_beyond_exact_max_uses_strided_offsets(monkeypatch: pytest.MonkeyPatch) -> None:
    """Levels above exact_max: overlapping estimate over the offsets that are
    multiples of D; checked against that estimator computed directly."""
    monkeypatch.setattr(allan, "STRIDE_OFFSETS", 4)
    x = _data("walk", 120_000, 9)
    eng = allan.OctaveEngine(1, exact_max=256, block=1024)
    for part in np.array_split(x, 5):
        eng.push(part[None, :])
    r = eng.finish()
    full = allan.octave_oavar(x)
    exact = r.stride == 1
    np.testing.assert_allclose(r.oavar[exact, 0], full.oavar[: exact.sum(), 0], rtol=1e-13)
    assert (r.stride[~exact] == 64).all()
    X = np.concatenate(([0.0], np.cumsum(x - x[: allan.BLOCK].mean())))
    for k in np.flatnonzero(~exact):
        m, D = int(r.ms[k]), int(r.stride[k])
        P = X[::D]
        q = m // D
        d = P[2 * q :] - 2 * P[q:-q] + P[: -2 * q]
        assert d.size == r.terms[k]
        assert abs(np.dot(d, d) / (2.0 * m * m * d.size) / r.oavar[k, 0] - 1) < 1e-9
    np.testing.assert_allclose(r.avar[:, 0], full.avar[: r.ms.size, 0], rtol=1e-12)


# ---- published values (NIST SP 1065 / NBS, as allantools' own tests use) --------------------

NBS14_PHASE = [0.00000, 103.11111, 123.22222, 157.33333, 166.44444, 48.55555, -96.33333, -2.22222, 111.88889, 0.00000]
NBS14_FREQ = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0]
NBS14_10 = {
    "adev": (91.22945, 115.8082),
    "oadev": (91.22945, 85.95287),
    "mdev": (91.22945, 74.78849),
    "ohdev": (70.80607, 85.61487),
}
NBS14_1000 = {
    "adev": (2.922319e-01, 9.965736e-02, 3.897804e-02),
    "oadev": (2.922319e-01, 9.159953e-02, 3.241343e-02),
    "mdev": (2.922319e-01, 6.172376e-02, 2.170921e-02),
    "ohdev": (2.943883e-01, 9.581083e-02, 3.237638e-02),
}


def _nbs14_1000() -> np.ndarray:
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]
    return np.array(n, dtype=np.float64) / 2147483647


@pytest.mark.parametrize("stat", sorted(NBS14_10))
def test_nbs14_10_point(stat: str) -> None:
    # the published phase is the frequency data, mean removed, integrated
    assert np.allclose(np.diff(NBS14_PHASE), np.array(NBS14_FREQ) - np.mean(NBS14_FREQ), atol=1e-4)
    got = _ours(stat, np.array(NBS14_FREQ), np.array([1, 2]))
    np.testing.assert_allclose(got, NBS14_10[stat], rtol=1e-4)


@pytest.mark.parametrize("stat", sorted(NBS14_1000))
def test_nbs14_1000_point(stat: str) -> None:
    got = _ours(stat, _nbs14_1000(), np.array([1, 10, 100]))
    np.testing.assert_allclose(got, NBS14_1000[stat], rtol=1e-4)


def test_tau_grids() -> None:
    assert allan.tau_grid("octave", 100).tolist() == [1, 2, 4, 8, 16, 32, 64]
    assert allan.tau_grid("decade", 500).tolist() == [1, 2, 4, 10, 20, 40, 100, 200, 400]
    assert allan.tau_grid("all", 5).tolist() == [1, 2, 3, 4, 5]
    lg = allan.tau_grid("log", 10_000)
    assert lg[0] == 1 and lg[-1] == 10_000 and 35 <= lg.size <= 41
    with pytest.raises(ValueError):
        allan.tau_grid("weekly", 10)
