"""The whole-curve fit: a sum of catalogue processes fitted to every octave
point of an Allan variance curve, weighted by the estimates' covariance.

The model (processes.py; u the channel's rate unit, m = tau fs):

    AVAR(m) = Q^2 q(m) + N^2 w(m; fc) + B^2 b + K^2 k(m) + R^2 r(m) + sum_j s_j^2 g(m; T_j)

each column the exact discrete-time AVAR of its process at unit size (w the
white noise, or, with a band limit, the low-passed white noise of cutoff fc,
order 1 or 2, normalized to unit LOW-FREQUENCY density; g a Gauss-Markov
process of correlation time T_j).  The model is linear in the squares c >= 0
and nonlinear in fc and the T_j: variable projection (for given fc, T the
c are the GLS non-negative least squares; fc and T by scipy.optimize over
their logarithms, started from a grid over the measured tau range and
bounded to it, so the search never leaves the curve).

Weights: the generalized least squares of terms.py (each point chi-squared
with Greenhall's EDF for the local noise type, correlated between octaves),
iterated with the model as the reference (GMWM, Guerrier et al. 2013, weights
by the estimates' covariance the same way).  A real sensor is never exactly a
sum of catalogue processes, and a million samples make the short-tau points
so precise that any misfit there would decide everything: when chi2/dof
exceeds 1, a model error (relative, at most MODEL_ERR of the deviation) is
added in quadrature to each point's sd, the least that brings chi2/dof to 1,
and the intervals are widened by what remains.

Model selection: the IEEE 952 terms first (stepwise, terms.py), then a band
limit (replacing white N by the low-passed one; order 1 or 2, whichever fits
better) and up to MAX_GM Gauss-Markov processes are each kept only when they
lower chi-squared by the 95 % point of chi2 with their number of parameters
(times chi2/dof when above 1: an F test); then each linear term whose removal
costs less than 3.84 is dropped.  Intervals (95 %): from the covariance of
all parameters (Jacobian of the whitened residuals), chi-squared shaped for
the c (never below 0), log-normal for fc and T.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize, stats

from ..stats.edf import alpha_from_slope
from .processes import AR1, LP, QN, RW, WN, Model, Ramp, Sine
from .reading import _compare, _linear_term, _unexplained, slope_reading, to_model
from .terms import B_FACTOR, CHI2_1_95, TERMS, EdfFn, FitResult, Term, _nnls, _thin, b_classic, usable_points

MAX_GM = 2
SINE = False
"""Try a sinusoid (an oscillation's hump, ADEV peak at 0.371 / f0, two octaves or more inside
the curve) after the GM processes on every curve; otherwise only where the first fit leaves a
hump whose excess falls like an oscillation's (elsewhere it would trade against K and the GMs)."""
GM_T_MIN = 10.0
"""A Gauss-Markov process's T is at least this many shortest taus (its ADEV hump,
at 1.89 T, four octaves into the curve): a faster one is white noise there."""
MODEL_ERR = 0.05
"""Largest relative model error granted (ADEV; 0.10 in AVAR)."""
Z95 = 1.959963984540054
CHI2_2_95 = 5.991464547107979
LINEAR = ("Q", "N", "B", "K", "R")


@dataclass
class Structure:
    linear: tuple[str, ...] = LINEAR  # which IEEE 952 columns are free
    lp: int = 0  # 0: white N; 1 or 2: N low-passed (order)
    ngm: int = 0
    sine: int = 0  # 1: a sinusoid (amplitude, frequency)

    def names(self) -> list[str]:
        return list(self.linear) + [f"GM{j + 1}" for j in range(self.ngm)] + ["SIN"] * self.sine

    def nonlinear(self) -> list[str]:
        return (["fc"] if self.lp else []) + [f"T{j + 1}" for j in range(self.ngm)] + ["f0"] * self.sine


def columns(s: Structure, theta: np.ndarray, m: np.ndarray, fs: float) -> np.ndarray:
    """(points, columns) AVAR per unit coefficient, in the order of s.names()."""
    cols = []
    i = 0
    fc = math.exp(theta[0]) if s.lp else None
    for k in s.linear:
        if k == "Q":
            cols.append(QN(1.0).avar(m, fs))
        elif k == "N":
            cols.append(LP(1.0, fc, s.lp).avar(m, fs) if s.lp else WN(1.0).avar(m, fs))
        elif k == "B":
            cols.append(np.full(m.shape, B_FACTOR))
        elif k == "K":
            cols.append(RW(1.0).avar(m, fs))
        elif k == "R":
            cols.append(Ramp(1.0).avar(m, fs))
    i = 1 if s.lp else 0
    for j in range(s.ngm):
        cols.append(AR1(1.0, math.exp(theta[i + j])).avar(m, fs))
    if s.sine:
        cols.append(Sine(1.0, math.exp(theta[-1])).avar(m, fs))
    return np.stack(cols, axis=1) if cols else np.zeros((m.size, 0))


@dataclass
class CurveFit(FitResult):
    """FitResult of the whole-curve fit: ``terms`` holds Q N B K R and, when
    fitted, LP (fc, order) and GM1, GM2 (tau_c); ``fitted`` the catalogue
    model; ``slope`` the IEEE 952 slope reading beside it."""

    fs: float = 1.0
    fitted: Model = field(default_factory=Model)
    structure: Structure = field(default_factory=Structure)
    slope: dict = field(default_factory=dict)

    def model(self, tau: np.ndarray) -> np.ndarray:
        return self.fitted.avar(np.asarray(tau, dtype=np.float64) * self.fs, self.fs)

    def components(self, tau: ArrayLike) -> dict[str, np.ndarray]:
        """AVAR of each fitted process at tau, by term name (N for white or low-passed)."""
        m = np.asarray(tau, dtype=np.float64) * self.fs
        out: dict[str, np.ndarray] = {}
        gm = 0
        for p in self.fitted:
            name = p.name
            if name == "LP":
                name = "N"
            if name == "GM":
                gm += 1
                name = f"GM{gm}"
            if name == "S":
                name = "SIN"
            out[name] = p.avar(m, self.fs)
        return out


class _Gls:
    """Whitening by the Cholesky factor of the estimates' covariance: the
    statistical part correlated between octaves (terms.RHO), the model error
    (``floor``, relative sd of AVAR) independent from point to point."""

    def __init__(
        self,
        t: np.ndarray,
        ref: np.ndarray,
        e: np.ndarray,
        alpha: np.ndarray,
        kind: str,
        floor: float = 0.0,
        robust: Optional[np.ndarray] = None,
    ) -> None:
        from .terms import RHO, _cholesky

        sd = ref * np.sqrt(2.0 / e)
        rho = RHO[kind]
        lam = -np.log(np.array([rho.get(int(a), rho[0]) for a in alpha]))
        l2 = np.log2(t)
        dist = np.abs(l2[:, None] - l2[None, :])
        S = np.exp(-dist * (lam[:, None] + lam[None, :]) / 2.0) * np.outer(sd, sd)
        S[np.diag_indices_from(S)] += (floor * ref) ** 2
        self.sd = np.sqrt(np.diag(S))
        if robust is not None:  # points far off the model: their variance raised (influence capped)
            S = S * np.sqrt(np.outer(robust, robust))
        self.S = S
        self.Li = np.linalg.inv(_cholesky(S))

    def white(self, v: np.ndarray) -> np.ndarray:
        return self.Li @ v


class _Problem:
    """The points of one curve and their covariance model."""

    def __init__(self, t: np.ndarray, y: np.ndarray, fs: float, edf_of, kind: str, floor: float = 0.0) -> None:
        self.t, self.y, self.fs, self.m = t, y, fs, t * fs
        self.edf_of, self.kind = edf_of, kind
        self.floor = floor
        self.robust = np.ones(t.size)
        self.robust_on = False
        self.sine_on = SINE
        self.set_reference(y)

    def set_reference(self, ref: np.ndarray) -> None:
        self.ref = np.where(ref > 0, ref, self.y)
        self.alpha = _alphas(self.t, self.ref)
        self.e = self.edf_of(self.alpha)
        self.gls = _Gls(self.t, self.ref, self.e, self.alpha, self.kind, self.floor, self.robust)
        self.yw = self.gls.white(self.y)

    def solve(self, s: Structure, theta: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        A = columns(s, theta, self.m, self.fs)
        Aw = self.gls.white(A)
        c = _nnls(Aw, self.yw) if A.shape[1] else np.zeros(0)
        return c, float(np.sum((self.yw - Aw @ c) ** 2)), A


def _alphas(t: np.ndarray, model: np.ndarray) -> np.ndarray:
    lt, la = np.log(t), np.log(model)
    out = np.zeros(t.size, dtype=np.int64)
    for i in range(t.size):  # over curve points (tens)
        a, b = max(i - 1, 0), min(i + 1, t.size - 1)
        out[i] = alpha_from_slope((la[b] - la[a]) / (lt[b] - lt[a]) if b > a else -1.0)
    return out


def _bounds(s: Structure, t: np.ndarray, fs: float) -> list[tuple[float, float]]:
    out = []
    if s.lp:
        out.append((math.log(max(0.5 / (2 * math.pi * t[-1]), fs / 5000.0)), math.log(0.49 * fs)))
    for _ in range(s.ngm):  # a faster GM is white noise to these taus: N's, not a GM's
        out.append((math.log(t[0] * GM_T_MIN), math.log(t[-1] * 4.0)))
    if s.sine:  # its ADEV peaks at 0.371 / f0: inside the measured taus
        out.append((math.log(0.371 * 4 / t[-1]), math.log(min(0.371 / (4 * t[0]), 0.45 * fs))))
    return out


def _optimize(p: _Problem, s: Structure, theta0: np.ndarray, new: Optional[int]) -> tuple[np.ndarray, float]:
    """Nonlinear parameters minimizing chi2: a grid on the new one (others held),
    then a bounded joint polish."""
    bnds = _bounds(s, p.t, p.fs)
    if not bnds:
        return theta0, p.solve(s, theta0)[1]
    theta = np.array(theta0, dtype=np.float64)

    def f(th: np.ndarray) -> float:
        return p.solve(s, _clip(s, th, bnds))[1]

    if new is not None:
        lo, hi = bnds[new]
        best = (math.inf, theta[new])
        for g in np.linspace(lo, hi, 11):
            theta[new] = g
            v = f(theta)
            if v < best[0]:
                best = (v, g)
        theta[new] = best[1]
    if theta.size == 1:
        lo, hi = bnds[0]
        step = (hi - lo) / 16
        r = optimize.minimize_scalar(
            lambda x: f(np.array([x])),
            bounds=(max(lo, theta[0] - step), min(hi, theta[0] + step)),
            method="bounded",
            options={"xatol": 1e-3},
        )
        theta = np.array([r.x]) if r.fun <= f(theta) else theta
    else:
        r = optimize.minimize(
            f, theta, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-6, "maxfev": 30 * theta.size}
        )
        if r.fun <= f(theta):
            theta = np.asarray(r.x)
    theta = _clip(s, theta, bnds)
    return theta, f(theta)


GM_LP_FACTOR = 10.0
"""With a band limit, a GM's T is at least this many of the filter's time constants
1 / (2 pi fc): a faster GM only reshapes the filter's bend."""


def _clip(s: Structure, th: np.ndarray, bnds: list[tuple[float, float]]) -> np.ndarray:
    th = np.clip(th, [b[0] for b in bnds], [b[1] for b in bnds])
    if s.lp and s.ngm:
        th[1 : 1 + s.ngm] = np.maximum(th[1 : 1 + s.ngm], math.log(GM_LP_FACTOR / (2 * math.pi)) - th[0])
    return th


def _fit_structure(
    p: _Problem, s: Structure, theta0: np.ndarray, new: Optional[int], rounds: int = 2
) -> tuple[np.ndarray, np.ndarray, float]:
    """(theta, c, chi2) of a structure, the weights iterated with its model."""
    theta = theta0
    for _ in range(rounds):
        theta, _ = _optimize(p, s, theta, new)
        new = None
        c, chi2, A = p.solve(s, theta)
        mod = A @ c
        p.set_reference(mod)
        if p.robust_on:
            z = (p.y - mod) / p.gls.sd
            p.robust = np.maximum(1.0, (z / ROBUST_Z) ** 2)
            p.set_reference(mod)
    c, chi2, _ = p.solve(s, theta)
    return theta, c, chi2


ROBUST_Z = 3.0
"""A point more than this many sd off the model gets its variance raised so that it
counts as ROBUST_Z sd (capped influence: a resonance or a hump the catalogue lacks
cannot pull the other terms)."""


def _test(gain: float, chi2_big: float, dof_big: int, params: int) -> bool:
    q = CHI2_1_95 if params == 1 else float(stats.chi2.ppf(0.95, params))
    return gain >= q * max(1.0, chi2_big / max(dof_big, 1))


def fit_curve(
    tau: ArrayLike,
    avar: ArrayLike,
    edf_fn: EdfFn,
    fs: Optional[float] = None,
    mask: Optional[np.ndarray] = None,
    overlapping: bool = True,
    allowed: tuple[str, ...] = TERMS,
    extended: bool = True,
) -> CurveFit:
    """Fit the catalogue to the curve (tau s, avar u^2) at the sample rate fs.

    ``edf_fn(alphas)`` gives each point's EDF (edf.edf_function); ``mask`` the
    points to use; ``allowed`` the IEEE 952 terms that may appear;
    ``extended`` False: the five IEEE 952 terms only (no band limit, no GM)."""
    tau = np.asarray(tau, dtype=np.float64)
    avar = np.asarray(avar, dtype=np.float64)
    used = usable_points(tau, avar, mask)
    idx = np.flatnonzero(used)
    idx = idx[np.argsort(tau[idx])]
    idx = idx[_thin(tau[idx])]
    fitted = np.zeros(tau.size, dtype=bool)
    fitted[idx] = True
    if fs is None:
        fs = 1.0 / float(tau[idx].min()) if idx.size else 1.0
    kind = "overlapping" if overlapping else "nonoverlapping"
    if idx.size < 2:
        terms = {k: Term(k, None, None, None, None, 0.0, math.inf, "no data") for k in TERMS}
        return CurveFit(
            terms,
            np.zeros(5),
            np.zeros((5, 5)),
            math.nan,
            fitted,
            np.zeros(tau.size, np.int64),
            np.full(tau.size, np.nan),
            None,
            ["fewer than 2 usable points: nothing to fit"],
            fs=fs,
        )
    t, y = tau[idx], avar[idx]

    def edf_of(alpha: np.ndarray) -> np.ndarray:
        full = np.zeros(tau.size, dtype=np.int64)
        full[idx] = alpha
        e = np.asarray(edf_fn(full), dtype=np.float64)[idx]
        return np.where(np.isfinite(e) & (e > 0), e, 1.0)

    lin = tuple(k for k in LINEAR if k in allowed)
    notes: list[str] = []

    def select(
        sub: np.ndarray, floor: float, robust: bool = False, sine: bool = False
    ) -> tuple[_Problem, Structure, np.ndarray]:
        def edf_sub(alpha: np.ndarray) -> np.ndarray:
            a = np.zeros(t.size, dtype=np.int64)
            a[sub] = alpha
            return edf_of(a)[sub]

        p = _Problem(t[sub], y[sub], fs, edf_sub, kind, floor)
        p.robust_on, p.sine_on = robust, sine or SINE
        s, theta, c, chi2 = _stepwise(p, Structure(lin), np.zeros(0))
        if extended and "N" in lin and sub.size >= 4:
            s, theta, c, chi2 = _extend(p, s, theta, c, chi2, lin)
        return p, s, theta

    keep = np.arange(t.size)
    p, s, theta = select(keep, 0.0)
    c, chi2, _ = p.solve(s, theta)
    floor = _set_floor(p, s, theta, c, max(p.t.size - int(np.sum(c > 0)) - theta.size, 1))
    if floor > 0:  # a real sensor: select again, the model error in the weights, robustly
        c, _, A = p.solve(s, theta)  # a sinusoid only where the curve shows an oscillation's hump
        osc = any(r["kind"] == "oscillation" for r in _unexplained(p, A @ c, p.e))
        s1, th1 = s, theta
        p, s, theta = select(keep, floor, robust=True, sine=osc)
        # the first structure under the same weights: the robust selection may wander off
        p1 = _Problem(t, y, fs, edf_of, kind, floor)
        p1.robust_on = True
        th1, c1, chi1 = _fit_structure(p1, s1, th1, None)
        c2, chi2_, _ = p.solve(s, theta)
        if chi1 + 2 * (np.sum(c1 > 0) + th1.size) < chi2_ + 2 * (np.sum(c2 > 0) + theta.size):
            p, s, theta = p1, s1, th1
    res = _result(p, s, theta, tau, avar, used, fitted, idx, notes)
    return res


def _stepwise(
    p: _Problem, s: Structure, theta: np.ndarray, keep: tuple[str, ...] = ()
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """Drop the linear terms the others can do without (chi2 gain < 3.84, F test)."""
    theta, c, chi2 = _fit_structure(p, s, theta, None)
    while True:
        names = s.names()
        zero = [k for k, v in zip(names, c) if v <= 0 and k in s.linear and k not in keep]
        if zero:  # terms at 0 leave without a test
            s = replace(s, linear=tuple(k for k in s.linear if k not in zero))
            theta, c, chi2 = _fit_structure(p, s, theta, None, rounds=1)
            continue
        active = [k for k, v in zip(names, c) if v > 0 and k in s.linear and k not in keep]
        dof = max(p.t.size - int(np.sum(c > 0)) - theta.size, 1)
        if len(active) + len(keep) <= 1:
            return s, theta, c, chi2
        best = None
        for k in active:
            s2 = replace(s, linear=tuple(x for x in s.linear if x != k))
            _, chi2b, _ = p.solve(s2, theta)
            if best is None or chi2b < best[1]:
                best = (s2, chi2b)
        if best is None or _test(best[1] - chi2, chi2, dof, 1):
            return s, theta, c, chi2
        s = best[0]
        theta, c, chi2 = _fit_structure(p, s, theta, None, rounds=1)


def _extend(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float, lin: tuple[str, ...]
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """Band limit, then Gauss-Markov processes, each kept only when the data need it."""
    # every allowed term again (a misfit short end may have pushed some out), but Q:
    # a quantization's rise and a filter's bend would only trade against each other
    base_lin = tuple(k for k in lin if k != "Q")
    cands = []
    for order in (1, 2):
        s2 = Structure(base_lin, order, 0)
        th, c2, chi2b = _fit_structure(p, s2, np.array([math.log(0.25 * p.fs)]), 0)
        cands.append((chi2b, s2, th, c2))
    chi2b, s2, th, c2 = min(cands, key=lambda x: x[0])
    dof = max(p.t.size - int(np.sum(c2 > 0)) - 1, 1)
    if c2[s2.names().index("N")] > 0 and _test(chi2 - chi2b, chi2b, dof, 1):
        s, theta, c, chi2 = _stepwise(p, s2, th, keep=("N",))
    for _j in range(MAX_GM):
        s2 = Structure(tuple(k for k in lin if k in s.linear or k in ("B", "K", "R")), s.lp, s.ngm + 1)
        if p.t.size - (len(s2.linear) + s2.ngm + len(s2.nonlinear())) < 2:
            break
        th0 = np.concatenate((theta, [math.log(p.t[p.t.size // 2])]))
        th, c2, chi2b = _fit_structure(p, s2, th0, th0.size - 1)
        c2 = np.concatenate((c2[:-1], [c2[-1]]))
        dof = max(p.t.size - int(np.sum(c2 > 0)) - th.size, 1)
        if c2[-1] > 0 and _test(chi2 - chi2b, chi2b, dof, 2) and _gm_visible(p, s2, th, c2):
            s, theta, c, chi2 = _stepwise(p, s2, th, keep=("N",))
        else:
            break
    if p.sine_on:
        s, theta, c, chi2 = _try_sine(p, s, theta, c, chi2)
    return s, theta, c, chi2


def _try_sine(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """A sinusoid, kept when it lowers chi2 by the 95 % point of chi2(2) and is a fifth
    of the model somewhere."""
    if not s.sine and p.t.size - (len(s.linear) + s.ngm + len(s.nonlinear()) + 2) >= 2:
        s2 = replace(s, sine=1)
        # the robust weights of the model without it have set its hump aside: the
        # sinusoid is judged with weights of its own
        saved, mod = p.robust, columns(s, theta, p.m, p.fs) @ c
        p.robust = np.ones(p.t.size)
        p.set_reference(mod)
        th0 = _sine_start(p, s, theta, c, s2)
        th, c2, chi2b = _fit_structure(p, s2, th0, None)
        dof = max(p.t.size - int(np.sum(c2 > 0)) - th.size, 1)
        if c2[-1] > 0 and _test(chi2 - chi2b, chi2b, dof, 2) and _gm_visible(p, s2, th, c2, 0.2):
            return _stepwise(p, s2, th, keep=("N",))
        p.robust = saved
        p.set_reference(mod)
    return s, theta, c, chi2


def _sine_start(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, s2: Structure) -> np.ndarray:
    """Parameters to start a sinusoid from: its frequency put where the present model
    leaves the largest hump (ADEV peak at 0.371 / f0, and half and twice that), or on a
    grid of the measured taus, whichever fits best (a sinusoid's hump is an octave wide:
    a coarse grid alone misses it)."""
    r = p.y / (columns(s, theta, p.m, p.fs) @ c)
    peaks = [i for i in range(1, r.size - 1) if r[i] > 1.0 and r[i] >= r[i - 1] and r[i] >= r[i + 1]]
    lo, hi = _bounds(s2, p.t, p.fs)[-1]
    cands = [math.log(0.371 / (p.t[i] * k)) for i in peaks for k in (0.7, 1.0, 1.4)]
    cands += list(np.linspace(lo, hi, 17))
    best = (math.inf, None)
    for g in cands:
        if lo <= g <= hi:
            th = np.concatenate((theta, [g]))
            v = p.solve(s2, th)[1]
            if v < best[0]:
                best = (v, th)
    return best[1] if best[1] is not None else np.concatenate((theta, [0.5 * (lo + hi)]))


def _gm_visible(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, share: float = 0.5) -> bool:
    """A new Gauss-Markov process is kept only with white noise beside it and where
    it is at least half of the model somewhere (its hump shows): else it only
    stands in for the band limit or the white noise."""
    names = s.names()
    if "N" not in names or c[names.index("N")] <= 0:
        return False
    A = columns(s, theta, p.m, p.fs)
    part = A[:, -1] * c[-1]
    return bool(np.any(part >= share * (A @ c)))


def _upper(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, k: str) -> Optional[float]:
    """95 % upper bound of an absent IEEE term: unconstrained LS with it added."""
    s2 = replace(s, linear=tuple(x for x in LINEAR if x in s.linear or x == k))
    A = p.gls.white(columns(s2, theta, p.m, p.fs))
    names = s2.names()
    old = s.names()
    keep = [i for i, n in enumerate(names) if n == k or (n in old and c[old.index(n)] > 0)]
    X = A[:, keep]
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    inv = np.linalg.pinv((X / scale).T @ (X / scale))
    cc = inv @ ((X / scale).T @ p.yw) / scale
    cov = inv / np.outer(scale, scale)
    j = keep.index(names.index(k))
    return math.sqrt(max(float(cc[j]), 0.0) + Z95 * math.sqrt(max(float(cov[j, j]), 0.0)))


def _set_floor(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, dof: int) -> float:
    """The least model error (relative sd of AVAR, up to 2 MODEL_ERR) that brings
    chi2/dof to 1 at these parameters (set in p)."""
    A = columns(s, theta, p.m, p.fs)
    mod = A @ c

    def red(f: float) -> float:
        p.floor = f
        p.set_reference(mod)
        return float(np.sum((p.yw - p.gls.white(A) @ c) ** 2)) / dof

    if red(0.0) <= 1.0:
        return 0.0
    top = 2.0 * MODEL_ERR
    if red(top) >= 1.0:
        return top
    lo, hi = 0.0, top
    for _ in range(8):
        mid = 0.5 * (lo + hi)
        if red(mid) > 1.0:
            lo = mid
        else:
            hi = mid
    red(hi)
    return hi


def _covariance(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, Aw: np.ndarray, inflate: float
) -> tuple[np.ndarray, np.ndarray]:
    """sd of every c and every log fc / log T: the inverse of J'J, J the Jacobian of the
    whitened residuals (active c analytically, fc and T numerically), widened by ``inflate``."""
    act = np.flatnonzero(c > 0)
    J = [Aw[:, j] for j in act]
    for i in range(theta.size):
        h = 1e-4
        th = theta.copy()
        th[i] += h
        J.append((p.gls.white(columns(s, th, p.m, p.fs)) @ c - Aw @ c) / h)
    J = np.stack(J, axis=1) if J else np.zeros((p.t.size, 0))
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    cov = np.linalg.pinv((J / scale).T @ (J / scale)) / np.outer(scale, scale) * inflate
    sd_c = np.zeros(c.size)
    sd_c[act] = np.sqrt(np.maximum(np.diag(cov)[: act.size], 0.0))
    sd_th = np.sqrt(np.maximum(np.diag(cov)[act.size :], 0.0))
    return sd_c, sd_th


def _result(
    p: _Problem,
    s: Structure,
    theta: np.ndarray,
    tau: np.ndarray,
    avar: np.ndarray,
    used: np.ndarray,
    fitted: np.ndarray,
    idx: np.ndarray,
    notes: list[str],
) -> CurveFit:
    c, chi2, A = p.solve(s, theta)
    names = s.names()
    dof = max(p.t.size - int(np.sum(c > 0)) - theta.size, 1)
    floor = _set_floor(p, s, theta, c, dof)
    if floor > 0:
        c, chi2, A = p.solve(s, theta)
        notes.append(
            f"model error granted to the processes: {floor / 2 * 100:.2g} % of the deviation "
            f"(the least that brings chi2/dof to 1, at most {MODEL_ERR * 100:g} %)"
        )
    gm_alive = [j for j in range(s.ngm) if c[names.index(f"GM{j + 1}")] > 0]
    chi2_red = chi2 / dof
    inflate = max(1.0, chi2_red)
    if chi2_red > 2.0:
        notes.append(
            f"the model fits the curve only to chi2/dof = {chi2_red:.3g} (> 2): intervals are widened accordingly"
        )
    Aw = p.gls.white(A)
    sd_c, sd_th = _covariance(p, s, theta, c, Aw, inflate)
    fitted_model = to_model(s, theta, c)
    grid = np.exp(np.linspace(math.log(p.t[0]), math.log(p.t[-1]), 200))
    res = CurveFit(
        {},
        np.zeros(5),
        np.zeros((5, 5)),
        chi2_red,
        fitted,
        np.zeros(tau.size, np.int64),
        np.full(tau.size, np.nan),
        None,
        notes,
        fs=p.fs,
        fitted=fitted_model,
        structure=s,
    )
    comps = res.components(grid)
    total = sum(comps.values()) if comps else np.zeros(grid.size)
    terms: dict[str, Term] = {}
    for k in TERMS:
        if k in names and c[names.index(k)] > 0:
            j = names.index(k)
            terms[k] = _linear_term(k, c[j], sd_c[j], comps.get(k), total, grid)
        else:
            up = _upper(p, s, theta, c, k)
            why = (
                "left out of the fit"
                if up is None
                else f"not in the data (the model does without it; at most {up:.3g})"
            )
            terms[k] = Term(k, None, None, None, None, 0.0, 0.0 if up is None else up, why)
    i_th = 0
    if s.lp:
        fc, sd = math.exp(theta[0]), sd_th[0]
        lo, hi = fc * math.exp(-Z95 * sd), min(fc * math.exp(Z95 * sd), 0.5 * p.fs)
        rng = (float(p.t[0]), float(min(p.t[-1], 4.0 / (2 * math.pi * fc))))
        terms["LP"] = Term(
            "LP",
            fc,
            lo,
            hi,
            rng,
            fc,
            hi,
            f"the white noise N reaches the samples through a {'one' if s.lp == 1 else 'two'}"
            f"-pole low-pass of {fc:.3g} Hz: the curve bends under N's line below about "
            f"{1 / (2 * math.pi * fc):.3g} s",
            extra={"fc": fc, "fc_low": lo, "fc_high": hi, "order": s.lp},
        )
        i_th = 1
    for n_out, j in enumerate(gm_alive):
        name = f"GM{j + 1}"
        k = names.index(name)
        T, sdT = math.exp(theta[i_th + j]), sd_th[i_th + j]
        term = _linear_term(name, c[k], sd_c[k], comps.get(name), total, grid)
        term.name = f"GM{n_out + 1}"
        term.extra = {"tau_c": T, "tau_c_low": T * math.exp(-Z95 * sdT), "tau_c_high": T * math.exp(Z95 * sdT)}
        if T > p.t[-1]:
            term.note = (term.note + "; " if term.note else "") + (
                f"its correlation time {T:.3g} s is longer than the curve's last tau: over these taus it "
                f"acts as a rate random walk K = {math.sqrt(c[k]) * math.sqrt(2.0 / T):.3g}"
            )
        terms[term.name] = term
    if s.sine and c[names.index("SIN")] > 0:
        k = names.index("SIN")
        f0, sdf = math.exp(theta[-1]), sd_th[-1]
        term = _linear_term("SIN", c[k], sd_c[k], comps.get("SIN"), total, grid)
        term.extra = {"f0_hz": f0, "f0_low": f0 * math.exp(-Z95 * sdf), "f0_high": f0 * math.exp(Z95 * sdf)}
        term.note = (term.note + "; " if term.note else "") + (
            f"an oscillation of {f0:.3g} Hz (period {1 / f0:.3g} s), amplitude {math.sqrt(c[k]):.3g}"
        )
        terms["SIN"] = term
    res.terms = terms
    res.coef = np.array([c[names.index(k)] if k in names else 0.0 for k in TERMS])
    e = p.edf_of(p.alpha)
    res.alpha[idx], res.edf[idx] = p.alpha, e
    res.b_classic = b_classic(tau, avar, used, res.edf)
    res.slope = slope_reading(p.t, p.y, e)
    _compare(res, notes)
    res.unexplained = _unexplained(p, A @ c, e)
    off = p.robust > 1.0
    if off.any():
        notes.append(
            "points far off the model (more than 3 sd) counted as 3 sd: " + ", ".join(f"{v:.3g} s" for v in p.t[off])
        )
    notes.extend(r["text"] for r in res.unexplained)
    return res
