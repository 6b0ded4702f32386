"""Equivalent degrees of freedom and chi-squared confidence intervals.

``edf_greenhall`` is the algorithm of C. A. Greenhall and W. J. Riley,
"Uncertainty of stability variances based on finite differences" (PTTI
2003; the basis of NIST SP 1065 section 5.3 and of Stable32): the EDF of an
Allan (d = 2), Hadamard (d = 3) or first-difference (d = 1) variance
estimate, unmodified or modified, for a power-law noise S_y(f) ~ f^alpha,
any stride. ``edf_simple`` holds the older closed forms of NIST SP 1065
Table 5 (overlapping ADEV). Both are tested against allantools.ci.

Stride: the estimator uses second differences starting every ``stride``
samples: 1 fully overlapping, m non-overlapping (the device's), anything
between for the strided levels of allan.OctaveEngine. Greenhall's stride
factor is S = m / stride.

Noise types for IMU rate data (alpha of S_rate(f) ~ f^alpha):
  Q quantization (white angle)  +2      N white rate (angle random walk)  0
  B flicker rate (bias instab.) -1      K rate random walk               -2
  R rate ramp: deterministic, treated as -2 (the fewest degrees of freedom).
"""

from __future__ import annotations

import functools
import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike
from scipy import special

from . import dist

J_MAX = 100
ALPHA_OF_TERM = {"Q": 2, "N": 0, "B": -1, "K": -2, "R": -2}

# Greenhall & Riley tables, rows alpha = +2 .. -4, columns d = 1, 2, 3 ((a0, a1); None: not allowed)
_TABLE1 = {
    2: ((2 / 3, 1 / 3), (7 / 9, 1 / 2), (22 / 25, 2 / 3)),
    1: ((0.840, 0.345), (0.997, 0.616), (1.141, 0.843)),
    0: ((1.079, 0.368), (1.033, 0.607), (1.184, 0.848)),
    -1: (None, (1.048, 0.534), (1.180, 0.816)),
    -2: (None, (1.302, 0.535), (1.175, 0.777)),
    -3: (None, None, (1.194, 0.703)),
    -4: (None, None, (1.489, 0.702)),
}
_TABLE2 = {
    2: ((3 / 2, 1 / 2), (35 / 18, 1.0), (231 / 100, 3 / 2)),
    1: ((78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)),
    0: ((2 / 3, 1 / 6), (2 / 3, 1 / 3), (7 / 9, 1 / 2)),
    -1: (None, (0.852, 0.375), (0.997, 0.617)),
    -2: (None, (1.079, 0.368), (1.033, 0.607)),
    -3: (None, None, (1.053, 0.553)),
    -4: (None, None, (1.302, 0.535)),
}
_TABLE3 = ((6.0, 4.0), (15.23, 12.0), (47.8, 40.0))  # alpha = 1: (b0, b1) per d
_SZ_WEIGHTS = {1: ((0, 2), (1, -1)), 2: ((0, 6), (1, -4), (2, 1)), 3: ((0, 20), (1, -15), (2, 6), (3, -1))}


def _sw(t: np.ndarray, alpha: int) -> np.ndarray:
    a = np.abs(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        lg = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
    if alpha == 2:
        return -a
    if alpha == 1:
        return t * t * lg
    if alpha == 0:
        return a**3
    if alpha == -1:
        return t**4 * lg
    if alpha == -2:
        return a**5
    if alpha == -3:
        return t**6 * lg
    if alpha == -4:
        return a**7
    raise ValueError(f"alpha must be an integer -4..2, got {alpha}")


def _sx(t: np.ndarray, F: float, alpha: int) -> np.ndarray:
    if math.isinf(F):
        return _sw(t, alpha + 2)
    return F * F * (2 * _sw(t, alpha) - _sw(t - 1.0 / F, alpha) - _sw(t + 1.0 / F, alpha))


def _sz(t: np.ndarray, F: float, alpha: int, d: int) -> np.ndarray:
    out = np.zeros_like(t, dtype=np.float64)
    for k, w in _SZ_WEIGHTS[d]:
        out += w * (_sx(t, F, alpha) if k == 0 else _sx(t - k, F, alpha) + _sx(t + k, F, alpha))
    return out


def _basic_sum(J: float, M: float, S: float, F: float, alpha: int, d: int) -> float:
    J = int(J)
    first = float(_sz(np.array([0.0]), F, alpha, d)[0]) ** 2
    second = (1 - J / M) * float(_sz(np.array([J / S]), F, alpha, d)[0]) ** 2
    third = 0.0
    if alpha == 2 and math.isfinite(F):
        # white PM: sx is a triangle of half-width 1/F, so sz(t) is zero but within 1/F of
        # t = 0..d; only those j (a few, where J reaches 2m ~ n at the longest taus) count
        j = _near_integers(J, S, F, d)
        return first + second + float(np.sum(2 * (1 - j / M) * _sz(j / S, F, alpha, d) ** 2))
    for a in range(1, J, SUM_CHUNK):  # in chunks: J reaches 2m (~n) for white PM at the longest taus
        j = np.arange(a, min(a + SUM_CHUNK, J), dtype=np.float64)
        third += float(np.sum(2 * (1 - j / M) * _sz(j / S, F, alpha, d) ** 2))
    return first + second + third


def _near_integers(J: int, S: float, F: float, d: int) -> np.ndarray:
    """The j in 1..J-1 with j / S within 1/F (and a step's margin) of one of 0..d."""
    picks = set()
    for k in range(d + 1):
        lo, hi = math.floor(S * (k - 1.0 / F)) - 1, math.ceil(S * (k + 1.0 / F)) + 1
        picks.update(range(max(lo, 1), min(hi, J - 1) + 1))
    return np.array(sorted(picks), dtype=np.float64)


SUM_CHUNK = 1 << 16
"""Terms of Greenhall's basic sum evaluated at a time (bounded memory)."""


def _sz0(F: float, alpha: int, d: int) -> float:
    return float(_sz(np.array([0.0]), F, alpha, d)[0])


@functools.lru_cache(maxsize=1 << 14)
def edf_greenhall(
    alpha: int, d: int, m: int, N: int, overlapping: bool = False, modified: bool = False, stride: Optional[int] = None
) -> float:
    """EDF of a variance estimate (Greenhall & Riley 2003).

    alpha: noise exponent of S_y (integer -4..2, alpha + 2d > 1); d: 1, 2
    (Allan) or 3 (Hadamard); m: averaging factor; N: phase points (rate
    samples + 1); overlapping: stride 1, else stride m (non-overlapping);
    ``stride`` overrides both. modified: MVAR (d = 2) / modified HVAR.
    """
    alpha, d = int(alpha), int(d)
    if alpha + 2 * d <= 1:
        raise ValueError(f"alpha {alpha} needs a higher difference order than d = {d}")
    F = 1.0 if modified else float(m)
    if stride is None:
        stride = 1 if overlapping else m
    S = float(m) / float(stride)
    L = m / F + m * d
    M = 1 + math.floor(S * (N - L) / m)
    if M < 1:
        return float("nan")
    J = min(M, (d + 1) * S)
    r = M / S
    if modified:
        if J <= J_MAX:
            return 1.0 / (_basic_sum(J, M, S, 1.0, alpha, d) / (_sz0(1.0, alpha, d) ** 2 * M))
        if r > d + 1:
            a0, a1 = _table(_TABLE1, alpha, d)
            return 1.0 / ((a0 - a1 / r) / r)
        mp = J_MAX / r
        return 1.0 / (_basic_sum(J_MAX, J_MAX, mp, 1.0, alpha, d) / (_sz0(1.0, alpha, d) ** 2 * J_MAX))
    if alpha <= 0:
        if J <= J_MAX:
            Fp = float(m) if m * (d + 1) <= J_MAX else math.inf
            return 1.0 / (_basic_sum(J, M, S, Fp, alpha, d) / (_sz0(Fp, alpha, d) ** 2 * M))
        if r > d + 1:
            a0, a1 = _table(_TABLE2, alpha, d)
            return 1.0 / ((a0 - a1 / r) / r)
        mp = J_MAX / r
        return 1.0 / (_basic_sum(J_MAX, J_MAX, mp, math.inf, alpha, d) / (_sz0(math.inf, alpha, d) ** 2 * J_MAX))
    if alpha == 1:
        if J <= J_MAX:
            return 1.0 / (_basic_sum(J, M, S, float(m), 1, d) / (_sz0(float(m), 1, d) ** 2 * M))
        b0, b1 = _TABLE3[d - 1]
        if r > d + 1:
            a0, a1 = _table(_TABLE2, alpha, d)
            return 1.0 / ((a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r))
        mp = J_MAX / r
        return 1.0 / (_basic_sum(J_MAX, J_MAX, mp, mp, 1, d) / ((b0 + b1 * math.log(m)) ** 2 * J_MAX))
    # alpha == 2, unmodified
    if math.ceil(r) > d:
        a0 = special.binom(4 * d, 2 * d) / special.binom(2 * d, d) ** 2
        return 1.0 / ((a0 - (d / 2.0) / r) / M)
    # few estimates (K <= d): the direct sum, which the closed form approximates
    return 1.0 / (_basic_sum(J, M, S, float(m), 2, d) / (_sz0(float(m), 2, d) ** 2 * M))


def _table(table: dict, alpha: int, d: int) -> tuple[float, float]:
    row = table[alpha][d - 1]
    if row is None:
        raise ValueError(f"no table entry for alpha {alpha}, d {d}")
    return row


def edf_simple(N: int, m: int, alpha: int) -> float:
    """NIST SP 1065 Table 5: EDF of the overlapping Allan variance (N phase points)."""
    N, m = float(N), float(m)
    if alpha == 2:
        return (N + 1) * (N - 2 * m) / (2 * (N - m))
    if alpha == 1:
        return math.exp(math.sqrt(math.log((N - 1) / (2 * m)) * math.log((2 * m + 1) * (N - 1) / 4)))
    if alpha == 0:
        return (3 * (N - 1) / (2 * m) - 2 * (N - 2) / N) * (4 * m * m / (4 * m * m + 5))
    if alpha == -1:
        return 2 * (N - 2) / (2.3 * N - 4.9) if m == 1 else 5 * N * N / (4 * m * (N + 3 * m))
    if alpha == -2:
        return (N - 2) / (m * (N - 3) ** 2) * ((N - 1) ** 2 - 3 * m * (N - 1) + 4 * m * m)
    raise ValueError(f"alpha must be -2..2, got {alpha}")


def chi2_interval(
    var: np.ndarray | float, edf: np.ndarray | float, level: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``level`` interval of a variance with ``edf`` degrees of freedom
    (NIST SP 1065 eq. 45): [edf var / chi2(1 - a/2), edf var / chi2(a/2)]."""
    v = np.asarray(var, dtype=np.float64)
    e = np.asarray(edf, dtype=np.float64)
    lo_q = (1 - level) / 2
    with np.errstate(invalid="ignore", divide="ignore"):
        low = e * v / dist.chi2_ppf(1 - lo_q, e)
        high = e * v / dist.chi2_ppf(lo_q, e)
    return low, high


def alpha_from_slope(mu: float) -> int:
    """alpha of the power-law noise whose AVAR goes as tau^mu (alpha_from_slopes)."""
    return int(alpha_from_slopes(np.array([mu], dtype=np.float64))[0])


def alpha_from_slopes(mu: ArrayLike) -> np.ndarray:
    """alpha of the power-law noise whose AVAR goes as tau^mu, for each mu: -mu - 1, rounded
    (half to even) and kept within the IMU noise types (+2 for mu <= -1.5: white angle; 0
    where mu is not finite)."""
    mu = np.asarray(mu, dtype=np.float64)
    a = np.where(mu <= -1.5, 2.0, np.minimum(np.maximum(np.rint(-mu - 1.0), -2.0), 0.0))
    return np.where(np.isfinite(mu), a, 0.0).astype(np.int64)


def edf_points(
    ms: np.ndarray,
    N: np.ndarray,
    stride: np.ndarray,
    d: int = 2,
    modified: bool = False,
    alphas: tuple[int, ...] = (2, 0, -1, -2),
    max_exact: int = 120,
) -> dict[int, np.ndarray]:
    """EDF of each point (m, N phase points, stride) for each noise type ``alphas``.

    Dense curves (more than ``max_exact`` points) get the EDF at ``max_exact``
    log-spaced points and log-log interpolation in between (the EDF is smooth
    in m)."""
    ms = np.asarray(ms, dtype=np.int64)
    N = np.broadcast_to(np.asarray(N, dtype=np.int64), ms.shape)
    stride = np.broadcast_to(np.asarray(stride, dtype=np.int64), ms.shape)
    if ms.size > max_exact:
        pick = np.unique(np.round(np.linspace(0, ms.size - 1, max_exact)).astype(np.int64))
    else:
        pick = np.arange(ms.size)
    out: dict[int, np.ndarray] = {}
    for a in alphas:
        vals = np.array([_safe_edf(a, d, int(ms[i]), int(N[i]), int(stride[i]), modified) for i in pick])
        if pick.size == ms.size:
            out[a] = vals
        else:
            ok = np.isfinite(vals) & (vals > 0)
            out[a] = np.exp(np.interp(np.log(ms), np.log(ms[pick][ok]), np.log(vals[ok])))
    return out


def _safe_edf(alpha: int, d: int, m: int, N: int, stride: int, modified: bool) -> float:
    """Greenhall's EDF; where it is undefined (too few points), the number of
    (overlapping) differences divided by their length in strides, at least 1."""
    try:
        e = edf_greenhall(alpha, d, m, N, modified=modified, stride=stride)
    except (ValueError, ZeroDivisionError, OverflowError, FloatingPointError):
        e = math.nan
    if not (math.isfinite(e) and e > 0):
        terms = max((N - 1 - d * m) // stride + 1, 1)
        e = max(terms * stride / (m * (d + 1)), 1.0)
    return float(e)


def edf_function(ms: np.ndarray, N: np.ndarray, stride: np.ndarray, d: int = 2, modified: bool = False):
    """alphas per point -> EDF per point, for fit_terms (tables computed once)."""
    table = edf_points(ms, N, stride, d, modified)

    def fn(alphas: np.ndarray) -> np.ndarray:
        a = np.asarray(alphas, dtype=np.int64)
        out = np.empty(a.size)
        for alpha, vals in table.items():
            sel = a == alpha
            out[sel] = vals[sel]
        other = ~np.isin(a, list(table))
        out[other] = table[0][other]
        return out

    return fn
