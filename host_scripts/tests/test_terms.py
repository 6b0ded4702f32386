"""IEEE 952 noise terms: each term recovered from streams built for it, the
ones absent reported as not identifiable, intervals that hold the truth, and
the correlation constants the fit relies on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan.noise import lsq, terms
from imu_allan.noise.streams import Flicker
from imu_allan.stats import allan, edf

FS = 100.0


def _fit(x: np.ndarray, fs: float = FS) -> terms.FitResult:
    r = allan.octave_oavar(x)
    fn = edf.edf_function(r.ms, r.n + 1, r.stride)
    return terms.fit_terms(r.ms / fs, r.oavar[:, 0], fn)


def _stream(n: int, seed: int, Q=0.0, N=0.0, B=0.0, K=0.0, R=0.0, fs: float = FS) -> np.ndarray:
    """Rate samples with the given IEEE 952 terms (units u, u*s, u*sqrt(s) ...)."""
    rng = np.random.default_rng(seed)
    x = N * math.sqrt(fs) * rng.standard_normal(n)
    if Q:
        x += Q * fs * np.diff(rng.standard_normal(n + 1))  # white angle noise
    if K:
        x += np.cumsum(K / math.sqrt(fs) * rng.standard_normal(n))
    if R:
        x += R * np.arange(n) / fs
    if B:
        x += Flicker(B, fs, n, np.random.SeedSequence(seed + 1)).take(0, n)
    return x


def _rel(t: terms.Term, true: float) -> float:
    assert t.value is not None, t.note
    return t.value / true - 1


def test_quantization_and_white() -> None:
    f = _fit(_stream(1 << 18, 1, Q=0.03, N=0.1))
    assert abs(_rel(f.terms["Q"], 0.03)) < 0.10 and abs(_rel(f.terms["N"], 0.1)) < 0.10
    assert f.terms["Q"].tau_range[0] == pytest.approx(0.01) and f.terms["Q"].tau_range[1] < 0.5


def test_rate_ramp() -> None:
    f = _fit(_stream(1 << 19, 2, N=0.1, R=4e-4))
    assert abs(_rel(f.terms["R"], 4e-4)) < 0.10 and abs(_rel(f.terms["N"], 0.1)) < 0.02
    assert f.terms["R"].tau_range[0] > 20


def test_white_flicker_random_walk() -> None:
    """At 10 Hz for 58 h: N dominates up to 2 s, B from 3 to about 100 s, K beyond."""
    f = _fit(_stream(1 << 21, 3, N=0.02, B=0.02, K=0.002, fs=10.0), fs=10.0)
    for k, v in (("N", 0.02), ("B", 0.02), ("K", 0.002)):
        assert abs(_rel(f.terms[k], v)) < 0.10, (k, f.terms[k])
        t = f.terms[k]
        assert t.low < t.value < t.high
    lo_n, hi_n = f.terms["N"].tau_range
    lo_b, hi_b = f.terms["B"].tau_range
    lo_k, hi_k = f.terms["K"].tau_range
    assert lo_n == pytest.approx(0.1) and hi_n < lo_b < hi_b < lo_k  # N, then B, then K
    assert f.chi2_red < 5  # gen's flicker is 7 % high at tau0 (its fastest Gauss-Markov process)


def test_white_alone_leaves_the_others_unidentified() -> None:
    f = _fit(_stream(1 << 17, 4, N=0.05))
    assert abs(_rel(f.terms["N"], 0.05)) < 0.02
    for k in ("Q", "B", "K", "R"):
        t = f.terms[k]
        assert t.value is None and t.note.startswith("not") and t.upper >= 0
    # the upper bounds are real bounds: a B of that size would show
    assert f.terms["B"].upper < 0.05 / math.sqrt(0.5 * (1 << 17) / FS) / terms.B_READOFF * 3


def test_classic_b_readoff() -> None:
    f = _fit(_stream(1 << 20, 5, N=0.1, B=0.05))
    assert f.b_classic is not None
    # min(ADEV)/0.664: N still adds on the floor (high), the minimum of noisy points (low)
    assert 0.85 < f.b_classic["value"] / 0.05 < 1.3
    assert abs(_rel(f.terms["B"], 0.05)) < 0.05


def test_intervals_hold_the_truth() -> None:
    """N and K 95 % intervals over 16 records: the GLS with correlated points keeps
    them honest (without the correlation they would be 2-3 times too narrow)."""
    hit_n = hit_k = 0
    for seed in range(16):
        f = _fit(_stream(1 << 16, 100 + seed, N=0.18, K=0.03))
        tn, tk = f.terms["N"], f.terms["K"]
        hit_n += tn.value is not None and tn.low <= 0.18 <= tn.high
        hit_k += tk.value is not None and tk.low <= 0.03 <= tk.high
    assert hit_n >= 12 and hit_k >= 12


@pytest.mark.parametrize("kind,rho", [("white", 0.50), ("walk", 0.86)])
def test_correlation_of_neighbouring_octaves(kind: str, rho: float) -> None:
    """The correlation of overlapping AVAR estimates one octave apart that the
    fit assumes (terms.RHO), re-measured on 200 simulated records."""
    rng = np.random.default_rng(7)
    est = []
    for _ in range(200):
        w = rng.standard_normal(1 << 12)
        r = allan.octave_oavar(np.cumsum(w) if kind == "walk" else w)
        est.append(r.oavar[3:8, 0])
    c = np.corrcoef(np.array(est).T)
    measured = float(np.mean(np.diag(c, 1)))
    assert terms.RHO["overlapping"][0 if kind == "white" else -2] == rho
    assert abs(measured - rho) < 0.12


def test_model_and_basis() -> None:
    tau = np.array([0.1, 1.0, 10.0])
    v = terms.model_avar(tau, {"N": 2.0, "B": 1.0, "K": None})
    np.testing.assert_allclose(v, 4.0 / tau + 2 * math.log(2) / math.pi)
    assert terms.B_READOFF == pytest.approx(0.6643, abs=1e-4)


def test_nonnegative_least_squares_is_scipys() -> None:
    """The fit's non-negative least squares (on unit-norm columns, scipy's solver called without
    its argument checks where scipy has it) gives scipy.optimize.nnls's answer to the last bit,
    on problems shaped like the fit's (tens of points, columns 1e-20 to 1e20 apart), and
    refuses a non-finite column as scipy does."""
    from scipy import optimize

    rng = np.random.default_rng(3)
    for _ in range(300):
        m, k = int(rng.integers(4, 25)), int(rng.integers(1, 7))
        A = rng.standard_normal((m, k)) * np.exp(rng.uniform(-20, 20, k))
        y = rng.standard_normal(m) * math.exp(rng.uniform(-5, 5))
        norm = np.sqrt(np.sum(A * A, axis=0))
        want = optimize.nnls(A / norm, y, maxiter=50 * k)[0] / norm
        assert np.array_equal(lsq._nnls(A, y), want)
    A[0, 0] = np.nan
    with pytest.raises(ValueError):
        lsq._nnls(A, y)
