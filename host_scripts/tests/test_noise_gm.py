"""A slow Gauss-Markov process beside band-limited white noise, graded on textbook streams.

Gaussian white noise of density N through a sampled one-pole RC (y_k = a y_{k-1} + (1 - a) x_k,
a = exp(-2 pi fc / fs)) or a two-pole Butterworth (scipy.signal.butter), plus an AR(1)
process from its difference equation (g_k = phi g_{k-1} + sigma sqrt(1 - phi^2) e_k,
phi = exp(-1 / (fs T)), started from its stationary law).  T is a fiftieth of the record,
and sigma puts the process's Allan deviation at four times the white line at 1.89 T, its
peak: the hump falls for the curve's last three to four octaves, where each estimate has a
few degrees of freedom and flicker plus a rate random walk can mimic it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_allan import api

FS = 400.0
SAMPLES = 1 << 20
N_TRUE = 0.003
T_TRUE = SAMPLES / FS / 50.0
HUMP = 4.0
CASES = [(kind, fc, seed) for kind in ("rc", "bw2") for fc in (FS / 100, FS / 20, FS / 4) for seed in (1, 2, 3, 4)]


def _gm_avar(sigma: float, T: float, tau: float) -> float:
    """AVAR of a first-order Gauss-Markov process (IEEE Std 952-1997 annex C, C.1.6)."""
    r = tau / T
    return sigma**2 * (2.0 / r) * (1.0 - (3.0 - 4.0 * math.exp(-r) + math.exp(-2.0 * r)) / (2.0 * r))


def _sigma() -> float:
    tau = 1.89 * T_TRUE
    return HUMP * N_TRUE / math.sqrt(tau) / math.sqrt(_gm_avar(1.0, T_TRUE, tau))


def _stream(kind: str, fc: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng([seed, int(fc), kind == "rc"])
    w = rng.standard_normal(SAMPLES) * N_TRUE * math.sqrt(FS)
    if kind == "rc":
        a = math.exp(-2.0 * math.pi * fc / FS)
        x = signal.lfilter([1.0 - a], [1.0, -a], w)
    else:
        x = signal.sosfilt(signal.butter(2, fc, fs=FS, output="sos"), w)
    sigma = _sigma()
    phi = math.exp(-1.0 / (FS * T_TRUE))
    e = rng.standard_normal(SAMPLES) * sigma * math.sqrt(1.0 - phi * phi)
    g0 = phi * sigma * rng.standard_normal()
    return x + signal.lfilter([1.0], [1.0, -phi], e, zi=[g0])[0]


@pytest.fixture(scope="module")
def fits() -> list:
    return [api.noise_terms(_stream(*case), FS).terms for case in CASES]


def test_the_hump_is_sized_as_stated() -> None:
    """The formula's peak: ADEV of the process at 1.89 T is HUMP times the white line."""
    tau = 1.89 * T_TRUE
    assert math.sqrt(_gm_avar(_sigma(), T_TRUE, tau)) == pytest.approx(HUMP * N_TRUE / math.sqrt(tau))
    near = [_gm_avar(1.0, T_TRUE, k * T_TRUE) for k in (1.7, 1.89, 2.1)]
    assert near[1] >= max(near[0], near[2]) * 0.999  # 1.89 T is the peak


def test_a_slow_gauss_markov_process_is_found_with_its_time_within_2x(fits) -> None:
    """The process fitted (GM1 or GM2, the larger) with T within a factor 2 of the truth on 19
    or more of the 24 streams (20 measured; 17-18 before a GM could take the place of the walk
    that mimics its hump), and N within 10 % on every one.  Not on all: on some records the hump's last
    octaves, a few degrees of freedom each, fit flicker plus a walk as well as the process
    (chi-squared equal within 0.1, the same number of parameters), or a walk alone."""
    found = []
    for case, t in zip(CASES, fits):
        assert abs(t["N"].value / N_TRUE - 1.0) < 0.10, (case, t["N"])
        gms = [v for k, v in t.items() if k.startswith("GM") and v.value]
        T = max(gms, key=lambda g: g.value).extra["tau_c"] if gms else None
        found.append((case, T and round(T / T_TRUE, 2)))
    held = sum(1 for _, r in found if r and 0.5 <= r <= 2.0)
    assert held >= 19, found
