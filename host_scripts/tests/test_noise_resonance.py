"""The resonance of the catalogue (a mechanical mode rung by the bench: narrow-band
noise around f0), graded on a stream it did not make.

The independent generator is Rice's quadrature form of narrow-band noise
(S. O. Rice, "Mathematical analysis of random noise", 1944, section 3.7):
x_k = I_k cos(w0 k) - J_k sin(w0 k), I and J two independent first-order
Gauss-Markov processes (the AR(1) recursion, variance sigma^2, phi = exp(-dt/T)),
whose autocovariance is sigma^2 phi^|k| cos(w0 k); the catalogue simulates the
real part of a complex AR(1) instead.  Its Allan variance is checked against
the textbook sum AVAR(m) = (4 S(m) - S(2m)) / (2 m^2), S(m) = sum_{|k|<m} (m - |k|) r(k),
computed here term by term."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_allan import api
from imu_allan.noise import LP, Model
from imu_allan.noise.resonance import Resonance
from imu_allan.stats import allan

FS = 100.0
F0, QUALITY = 9.9, 10.0  # the mode of the ADIS16405 accelerometers' mount: 8.6-10.6 Hz, Q about 10
T = QUALITY / (math.pi * F0)
N_TRUE, FC = 0.1, 30.0


def _rice(n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    phi = math.exp(-1.0 / (FS * T))
    quad = []
    for _ in range(2):
        v = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
        quad.append(signal.lfilter([1.0], [1.0, -phi], v, zi=[phi * sigma * rng.standard_normal()])[0])
    w0k = 2 * math.pi * F0 / FS * np.arange(n)
    return quad[0] * np.cos(w0k) - quad[1] * np.sin(w0k)


def _textbook_avar(m: int, sigma: float) -> float:
    def s(mm: int) -> float:
        k = np.arange(1, mm)
        r = sigma**2 * np.exp(-k / (FS * T)) * np.cos(2 * math.pi * F0 * k / FS)
        return mm * sigma**2 + 2.0 * float(np.sum((mm - k) * r))

    return (4.0 * s(m) - s(2 * m)) / (2.0 * m * m)


def test_resonance_allan_variance_is_the_textbook_sum_at_every_cluster_size() -> None:
    res = Resonance(1.3, F0, T)
    ms = np.array([1, 2, 3, 4, 5, 7, 10, 16, 33, 64, 200, 1000])
    want = np.array([_textbook_avar(int(m), 1.3) for m in ms])
    np.testing.assert_allclose(res.avar(ms, FS), want, rtol=1e-9)


def test_resonance_curve_and_spectrum_are_those_of_an_independent_narrow_band_stream() -> None:
    sigma = 1.0
    x = _rice(1 << 20, sigma, np.random.default_rng(7))
    res = Resonance(sigma, F0, T)
    ms = 2 ** np.arange(0, 8)
    var, _ = allan.oavar(x, ms)
    np.testing.assert_allclose(var / res.avar(ms, FS), 1.0, atol=0.04)
    f, p = signal.welch(x, fs=FS, nperseg=4096)
    near = (f > F0 - 2) & (f < F0 + 2)  # the peak and its skirts, where the process has its power
    assert abs(float(np.median(p[near] / res.psd(f[near], FS))) - 1) < 0.05
    grid = np.linspace(1e-4, FS / 2, 400001)  # the one-sided PSD integrates to the variance
    assert abs(np.trapezoid(res.psd(grid, FS), grid) / sigma**2 - 1) < 1e-3
    assert abs(float(np.var(res.simulate(1 << 18, FS, 3))) / sigma**2 - 1) < 0.05  # the catalogue's own stream


def _sensor(n: int, seed: int, share: float) -> np.ndarray:
    """White noise N through a two-pole Butterworth (unit DC gain), plus the mode."""
    rng = np.random.default_rng(seed)
    b, a = signal.butter(2, FC, fs=FS)
    x = signal.lfilter(b, a, rng.standard_normal(n) * N_TRUE * math.sqrt(FS))
    if share:
        x = x + _rice(n, N_TRUE * math.sqrt(share * FS), rng)
    return x


@pytest.mark.parametrize("seed", [1, 2])
def test_fit_reads_n_under_a_resonance_from_an_independent_generator(seed) -> None:
    # the mode holds 6 % of the white noise's variance: without it in the model, the bump it
    # puts on the short taus is taken by N (2-3 % high, its interval missing the truth)
    fit = api.noise_terms(_sensor(1_000_000, seed, 0.06), FS)
    t = fit.terms
    assert t["N"].value is not None and abs(t["N"].value / N_TRUE - 1) < 0.02, fit.fitted
    assert t["N"].low <= N_TRUE <= t["N"].high, (t["N"], fit.fitted)
    assert t["Q"].value is None, fit.fitted
    assert "RES" in t, fit.fitted
    assert abs(t["RES"].extra["f0_hz"] / F0 - 1) < 0.1, t["RES"]
    assert QUALITY / 2 < t["RES"].extra["quality"] < QUALITY * 2, t["RES"]
    want_sd = N_TRUE * math.sqrt(0.06 * FS)
    assert abs(t["RES"].value / want_sd - 1) < 0.2, t["RES"]


def test_fit_reads_the_catalogues_own_resonance_stream_the_same_way() -> None:
    model = Model([LP(N_TRUE, FC, 2), Resonance(N_TRUE * math.sqrt(0.06 * FS), F0, T)])
    fit = api.noise_terms(model.simulate(1_000_000, FS, 5), FS)
    assert abs(fit.terms["N"].value / N_TRUE - 1) < 0.02, fit.fitted
    assert abs(fit.terms["RES"].extra["f0_hz"] / F0 - 1) < 0.1, fit.fitted


@pytest.mark.parametrize("seed", [3, 4])
def test_low_passed_white_noise_gets_no_resonance(seed) -> None:
    fit = api.noise_terms(_sensor(1_000_000, seed, 0.0), FS)
    assert "RES" not in fit.terms, fit.fitted
    assert abs(fit.terms["N"].value / N_TRUE - 1) < 0.02, fit.fitted
