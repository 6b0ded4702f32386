"""The model error granted by tau region: a misfit the catalogue cannot fit, where it lives.

The streams are written here from textbook formulas, not with the catalogue's simulator:
white noise of density N (sd N sqrt(fs) per sample); sinusoids A sin(2 pi f t + phi) at
long taus, three of them (the catalogue holds one: the others are a misfit it cannot
fit, at their ADEV humps 0.371 / f = 1.2-7.4 s); a one-pole RC low-pass by its
difference equation y_k = a y_(k-1) + (1 - a) x_k, a = exp(-2 pi fc / fs) (unit gain at
0 Hz: N stays the low-frequency density); a mechanical mode as the AR(2) resonator
x_k = 2 r cos(w) x_(k-1) - r^2 x_(k-2) + e_k, r = exp(-pi f0 / (Q fs)), w = 2 pi f0 / fs,
whose variance is var(e) (1 + r^2) / ((1 - r^2) ((1 + r^2)^2 - 4 r^2 cos(w)^2)).

A whole-curve model error (one for every point) would widen N's interval by the lines
at long taus and hide the resonance of the short taus under it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_allan import api

FS, N_TRUE = 100.0, 0.02
SIZE = 1 << 20
LINES = ((0.004, 0.05), (0.004, 0.13), (0.003, 0.31))  # (amplitude, Hz): humps at 7.4, 2.9 and 1.2 s
F0, QUALITY, SHARE = 9.5, 10.0, 0.03  # a mount's mode: 3 % of the white variance
FC = 30.0


def _white(rng: np.random.Generator) -> np.ndarray:
    return rng.standard_normal(SIZE) * N_TRUE * math.sqrt(FS)


def _lines(rng: np.random.Generator) -> np.ndarray:
    t = np.arange(SIZE) / FS
    return sum(a * np.sin(2 * math.pi * f * t + rng.uniform(0, 2 * math.pi)) for a, f in LINES)


def _rc(x: np.ndarray) -> np.ndarray:
    a = math.exp(-2 * math.pi * FC / FS)
    return signal.lfilter([1 - a], [1.0, -a], x)


def _mode(rng: np.random.Generator) -> np.ndarray:
    r, w = math.exp(-math.pi * F0 / (QUALITY * FS)), 2 * math.pi * F0 / FS
    var = (1 + r * r) / ((1 - r * r) * ((1 + r * r) ** 2 - 4 * r * r * math.cos(w) ** 2))
    x = signal.lfilter([1.0], [1.0, -2 * r * math.cos(w), r * r], rng.standard_normal(SIZE))
    return x * math.sqrt(SHARE * N_TRUE**2 * FS / var)


def _width(n) -> float:
    return (n.high - n.low) / n.value


@pytest.mark.parametrize("seed", [1, 2])
def test_lines_at_long_taus_leave_N_interval_as_white_noise_alone_gives_it(seed: int) -> None:
    rng = np.random.default_rng(seed)
    white = _white(rng)
    alone = api.noise_terms(white, FS)
    fit = api.noise_terms(white + _lines(rng), FS)
    n, n0 = fit.terms["N"], alone.terms["N"]
    assert not alone.model_errors.any()  # white noise fits within chance: no model error at all
    # the lines misfit beyond chance: an error granted at their taus, none on the taus N is read on
    tau = FS**-1 * 2.0 ** np.arange(fit.model_errors.size)
    assert fit.model_errors[(tau >= 1.0) & (tau <= 8.0)].max() > 0
    assert not fit.model_errors[tau <= 0.16].any()
    assert _width(n) <= 1.5 * _width(n0), (n, n0)
    # N read as on the white noise alone (within that fit's half-width; the truth within 1 %)
    assert abs(n.value - n0.value) <= 0.5 * (n0.high - n0.low) and abs(n.value / N_TRUE - 1) < 0.01, (n, n0)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_resonance_beside_long_tau_lines_is_found_and_N_read_under_it(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = _rc(_white(rng)) + _mode(rng) + _lines(rng)
    fit = api.noise_terms(x, FS)
    n, res = fit.terms["N"], fit.terms.get("RES")
    assert res is not None and res.value is not None, sorted(fit.terms)
    assert abs(res.extra["f0_hz"] / F0 - 1) < 0.1
    assert abs(n.value / N_TRUE - 1) < 0.015 and n.low <= N_TRUE <= n.high, n
