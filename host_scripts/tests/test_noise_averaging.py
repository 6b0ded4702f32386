"""The averaging band limit (a moving average; two in cascade: the Bartlett window
of parts that average at an internal rate far above the rate they are read at),
graded by what it did not make: the textbook discrete filter at a fine internal
rate, built here with numpy alone (np.convolve of boxes of L taps, every U-th
sample read), its Allan variance computed from the definition (the variance of
the difference of adjacent cluster means, a linear filter of the white noise:
the sum of its squared weights)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan import api
from imu_allan.noise import LP, Flicker, Model
from imu_allan.noise.averaging import X3DB

FS = 100.0


def _kernel(stages: int, taps: int) -> np.ndarray:
    h = np.ones(1)
    for _ in range(stages):
        h = np.convolve(h, np.ones(taps) / taps)
    return h


def _avar_by_definition(h: np.ndarray, up: int, m: int) -> float:
    """AVAR at cluster size m of unit white noise at the fine rate through h, read every
    ``up``-th sample: half the variance of the difference of two adjacent m-means."""
    comb = np.zeros(2 * m * up)
    comb[: m * up : up] = -1.0 / m
    comb[m * up :: up] = 1.0 / m
    w = np.convolve(comb, h)
    return 0.5 * float(np.sum(w * w))


def _lf_density(h: np.ndarray, up: int) -> float:
    """dt sum_k r(k) of the read samples (unit white at the fine rate): the level N^2."""
    r = np.correlate(h, h, mode="full")
    mid = h.size - 1
    lags = np.arange(-(mid // up), mid // up + 1) * up + mid
    return float(np.sum(r[lags])) / FS


@pytest.mark.parametrize("stages", [1, 2])
@pytest.mark.parametrize("width", [0.6, 1.0, 1.7, 6.3])  # the average's width, in read samples
def test_exact_allan_variance_matches_the_definition_on_a_fine_internal_rate(stages, width) -> None:
    up = 400
    h = _kernel(stages, int(round(width * up)))
    fc = X3DB[stages] / (width / FS)
    level = _lf_density(h, up)
    for m in (1, 2, 3, 5, 8, 16, 64):
        truth = _avar_by_definition(h, up, m) / level  # per unit low-frequency density
        got = float(LP(1.0, fc, stages, "average").avar(np.array([m]), FS)[0])
        assert abs(got / truth - 1) < 2e-3, (m, got, truth)


def _bartlett_stream(n: int, seed: int, n_true: float, up: int = 32, taps: int = 32) -> np.ndarray:
    """White noise at up * FS through two cascaded averages of ``taps`` taps (each a
    difference of the cumulative sum), read every ``up``-th sample (an iSensor part's
    Bartlett window, decimated by reading)."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n * up + 2 * taps) * n_true * math.sqrt(FS * up)
    for _ in range(2):
        c = np.concatenate(([0.0], np.cumsum(x)))
        x = (c[taps:] - c[:-taps]) / taps
    return x[::up][:n]


def test_fit_reads_the_white_level_through_an_independent_bartlett_window() -> None:
    n_true = 0.04
    x = _bartlett_stream(1 << 20, 3, n_true)
    fit = api.noise_terms(x, FS)
    n = fit.terms["N"]
    assert n.value is not None and abs(n.value / n_true - 1) < 0.03, (n, fit.fitted)
    assert n.low <= n_true <= n.high, (n, fit.fitted)
    assert fit.terms["Q"].value is None, fit.fitted
    lp = fit.terms["LP"]
    assert lp.extra["shape"] == "average", fit.fitted  # the averages fit it better than the poles


def test_the_catalogues_own_bartlett_stream_with_flicker() -> None:
    n_true, b_true = 0.04, 0.01
    x = (Model([LP(n_true, 30.0, 2, "average")]) + Flicker(b_true)).simulate(1 << 20, FS, 5)
    fit = api.noise_terms(x, FS)
    assert abs(fit.terms["N"].value / n_true - 1) < 0.05, fit.fitted
    assert fit.terms["B"].value is not None and abs(fit.terms["B"].value / b_true - 1) < 0.35, fit.fitted


def test_the_catalogues_stream_has_the_exact_autocovariance() -> None:
    from imu_allan.noise.averaging import average_autocov

    x = LP(1.0, 25.0, 2, "average").simulate(1 << 20, FS, 9)
    r = average_autocov(25.0, FS, 2)
    got = np.array([np.mean(x[: x.size - k] * x[k:]) for k in range(r.size + 2)])
    want = np.concatenate((r, [0.0, 0.0]))
    assert np.all(np.abs(got - want) < 5 * r[0] / math.sqrt(x.size)), (got, want)
