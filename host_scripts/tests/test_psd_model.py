"""Welch PSD (as scipy / pwelch), the terms' PSD levels, the thesis model and FIT%."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal

from imu_allan.noise import model
from imu_allan.noise.streams import Flicker
from imu_allan.stats import allan, psd


def test_welch_streams_like_scipy() -> None:
    rng = np.random.default_rng(0)
    x = rng.standard_normal((2, 50_000)) * np.array([[1.0], [3.0]]) + 7.0
    n = psd.segment_length(x.shape[1])
    w = psd.Welch(2, 100.0, n)
    for part in np.array_split(x, 9, axis=1):
        w.push(part)
    f, p = w.result()
    f2, p2 = scipy.signal.welch(
        x, 100.0, window=np.hamming(n), nperseg=n, noverlap=n // 2, nfft=16384, detrend="constant", axis=-1
    )
    np.testing.assert_allclose(f, f2)
    np.testing.assert_allclose(p, p2, rtol=1e-10)
    assert n == 50_000 // 4.5 and w.nfft == 16384  # pwelch: 8 segments, half overlapping, 2^k FFT


def test_long_segments_float32_transforms_stay_within_1e_5_of_scipy() -> None:
    """Segments of 2^16 samples go through float32 transforms (psd.SINGLE_FROM): a
    random walk over white noise, rounded to codes (a PSD over five decades), against
    scipy's float64 Welch with the same segments, bin by bin."""
    rng = np.random.default_rng(4)
    n = 600_000
    x = np.rint(np.cumsum(rng.standard_normal(n)) * 0.05 + rng.standard_normal(n) * 2 + 500)
    nseg = psd.segment_length(n)
    w = psd.Welch(1, 1000.0, nseg)
    for a in range(0, n, 77_777):
        w.push(x[None, a : a + 77_777])
    f, p = w.result()
    f2, p2 = scipy.signal.welch(
        x, 1000.0, window=np.hamming(nseg), nperseg=nseg, noverlap=nseg // 2, nfft=w.nfft, detrend="constant"
    )
    assert w.single and nseg == psd.SINGLE_FROM and p2.max() / p2[1:].min() > 1e5
    np.testing.assert_allclose(f, f2)
    np.testing.assert_allclose(p[0], p2, rtol=1e-5)


def test_term_levels_match_simulated_noise() -> None:
    fs, n = 100.0, 1 << 19
    rng = np.random.default_rng(1)
    N, K, B = 0.05, 0.01, 0.03
    cases = {
        "N": N * math.sqrt(fs) * rng.standard_normal(n),
        "K": np.cumsum(K / math.sqrt(fs) * rng.standard_normal(n)),
        "B": Flicker(B, fs, n, np.random.SeedSequence(2)).take(0, n),
    }
    for k, x in cases.items():
        w = psd.Welch(1, fs, 1 << 14)
        w.push(x[None, :])
        f, p = w.result()
        line = psd.term_psd(f[1:], {"N": N, "K": K, "B": B}, fs)[k]
        band = (f[1:] > 0.05) & (f[1:] < 5)
        ratio = np.exp(np.mean(np.log(p[0, 1:][band] / line[band])))
        assert ratio == pytest.approx(1.0, rel=0.15), k


def test_log_bins() -> None:
    f = np.linspace(0, 50, 5001)
    p = np.vstack([np.ones_like(f), 2 * np.ones_like(f)])
    fb, pb = psd.log_bins(f, p)
    assert fb[0] > 0 and np.all(np.diff(fb) > 0)
    np.testing.assert_allclose(pb, [[1.0] * fb.size, [2.0] * fb.size])


def test_gauss_markov_allan_variance() -> None:
    """The closed form behind the thesis model's B -> (sigma, T) mapping."""
    x = np.geomspace(0.01, 100, 500)
    v = model.gm_avar(x, 1.0, 1.0)
    i = int(np.argmax(v))
    assert x[i] == pytest.approx(model.GM_PEAK_X, rel=0.02)
    assert math.sqrt(v[i]) == pytest.approx(model.GM_PEAK_ADEV, rel=1e-3)
    p = model.ModelParams(fs=100.0, gm_sigma=1.0, gm_tau=2.0)
    sim = np.concatenate(list(model.simulate(p, 1 << 20, seed=3)))
    r = allan.octave_oavar(sim)
    tau = r.ms / 100.0
    sel = (tau > 0.5) & (tau < 40)
    np.testing.assert_allclose(np.sqrt(r.oavar[sel, 0]), np.sqrt(model.gm_avar(tau[sel], 1.0, 2.0)), rtol=0.08)


def test_model_from_terms_puts_the_peak_on_the_floor() -> None:
    p = model.from_terms({"N": 0.1, "B": 0.05, "K": 0.002, "Q": None}, fs=100.0, tau_b=38.0)
    assert p.white == pytest.approx(1.0) and p.rrw == pytest.approx(0.0002)
    assert p.gm_tau == pytest.approx(38.0 / model.GM_PEAK_X)
    peak = math.sqrt(model.gm_avar(np.array([38.0]), p.gm_sigma, p.gm_tau)[0])
    assert peak == pytest.approx(model.B_FLOOR * 0.05, rel=1e-3)


def test_simulation_does_not_depend_on_the_chunking() -> None:
    p = model.ModelParams(fs=50.0, white=1.0, gm_sigma=0.3, gm_tau=5.0, rrw=0.01, quant=0.02, ramp=1e-3)
    a = np.concatenate(list(model.simulate(p, 10_000, seed=4)))
    b = np.concatenate(list(model.simulate(p, 10_000, seed=4, chunk=777)))
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_fit_percent() -> None:
    s = np.array([1.0, 2.0, 3.0])
    assert model.fit_percent(s, s) == 100.0
    assert model.fit_percent(s, np.zeros(3)) == 0.0
    assert model.fit_nrmse(s, np.full(3, 2.0)) == pytest.approx(0.0)
    # the thesis' formula on two independent noises of equal power: about 1 - sqrt(2)
    rng = np.random.default_rng(5)
    v = model.fit_percent(rng.standard_normal(100_000), rng.standard_normal(100_000))
    assert v == pytest.approx((1 - math.sqrt(2)) * 100, abs=1.0)
    # on log10 ADEV in a unit where values are ~1e-3, a 10 % error everywhere still scores high
    dev = np.geomspace(1e-2, 1e-3, 20)
    assert model.fit_percent(np.log10(dev), np.log10(dev * 1.1)) > 97
    assert model.fit_nrmse(np.log10(dev), np.log10(dev * 1.1)) < 90


def test_welch_compiled_segments_are_numpys_bit_for_bit(monkeypatch) -> None:
    """The compiled demean-window and periodogram sums (stats/ck_text.c) do numpy's
    operations in numpy's order: the same bits, whatever the segment length."""
    from imu_allan.stats import kernels

    if not kernels.COMPILED:
        pytest.skip("the compiled kernels are not built")
    x = np.rint(np.random.default_rng(3).standard_normal((2, 300_001)) * 2 + 500)

    def run() -> list:
        out = []
        for nseg in (psd.segment_length(x.shape[1]), 4096, 1000):
            w = psd.Welch(2, 1000.0, nseg)
            for a in range(0, x.shape[1], 77_777):
                w.push(x[:, a : a + 77_777])
            out.append(w.result()[1])
        return out

    fast = run()
    monkeypatch.setattr(kernels, "_C", None)
    for a, b in zip(fast, run()):
        assert a.shape == b.shape and a.view(np.int64).tolist() == b.view(np.int64).tolist()
