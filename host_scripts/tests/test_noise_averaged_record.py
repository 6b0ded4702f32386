"""The band limit of a record whose samples are averages (integrate and dump, or a faster
record averaged down), graded by what it did not make.

Its Allan variance is checked against two computations made here: IEEE Std 952-1997's
band-limited (first-order Markov) formula, sigma^2(tau) = N^2 / tau (1 - Tc / (2 tau)
(3 - 4 e^(-tau/Tc) + e^(-2 tau/Tc))), Tc = 1 / (2 pi fc), which the block means of the
continuous RC follow at every tau = m dt; and, for the one and the two-pole filter alike,
the definition on a fine internal rate (the impulse response sampled, the white noise
through it, the difference of adjacent cluster means a linear filter: the sum of its
squared weights).  The fit is graded on the textbook recursions written here with numpy
alone: white noise through an RC at ten and at a hundred times the read rate (the
discrete one-pole of a part's digital filter; the exact Ornstein-Uhlenbeck step of an
analog one), block means of ten or a hundred samples read, the cutoff from half the read
rate to five times it, where no point-sampled form can follow it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan import api
from imu_allan.noise import LP, WN

FS = 10.0


def _ieee_band_limited(tau: np.ndarray, fc: float) -> np.ndarray:
    tc = 1.0 / (2.0 * math.pi * fc)
    return 1.0 / tau * (1.0 - tc / (2.0 * tau) * (3.0 - 4.0 * np.exp(-tau / tc) + np.exp(-2.0 * tau / tc)))


@pytest.mark.parametrize("fc", [0.4, 3.0, 12.0, 45.0])
def test_the_averaged_pole_is_ieee_952s_band_limited_white_noise_at_every_tau(fc) -> None:
    m = np.array([1, 2, 3, 5, 8, 16, 100, 1000])
    got = LP(1.0, fc, 1, "pole_mean").avar(m, FS)
    np.testing.assert_allclose(got, _ieee_band_limited(m / FS, fc), rtol=1e-9)


def _impulse(order: int, fc: float, t: np.ndarray) -> np.ndarray:
    wc = 2.0 * math.pi * fc
    if order == 1:
        return wc * np.exp(-wc * t)
    w = wc / math.sqrt(2.0)  # the Butterworth's poles: wc (-1 +- i) / sqrt(2)
    return math.sqrt(2.0) * wc * np.exp(-w * t) * np.sin(w * t)


def _avar_by_definition(order: int, fc: float, m: int, up: int) -> float:
    """AVAR at m read samples (per unit density) of block means of up fine samples of unit
    white noise through the filter's impulse response: half the variance of the difference
    of two adjacent m-sample means, 0.5 sum w^2 / dt_fine."""
    dtf = 1.0 / (FS * up)
    g = _impulse(order, fc, np.arange(int(40.0 / (2 * math.pi * fc * dtf)) + 1) * dtf) * dtf
    g /= g.sum()  # the DC gain 1 of the continuous filter, on the fine grid
    comb = np.concatenate((-np.ones(m * up), np.ones(m * up))) / (m * up)
    w = np.convolve(comb, g)
    return 0.5 * float(np.sum(w * w)) / dtf


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("fc", [2.0, 8.0, 30.0])
def test_exact_allan_variance_matches_the_definition_on_a_fine_internal_rate(order, fc) -> None:
    up = int(max(100, 40 * fc / FS))
    for m in (1, 2, 4, 8):
        want = _avar_by_definition(order, fc, m, up) * FS  # per unit N^2 (AVAR N^2 / tau at long tau)
        got = float(LP(1.0, fc, order, "pole_mean").avar(np.array([m]), FS)[0]) * FS
        assert abs(got / want - 1) < 3e-3, (m, got, want)


def _rc_averaged(n: int, up: int, fc: float, n_true: float, seed: int) -> np.ndarray:
    """White noise of density n_true through an RC at up * FS, block means of up samples:
    the discrete one-pole y = a y + (1 - a) x (a part's digital filter) for up = 10, the
    exact Ornstein-Uhlenbeck step (variance n_true^2 pi fc) for up >= 100."""
    from scipy.signal import lfilter

    fs = FS * up
    a = math.exp(-2.0 * math.pi * fc / fs)
    rng = np.random.default_rng(seed)
    if up >= 100:
        sd = n_true * math.sqrt(math.pi * fc)
        x0 = sd * rng.standard_normal()
        e = rng.standard_normal(n * up) * sd * math.sqrt(1.0 - a * a)
    else:
        x0 = 0.0
        e = rng.standard_normal(n * up) * n_true * math.sqrt(fs) * (1.0 - a)
    y = lfilter([1.0], [1.0, -a], e, zi=[a * x0])[0]
    return y.reshape(-1, up).mean(axis=1)


@pytest.mark.parametrize(("up", "rel"), [(10, 0.5), (10, 1.0), (10, 3.0), (100, 1.0), (100, 2.0), (100, 5.0)])
def test_fit_reads_N_of_an_independent_rc_averaged_down(up, rel) -> None:
    n_true = 0.05
    x = _rc_averaged(100_000, up, rel * FS, n_true, 11)
    fit = api.noise_terms(x, FS)
    n = fit.terms["N"]
    assert n.value is not None and abs(n.value / n_true - 1) < 0.03, (n, fit.fitted)
    assert fit.terms["Q"].value is None, fit.fitted  # the bend is not a quantization's rise


def test_the_averaged_pole_is_the_form_chosen_above_the_read_rate() -> None:
    # a 2 fs cutoff: beyond any point-sampled form (they stop at fs / 2), a bend of 12 % at
    # the first point (1.5 / (2 pi fc) tau in AVAR) and 6 % at the second
    fc = 2.0 * FS
    x = _rc_averaged(400_000, 100, fc, 0.05, 4)
    fit = api.noise_terms(x, FS)
    lp = fit.terms.get("LP")
    assert lp is not None and lp.extra["shape"] == "pole_mean", fit.fitted
    assert lp.extra["fc_low"] <= fc <= lp.extra["fc_high"] and abs(lp.value / fc - 1) < 0.3, lp


@pytest.mark.parametrize("seed", range(6))
def test_no_band_limit_nor_quantization_on_white_noise_read_as_block_means(seed) -> None:
    x = WN(0.05).simulate(100_000 * 10, 100.0, seed).reshape(-1, 10).mean(axis=1)
    fit = api.noise_terms(x, FS)
    assert "LP" not in fit.terms and fit.terms["Q"].value is None, fit.fitted
    assert abs(fit.terms["N"].value / 0.05 - 1) < 0.03, fit.fitted


def test_the_catalogues_stream_has_the_exact_autocovariance() -> None:
    from imu_allan.noise.filters import mean_pole_autocov

    for order, fc in ((1, 25.0), (2, 3.0)):
        x = LP(1.0, fc, order, "pole_mean").simulate(1 << 20, FS, 9)
        r0, c, p = mean_pole_autocov(fc, FS, order)
        want = np.concatenate(([r0], np.real([np.sum(c * p**k) for k in range(1, 5)])))
        got = np.array([np.mean(x[: x.size - k] * x[k:]) for k in range(5)])
        assert np.all(np.abs(got - want) < 5 * r0 / math.sqrt(x.size)), (order, got, want)
