"""IEEE Std 952 noise terms from an Allan variance curve, by weighted fit.

The model (IEEE Std 952-1997 Annex C; u is the channel's rate unit, tau in s):

    AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2

    Q quantization [u s]   N random walk [u sqrt(s)]   B bias instability [u]
    K rate random walk [u / sqrt(s)]                   R rate ramp [u / s]

is linear in the coefficients c = (Q^2, N^2, B^2, K^2, R^2) >= 0.

Weights. Each point's AVAR estimate is chi-squared with ``edf`` degrees of
freedom (Greenhall's EDF for the noise type of the term that dominates
there, edf.py), so its standard deviation is model * sqrt(2 / edf): the
model, not the noisy estimate, so low points pull no harder than high ones.
Estimates at neighbouring taus come from the same samples and are
correlated: between octaves about 0.5 for white rate noise, 0.7 for flicker
and 0.86 for a random walk (overlapping estimator; measured by simulation,
see tests/test_terms.py), falling off geometrically with the distance in
octaves. The fit is a generalized least squares with that covariance,
under c >= 0 (NNLS on the whitened system), iterated with the EDF and the
noise types. Without the correlation the intervals would be 2 to 3 times
too narrow.

Terms. Stepwise selection first: a term whose removal raises the
chi-squared by less than 3.84 (95 %, one degree of freedom; times the
reduced chi-squared when that exceeds 1, an F test) is dropped as not
supported by the data and the fit redone; a dropped term comes back when
adding it lowers the chi-squared by that much (two collinear terms, say K
and R on the last points, cannot push each other out). Each remaining term gets the
standard deviation of its coefficient (GLS covariance, widened by
sqrt(chi2/dof) when the model fits worse than the noise allows), a 95 %
interval from the chi-squared distribution with the coefficient's own EDF
(2 c^2 / var c; asymmetric, never below 0) and the tau range where it
dominates (its share of the model >= 1/2). A term is *not identifiable*
when its coefficient is 0 or dropped, when c < 1.96 sd, or when it
dominates nowhere in the measured range; it then gets a 95 % upper bound
instead of a value.

The classic read-off of the bias instability, min(ADEV) / 0.664 (the
thesis' sigma_B), is returned beside the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
from numpy.typing import ArrayLike

from ..stats import dist
from ..stats.dist import Z95
from .lsq import _cholesky, _least_squares, _nnls

TERMS = ("Q", "N", "B", "K", "R")
B_FACTOR = 2.0 * math.log(2.0) / math.pi
B_READOFF = math.sqrt(B_FACTOR)
"""0.664: ADEV of flicker rate noise of coefficient B."""
ALPHA = {"Q": 2, "N": 0, "B": -1, "K": -2, "R": -2}
SLOPE = {"Q": -1.0, "N": -0.5, "B": 0.0, "K": 0.5, "R": 1.0}
"""log-log slope of ADEV where each term dominates."""
CHI2_1_95 = 3.841458820694124
"""A term must lower the weighted chi-squared by this much (95 %, 1 degree of freedom)."""

EdfFn = Callable[[np.ndarray], np.ndarray]
"""alphas per point -> EDF per point."""


def basis(tau: np.ndarray) -> np.ndarray:
    """(points, 5) matrix: AVAR per unit coefficient of Q^2, N^2, B^2, K^2, R^2."""
    t = np.asarray(tau, dtype=np.float64)
    return np.stack([3.0 / t**2, 1.0 / t, np.full_like(t, B_FACTOR), t / 3.0, t**2 / 2.0], axis=1)


def model_avar(tau: np.ndarray, values: dict[str, Optional[float]]) -> np.ndarray:
    """AVAR of the terms ``values`` (missing or None count as 0)."""
    c = np.array([(values.get(k) or 0.0) ** 2 for k in TERMS])
    return basis(np.asarray(tau, dtype=np.float64)) @ c


@dataclass
class Term:
    name: str
    value: Optional[float]  # None when not identifiable
    low: Optional[float]
    high: Optional[float]
    tau_range: Optional[tuple[float, float]]  # where it dominates (share >= 1/2)
    estimate: float  # the fitted coefficient's square root (0 if none)
    upper: float  # 95 % upper bound (always available)
    note: str = ""
    extra: dict = field(default_factory=dict)
    """Parameters beyond the value (LP: fc, order; GM: tau_c) and their intervals."""

    @property
    def identifiable(self) -> bool:
        return self.value is not None


@dataclass
class FitResult:
    terms: dict[str, Term]
    coef: np.ndarray  # c = (Q^2, N^2, B^2, K^2, R^2)
    cov: np.ndarray  # 5 x 5 (zero rows for terms at 0)
    chi2_red: float
    used: np.ndarray  # bool per input point
    alpha: np.ndarray  # noise type used for each point's EDF
    edf: np.ndarray  # EDF used for each point (nan if unused)
    b_classic: Optional[dict] = None  # {"value", "tau_s", "low", "high"}
    notes: list[str] = field(default_factory=list)
    unexplained: list[dict] = field(default_factory=list)
    """tau ranges the terms do not explain (identify.py): {"tau_s", "kind", "ratio", "text"}."""

    def model(self, tau: np.ndarray) -> np.ndarray:
        return basis(np.asarray(tau, dtype=np.float64)) @ self.coef

    def values(self) -> dict[str, Optional[float]]:
        return {k: t.value for k, t in self.terms.items()}

    def estimates(self) -> dict[str, float]:
        return {k: t.estimate for k, t in self.terms.items()}


def local_alpha(tau: np.ndarray, avar: np.ndarray) -> np.ndarray:
    """Noise type from the local log-log slope of AVAR (neighbours on each side)."""
    from ..stats.edf import alpha_from_slopes

    lt, la = np.log(tau), np.log(avar)
    mu = np.full(tau.size, -1.0)  # one point: -1
    if tau.size > 1:  # each point's neighbours, the end points' one and themselves
        mu[1:-1] = (la[2:] - la[:-2]) / (lt[2:] - lt[:-2])
        mu[0] = (la[1] - la[0]) / (lt[1] - lt[0])
        mu[-1] = (la[-1] - la[-2]) / (lt[-1] - lt[-2])
    return alpha_from_slopes(mu)


RHO = {
    "overlapping": {2: 0.42, 1: 0.42, 0: 0.50, -1: 0.68, -2: 0.86},
    "nonoverlapping": {2: 0.29, 1: 0.29, 0: 0.35, -1: 0.56, -2: 0.83},
}
"""Correlation of AVAR estimates one octave apart, per noise type (simulated)."""
PER_OCTAVE = 8
"""Denser curves are thinned to this many points per octave for the fit."""


def _thin(t: np.ndarray) -> np.ndarray:
    """Indices of at most PER_OCTAVE points per octave (sorted t)."""
    if t.size < 3 or t.size <= PER_OCTAVE * (math.log2(t[-1] / t[0]) + 1):
        return np.arange(t.size)
    grid = np.exp2(np.arange(math.log2(t[0]), math.log2(t[-1]) + 1e-9, 1.0 / PER_OCTAVE))
    idx = np.unique(np.clip(np.searchsorted(t, grid), 0, t.size - 1))
    return np.unique(np.concatenate((idx, [t.size - 1])))


def octave_correlation(t: np.ndarray, alpha: np.ndarray, kind: str, power: float = 1.0) -> np.ndarray:
    """Correlation of the Allan estimates at octave taus ``t``: RHO per octave
    apart for each point's noise type ``alpha``, the geometric mean of the two;
    d octaves apart RHO^(d^power) (power 1: RHO^d)."""
    t, alpha, rho = np.asarray(t), np.asarray(alpha), RHO[kind]
    key = (tuple(rho.items()), power, t.dtype.str, t.tobytes(), alpha.dtype.str, alpha.tobytes())
    out = _CORRELATION.get(key)  # a fit asks for the same noise types hundreds of times
    if out is None:
        lam = -np.log(np.array([rho.get(int(a), rho[0]) for a in alpha]))
        l2 = np.log2(t)
        dist = np.abs(l2[:, None] - l2[None, :])
        out = np.exp(-(dist if power == 1.0 else dist**power) * (lam[:, None] + lam[None, :]) / 2.0)
        out.setflags(write=False)
        if len(_CORRELATION) > 256:
            _CORRELATION.clear()
        _CORRELATION[key] = out
    return out


_CORRELATION: dict[tuple, np.ndarray] = {}


class _Gls:
    """Whitening by the Cholesky factor of the estimates' covariance."""

    def __init__(
        self,
        t: np.ndarray,
        ref: np.ndarray,
        e: np.ndarray,
        alpha: np.ndarray,
        kind: str,
        floor: float = 0.0,
    ) -> None:
        sd = ref * np.sqrt(2.0 / e + floor * floor)
        S = octave_correlation(t, alpha, kind) * np.outer(sd, sd)
        self.L = _cholesky(S)
        # the inverse once (tens of points): scipy's solve_triangular per call costs milliseconds
        self.Li = np.linalg.inv(self.L)

    def white(self, v: np.ndarray) -> np.ndarray:
        return self.Li @ v


def usable_points(tau: np.ndarray, avar: np.ndarray, mask: Optional[ArrayLike] = None) -> np.ndarray:
    """The points a fit may use: a finite positive variance at a positive tau,
    and within ``mask`` when one is given (every fitter starts from these)."""
    used = np.isfinite(avar) & (avar > 0) & np.isfinite(tau) & (tau > 0)
    if mask is not None:
        used &= np.asarray(mask, dtype=bool)
    return used


def fit_points(tau: np.ndarray, avar: np.ndarray, mask: Optional[ArrayLike]) -> tuple[np.ndarray, ...]:
    """(used, idx, fitted): the usable points, the indices a fit uses (sorted by tau,
    thinned to PER_OCTAVE per octave) and those as a mask."""
    used = usable_points(tau, avar, mask)
    idx = np.flatnonzero(used)
    idx = idx[np.argsort(tau[idx])]
    idx = idx[_thin(tau[idx])]
    fitted = np.zeros(tau.size, dtype=bool)
    fitted[idx] = True
    return used, idx, fitted


def points_edf(edf_fn: EdfFn, idx: np.ndarray, size: int) -> Callable[[np.ndarray], np.ndarray]:
    """EDF of the fitted points (idx of ``size``) for their noise types; 1 where none."""

    seen: dict[bytes, np.ndarray] = {}

    def edf_of(alpha: np.ndarray) -> np.ndarray:
        key = np.asarray(alpha, dtype=np.int64).tobytes()
        e = seen.get(key)  # a fit asks for the same noise types hundreds of times
        if e is None:
            full = np.zeros(size, dtype=np.int64)
            full[idx] = alpha
            e = np.asarray(edf_fn(full), dtype=np.float64)[idx]
            e = np.where(np.isfinite(e) & (e > 0), e, 1.0)
            e.setflags(write=False)
            seen[key] = e
        return e

    return edf_of


def fit_terms(
    tau: ArrayLike,
    avar: ArrayLike,
    edf_fn: EdfFn,
    mask: Optional[np.ndarray] = None,
    overlapping: bool = True,
    iterations: int = 5,
    allowed: tuple[str, ...] = TERMS,
    floor: float = 0.0,
    caps: Optional[np.ndarray] = None,
    signature: Optional[dict[str, tuple[float, float]]] = None,
) -> FitResult:
    """Fit the IEEE 952 terms to the points (tau, avar) not masked out.

    ``edf_fn(alphas)`` gives each point's EDF for a noise type per point;
    ``overlapping`` selects the correlation between neighbouring estimates.
    ``floor``: relative standard deviation of the model's own error, added
    in quadrature to each point's statistical one (identify.py). ``caps``:
    upper limits of the coefficients c (Q^2 .. R^2), inf where free.
    ``signature``: tau ranges where the curve shows a term's own slope (the
    flat floor of B): a significant term that is nowhere half of the model is
    still reported there.
    """
    ub = None if caps is None else np.asarray(caps, dtype=np.float64)
    tau = np.asarray(tau, dtype=np.float64)
    avar = np.asarray(avar, dtype=np.float64)
    used, idx, fitted = fit_points(tau, avar, mask)
    coef = np.zeros(len(TERMS))
    cov = np.zeros((len(TERMS), len(TERMS)))
    alpha_all = np.zeros(tau.size, dtype=np.int64)
    edf_all = np.full(tau.size, np.nan)
    notes: list[str] = []
    if idx.size < 2:
        notes.append("fewer than 2 usable points: nothing to fit")
        terms = {k: Term(k, None, None, None, None, 0.0, math.inf, "no data") for k in TERMS}
        return FitResult(terms, coef, cov, math.nan, fitted, alpha_all, edf_all, None, notes)
    t, y = tau[idx], avar[idx]
    kind = "overlapping" if overlapping else "nonoverlapping"
    A = basis(t)
    cols = np.array([k in allowed for k in TERMS])
    edf_of = points_edf(edf_fn, idx, tau.size)
    alpha = local_alpha(t, y)
    cols, alpha, dropped = _stepwise(A, y, t, cols, alpha, edf_of, kind, iterations, floor, ub)
    coef, alpha, gls = _irls(A, y, t, cols, alpha, edf_of, kind, iterations, floor, ub)
    yw, Aw = gls.white(y), gls.white(A)
    active = coef > 0
    dof = max(t.size - int(active.sum()), 1)
    chi2_red = float(np.sum((yw - Aw @ coef) ** 2) / dof)
    inflate = max(1.0, chi2_red)
    if chi2_red > 2.0:
        notes.append(
            f"the model fits the curve only to chi2/dof = {chi2_red:.3g} (> 2): intervals are "
            "widened accordingly (noise not of the IEEE 952 kinds, or drift?)"
        )
    if active.any():
        ia = np.flatnonzero(active)
        cov[np.ix_(ia, ia)] = np.linalg.pinv(Aw[:, active].T @ Aw[:, active]) * inflate
    alpha_all[idx] = alpha
    edf_all[idx] = edf_of(alpha)
    terms = _all_terms(t, coef, cov, Aw, yw, allowed, inflate, ub, signature or {}, dropped)
    return FitResult(
        terms,
        coef,
        cov,
        chi2_red,
        fitted,
        alpha_all,
        edf_all,
        b_classic(tau, avar, used, edf_all),
        notes,
    )


def _all_terms(
    t: np.ndarray,
    coef: np.ndarray,
    cov: np.ndarray,
    Aw: np.ndarray,
    yw: np.ndarray,
    allowed: tuple[str, ...],
    inflate: float,
    ub: Optional[np.ndarray],
    signature: dict[str, tuple[float, float]],
    dropped: dict[str, tuple[float, float]],
) -> dict[str, Term]:
    grid = np.exp(np.linspace(math.log(t[0]), math.log(t[-1]), 400))
    active = coef > 0
    terms = {}
    for j, k in enumerate(TERMS):
        cap = math.sqrt(ub[j]) if ub is not None and math.isfinite(ub[j]) else math.inf
        terms[k] = _term(
            k,
            j,
            coef,
            cov,
            Aw,
            yw,
            grid,
            active,
            k in allowed,
            inflate,
            cap,
            signature.get(k),
        )
        if k in dropped:
            terms[k].note = (
                f"not identifiable: the other terms explain the curve as well "
                f"(chi2 gain {dropped[k][0]:.3g} < {dropped[k][1]:.3g}; at most {_fmt(terms[k].upper)})"
            )
    return terms


def _stepwise(
    A: np.ndarray,
    y: np.ndarray,
    t: np.ndarray,
    cols: np.ndarray,
    alpha: np.ndarray,
    edf_of: Callable[[np.ndarray], np.ndarray],
    kind: str,
    iterations: int,
    floor: float,
    ub: Optional[np.ndarray],
) -> tuple[np.ndarray, np.ndarray, dict[str, tuple[float, float]]]:
    """The terms kept: drop what the others can do without, re-admit what is missed
    (each by the chi2 test); the dropped ones with (chi2 gain, the threshold it missed)."""
    dropped: dict[str, tuple[float, float]] = {}
    seen: set[tuple[bool, ...]] = set()
    for _ in range(4 * len(TERMS)):
        coef, alpha, gls = _irls(A, y, t, cols, alpha, edf_of, kind, iterations, floor, ub)
        yw, Aw = gls.white(y), gls.white(A)
        key = tuple(cols.tolist())
        if key in seen:
            break
        seen.add(key)
        base = float(np.sum((yw - Aw @ coef) ** 2))
        active = np.flatnonzero(coef > 0)
        dof = max(t.size - active.size, 1)
        worst, worst_gain = None, math.inf
        if active.size > 1:
            for j in active:
                c2 = cols.copy()
                c2[j] = False
                gain = _chi2(Aw, yw, c2, ub) - base
                if gain < worst_gain:
                    worst, worst_gain = int(j), gain
        if worst is not None and worst_gain < CHI2_1_95 * max(1.0, base / dof):
            cols[worst] = False
            dropped[TERMS[worst]] = (worst_gain, CHI2_1_95 * max(1.0, base / dof))
            continue
        best, best_gain = None, 0.0
        for name in list(dropped):
            j = TERMS.index(name)
            c2 = cols.copy()
            c2[j] = True
            with_j = _chi2(Aw, yw, c2, ub)
            gain = base - with_j
            if gain >= CHI2_1_95 * max(1.0, with_j / max(dof - 1, 1)) and gain > best_gain:
                best, best_gain = j, gain
        if best is None:
            break
        cols[best] = True
        del dropped[TERMS[best]]
    return cols, alpha, dropped


def _chi2(Aw: np.ndarray, yw: np.ndarray, cols: np.ndarray, ub: Optional[np.ndarray] = None) -> float:
    c = np.zeros(Aw.shape[1])
    c[cols] = _nnls(Aw[:, cols], yw, None if ub is None else ub[cols])
    return float(np.sum((yw - Aw @ c) ** 2))


def _irls(
    A: np.ndarray,
    y: np.ndarray,
    t: np.ndarray,
    cols: np.ndarray,
    alpha: np.ndarray,
    edf_of: Callable[[np.ndarray], np.ndarray],
    kind: str,
    iterations: int,
    floor: float = 0.0,
    ub: Optional[np.ndarray] = None,
) -> tuple[np.ndarray, np.ndarray, _Gls]:
    """Iterated GLS-NNLS: covariance from the model, EDF and correlation from the noise types."""
    ref = y.copy()
    coef = np.zeros(len(TERMS))
    gls = _Gls(t, ref, edf_of(alpha), alpha, kind, floor)
    for _ in range(iterations):
        gls = _Gls(t, ref, edf_of(alpha), alpha, kind, floor)
        coef = np.zeros(len(TERMS))
        coef[cols] = _nnls(gls.white(A[:, cols]), gls.white(y), None if ub is None else ub[cols])
        mod = A @ coef
        ref = np.where(mod > 0, mod, y)
        if coef.any():
            share = A * coef
            alpha = np.array([ALPHA[TERMS[j]] for j in np.argmax(share, axis=1)])
    gls = _Gls(t, ref, edf_of(alpha), alpha, kind, floor)
    return coef, alpha, gls


def _term(
    k: str,
    j: int,
    coef: np.ndarray,
    cov: np.ndarray,
    Aw: np.ndarray,
    yw: np.ndarray,
    grid: np.ndarray,
    active: np.ndarray,
    allowed: bool,
    inflate: float,
    cap: float = math.inf,
    signature: Optional[tuple[float, float]] = None,
) -> Term:
    """One term's value, interval, range and bound; ``cap`` (term units) is the
    largest value whose line stays under the curve's 95 % interval: no
    interval or bound goes above it."""
    if not allowed:
        return Term(k, None, None, None, None, 0.0, 0.0, "left out of the fit")
    c = float(coef[j])
    sd = math.sqrt(max(cov[j, j], 0.0))
    upper = min(_upper(j, Aw, yw, active, inflate), cap)
    if not math.isfinite(upper):
        why = "cannot be bounded by these data (no point constrains it)"
        return Term(k, None, None, None, None, math.sqrt(max(c, 0.0)), math.inf, why)
    if c <= 0:
        why = f"not in the data (fitted coefficient 0; at most {_fmt(upper)})"
        return Term(k, None, None, None, None, 0.0, upper, why)
    estimate = math.sqrt(c)
    lo, hi = _interval(c, sd)
    hi = min(hi, cap)
    upper = max(upper, hi)
    rng = _dominant(basis(grid), j, coef, hi, grid)
    if c < Z95 * sd:
        why = f"not identifiable: its 95 % interval includes 0 (estimate {_fmt(estimate)}, at most {_fmt(upper)})"
        return Term(k, None, None, None, rng, estimate, upper, why)
    if rng is None and signature is not None:
        why = (
            f"from the curve's flat region {_fmt(signature[0])} .. {_fmt(signature[1])} s, "
            "where it shares the floor with the neighbouring terms (nowhere half of the model)"
        )
        return Term(k, estimate, lo, hi, signature, estimate, hi, why)
    if rng is None:
        why = (
            f"not identifiable: dominates nowhere in the measured range (estimate "
            f"{_fmt(estimate)}, at most {_fmt(upper)})"
        )
        return Term(k, None, None, None, None, estimate, upper, why)
    return Term(k, estimate, lo, hi, rng, estimate, hi)


def _interval(c: float, sd: float) -> tuple[float, float]:
    """95 % interval of sqrt(c), chi-squared with the coefficient's own degrees of
    freedom 2 c^2 / sd^2 (asymmetric, never below 0)."""
    if sd <= 0:
        return math.sqrt(c), math.sqrt(c)
    nu = 2.0 * (c / sd) ** 2
    q_hi, q_lo = float(dist.chi2_ppf(0.975, nu)), float(dist.chi2_ppf(0.025, nu))
    return (math.sqrt(c * nu / q_hi) if q_hi > 0 else 0.0), (math.sqrt(c * nu / q_lo) if q_lo > 0 else math.inf)


def _dominant(Gb: np.ndarray, j: int, coef: np.ndarray, hi: float, grid: np.ndarray) -> Optional[tuple[float, float]]:
    """The tau range where term j is at least half of the model (else where it
    would be at the top of its interval, ``hi``), None if nowhere."""
    c = float(coef[j])
    mod = Gb @ coef
    sel = Gb[:, j] * c >= 0.5 * mod
    if not sel.any():
        c_hi = hi * hi
        sel = Gb[:, j] * c_hi >= 0.5 * (mod + Gb[:, j] * (c_hi - c))
    return (float(grid[sel][0]), float(grid[sel][-1])) if sel.any() else None


def _upper(j: int, Aw: np.ndarray, yw: np.ndarray, active: np.ndarray, inflate: float) -> float:
    """95 % upper bound of term j: least squares of the (whitened) data without
    the sign constraint, on the active terms plus j: sqrt(max(c_j, 0) + 1.96 sd)."""
    sel = active.copy()
    sel[j] = True
    c, cov = _least_squares(Aw[:, sel], yw)
    cov = cov * inflate
    pos = int(np.flatnonzero(np.flatnonzero(sel) == j)[0])
    return math.sqrt(max(float(c[pos]), 0.0) + Z95 * math.sqrt(max(float(cov[pos, pos]), 0.0)))


def b_classic(
    tau: np.ndarray,
    avar: np.ndarray,
    used: np.ndarray,
    edf: Optional[np.ndarray] = None,
    min_edf: float = 10.0,
) -> Optional[dict]:
    """The thesis' read-off: B = min(ADEV) / 0.664 and the tau of that minimum,
    over the points with at least ``min_edf`` degrees of freedom (the last few
    points of a curve scatter by a factor of 2 and more: their minimum says
    little)."""
    ok = used & np.isfinite(avar) & (avar > 0)
    if edf is not None and np.any(ok & (np.nan_to_num(edf) >= min_edf)):
        ok &= np.nan_to_num(edf) >= min_edf
    if not ok.any():
        return None
    i = int(np.flatnonzero(ok)[np.argmin(avar[ok])])
    return {"value": math.sqrt(avar[i]) / B_READOFF, "tau_s": float(tau[i]), "index": i}


def _fmt(v: float) -> str:
    return f"{v:.3g}"
