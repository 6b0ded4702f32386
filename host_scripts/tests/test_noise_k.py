"""K's 95 % interval and bound, graded on textbook streams the package did not make.

White noise of density N plus a rate random walk of coefficient K (the cumulative sum of
Gaussian steps of sd K / sqrt(fs)), 16000 s at 10 Hz: K = 1e-3 crosses N's line at
sqrt(3) N / K = 520 s, so the walk rules the last four octaves only, where each Allan
estimate has one to eight degrees of freedom.  The control: the same white noise with
flicker instead of the walk (Kasdin's fractional differencing, as in test_noise_fit)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_allan import api

FS = 10.0
SECONDS = 16000
N_TRUE = 0.3
K_TRUE = 1e-3
B_TRUE = 0.01
STREAMS = 100


def _stream(seed: int, k: float = 0.0, b: float = 0.0) -> np.ndarray:
    n = int(SECONDS * FS)
    x = np.random.default_rng([seed, 0]).standard_normal(n) * N_TRUE * math.sqrt(FS)
    if k:
        x += np.cumsum(np.random.default_rng([seed, 2]).standard_normal(n) * k / math.sqrt(FS))
    if b:
        j = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((j - 1 + 0.5) / j)))
        x += signal.fftconvolve(np.random.default_rng([seed, 3]).standard_normal(n) * b, h)[:n]
    return x


@pytest.fixture(scope="module")
def walks() -> list:
    return [api.noise_terms(_stream(seed, k=K_TRUE), FS).terms["K"] for seed in range(STREAMS)]


def test_K_interval_or_bound_holds_a_walk_that_rules_only_the_last_octaves(walks) -> None:
    """A 95 % interval holds the truth on 91 or more of 100 streams with probability 0.97.
    Judged by the fitted model's covariance alone, the interval or bound held it on 88 of
    these 100 (0.002 for a 95 % interval): where the realization runs low at the end, the
    fit is low, its weights small, and K's bound fell under the truth (on 11 of the 17
    streams where K was left out)."""
    held = sum((k.low if k.value else 0.0) <= K_TRUE <= (k.high if k.value else k.upper) for k in walks)
    identified = sum(k.value is not None for k in walks)
    assert held >= 91, held
    assert identified >= 75, identified  # the walk is there: mostly read, not only bounded


def test_K_bound_on_white_noise_and_flicker_stays_under_a_walk_the_records_show(walks) -> None:
    """With no walk, K is absent and its bound is small: its median under the K = 1e-3 that
    the same records read on most streams (the previous test: 83 of 100)."""
    bounds = []
    for seed in range(20):
        k = api.noise_terms(_stream(seed, b=B_TRUE if seed % 2 else 0.0), FS).terms["K"]
        assert k.value is None, (seed, k)
        bounds.append(k.upper)
    assert 0 < float(np.median(bounds)) < K_TRUE, bounds


def _oavar(x: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Overlapping Allan variance of rate samples x at averaging factors ms (NIST SP 1065 eq. 10)."""
    X = np.concatenate(([0.0], np.cumsum(x)))
    return np.array([np.mean((X[2 * m :] - 2 * X[m:-m] + X[: -2 * m]) ** 2) / (2.0 * m * m) for m in ms])


def test_K_s_inversion_correlates_a_walk_s_octaves_as_textbook_walks_do() -> None:
    """The correlation between a walk's Allan estimates two and three octaves apart, measured
    on 400 textbook walks, is the one K's inversion uses (kinterval.DECAY) within 0.08, and
    under the exponential form's (RHO^d) by more than 0.05: their correlation falls faster
    with distance than one octave's gives."""
    from imu_allan.noise.kinterval import DECAY
    from imu_allan.noise.terms import octave_correlation

    ms = 2 ** np.arange(4, 11)
    rng = np.random.default_rng(11)
    est = np.array([_oavar(np.cumsum(rng.standard_normal(1 << 15)), ms) for _ in range(400)])
    measured = np.corrcoef(est.T)
    taus, alpha = ms.astype(float), np.full(ms.size, -2)
    used = octave_correlation(taus, alpha, "overlapping", DECAY)
    exponential = octave_correlation(taus, alpha, "overlapping")
    for d in (2, 3):
        got = np.mean([measured[i, i + d] for i in range(ms.size - d)])
        model = used[0, d]
        assert abs(got - model) < 0.08, (d, got, model)
        assert exponential[0, d] - got > 0.05, (d, got, exponential[0, d])


def _gm_walk_stream(T: float, seed_walk: int = 20) -> np.ndarray:
    """White noise of 0.805 / sqrt(Hz) at 100 Hz, a first-order Gauss-Markov process of sd 0.26
    and correlation time T s (AR(1): phi = exp(-1 / (fs T))), and a walk of K = 0.1 whose
    realization (seed ``seed_walk``) runs low at mid taus and high at the end: 1e6 samples."""
    fs, n = 100.0, 1_000_000
    rng = np.random.default_rng(999)
    x = rng.standard_normal(n) * 0.805 * math.sqrt(fs)
    phi = math.exp(-1.0 / (fs * T))
    x += signal.lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * 0.26 * math.sqrt(1.0 - phi * phi))
    return x + np.cumsum(np.random.default_rng(seed_walk).standard_normal(n)) * 0.1 / math.sqrt(fs)


def test_a_walk_read_as_a_GM_and_a_ramp_is_K_or_inside_K_s_bound() -> None:
    """A walk whose realization carries a trend of its own is fitted as a long Gauss-Markov
    process and a ramp: K is read from the GM's rise (its interval holding the walk's K), or,
    where the GM's walk shows over one octave only, K's bound holds it; never "not in the
    data" under the truth (the bound was 0.63 of it with a GM of 15 s)."""
    for T in (15.0, 40.0):
        fit = api.noise_terms(_gm_walk_stream(T), 100.0)
        k = fit.terms["K"]
        assert fit.terms["R"].value is not None, (T, fit.terms)  # the case: a ramp at the end
        if k.value is None:
            assert k.upper >= 0.1, (T, k)
        else:
            assert k.low <= 0.1 <= k.high, (T, k)


def test_a_GM_and_a_drift_on_white_noise_are_not_read_as_K() -> None:
    """A Gauss-Markov process of 120 s and a ramp (no walk): fitted as both, K is not read
    from the GM (its walk line meets white noise under two octaves before T / 2)."""
    fs, n, T = 100.0, 1_000_000, 120.0
    rng = np.random.default_rng([1, 5])
    phi = math.exp(-1.0 / (fs * T))
    gm = signal.lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * 0.8 * math.sqrt(1.0 - phi * phi))
    x = rng.standard_normal(n) * 0.8 * math.sqrt(fs) + gm + 0.003 * np.arange(n) / fs
    terms = api.noise_terms(x, fs).terms
    assert terms["R"].value is not None and terms["GM1"].value is not None, terms
    assert terms["K"].value is None, terms["K"]


def test_K_s_interval_holds_a_walk_that_a_GM_beside_K_takes_part_of() -> None:
    """The same walk beside a GM of 30 s: fitted as K and a GM whose rise stands in for part of
    the walk (K read at half the truth), K's interval, judged without that GM as well, holds
    the walk's K (it reached 0.084 of the 0.1)."""
    k = api.noise_terms(_gm_walk_stream(30.0), 100.0).terms["K"]
    assert k.value is not None and k.low <= 0.1 <= k.high, k
