"""The problem of the whole-curve fit (fit.py): the catalogue's columns for a model
structure, the covariance of the octave estimates and the fit of one structure.

The model is linear in the squares c >= 0 and nonlinear in fc and the T_j:
variable projection (for given fc, T the c are the GLS non-negative least
squares; fc and T by scipy.optimize over their logarithms, started from a grid
over the measured tau range and bounded to it, so the search never leaves the
curve).

Weights: the generalized least squares of terms.py (each point chi-squared
with Greenhall's EDF for the local noise type, correlated between octaves),
iterated with the model as the reference (GMWM, Guerrier et al. 2013, weights
by the estimates' covariance the same way).  A real sensor is never exactly a
sum of catalogue processes, and a million samples make the short-tau points
so precise that any misfit there would decide everything: when chi2 on log
AVAR exceeds its 95 % point (a misfit beyond chance, ``misfits``), a model
error (relative, at most MODEL_ERR of the deviation) is added in quadrature to
the sd of the points where the model misfits (``set_floor``): each window of
five octaves whose chi2 is beyond chance (the 95 % point corrected for the
windows, Sidak) gives its points the least error that brings it to its
expectation (``local_floor``); a misfit that no window shows is granted on the
points whose window's chi2 exceeds its expectation, the least that brings
chi2/dof to 1.  The misfit of a real part sits in a tau region (lines and an
excess at long taus, a resonance at short ones): granted there, it neither
widens the intervals of terms read elsewhere (N on the short taus) nor hides a
term that lives elsewhere from the selection's tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from ..stats import dist
from .flicker import Flicker
from .lsq import _least_squares, _nnls
from .processes import AR1, FC_CEILING, LP, QN, RW, WN, Ramp, Sine
from .resonance import Resonance
from .simplex import nelder_mead
from .terms import local_alpha

GM_T_MIN = 10.0
"""A Gauss-Markov process's T is at least this many shortest taus (its ADEV hump,
at 1.89 T, four octaves into the curve): a faster one is white noise there."""
MODEL_ERR = 0.05
"""Largest relative model error granted (ADEV; 0.10 in AVAR)."""
LINEAR = ("Q", "N", "B", "K", "R")


@dataclass
class Structure:
    linear: tuple[str, ...] = LINEAR  # which IEEE 952 columns are free
    lp: int = 0  # 0: white N; 1, 2 or 4: N low-passed (order)
    ngm: int = 0
    sine: int = 0  # 1: a sinusoid (amplitude, frequency)
    res: int = 0  # 1: a resonance (sd; frequency and quality, theta before the sinusoid's)
    shape: str = "pole"  # the low-pass: "pole" (RC, Butterworth), "average" (box, Bartlett), "pole_mean" (averaged RC)

    def names(self) -> list[str]:
        gms = [f"GM{j + 1}" for j in range(self.ngm)]
        return list(self.linear) + gms + ["RES"] * self.res + ["SIN"] * self.sine

    def nonlinear(self) -> list[str]:
        gms = [f"T{j + 1}" for j in range(self.ngm)]
        return (["fc"] if self.lp else []) + gms + ["f_res", "q_res"] * self.res + ["f0"] * self.sine

    def flicker(self) -> str:
        """How the samples see the flicker (processes.Flicker.sampling): as points where
        the band limit is a pole read at instants; as means with no band limit (white
        noise holds the first octaves, the IEEE constant as ever) or an averaging one."""
        return "point" if self.lp and self.shape == "pole" else "mean"

    def res_at(self) -> int:
        """Index in theta of the resonance's log frequency (its log quality next)."""
        return (1 if self.lp else 0) + self.ngm


def columns(s: Structure, theta: np.ndarray, m: np.ndarray, fs: float) -> np.ndarray:
    """(points, columns) AVAR per unit coefficient, in the order of s.names()."""
    cols = []
    mb = m.tobytes()
    at = (fs, mb)
    for k in s.linear:
        if k == "N" and s.lp:
            cols.append(_column(("LP", s.lp, s.shape, float(theta[0])), at, m, fs))
        else:
            cols.append(_fixed(k, m, fs, s.flicker() if k == "B" else "", mb))
    i = 1 if s.lp else 0
    for j in range(s.ngm):
        cols.append(_column(("GM", float(theta[i + j])), at, m, fs))
    if s.res:
        i = s.res_at()
        cols.append(_column(("RES", float(theta[i]), float(theta[i + 1])), at, m, fs))
    if s.sine:
        cols.append(_column(("SIN", float(theta[-1])), at, m, fs))
    out = np.empty((m.size, len(cols)))
    for j, col in enumerate(cols):
        out[:, j] = col
    return out


_COLUMNS: dict[tuple, np.ndarray] = {}


def _column(what: tuple, at: tuple, m: np.ndarray, fs: float) -> np.ndarray:
    """The column of a process with parameters (``what``: its kind and log parameters), kept:
    the selection asks for the same band limit, time or resonance again under other weights,
    beside other terms or with another parameter changed (a grid, a refit of one parameter)."""
    key = what + at
    col = _COLUMNS.get(key)
    if col is None:
        kind = what[0]
        if kind == "LP":
            proc = LP(1.0, math.exp(what[3]), what[1], what[2])
        elif kind == "GM":
            proc = AR1(1.0, math.exp(what[1]))
        elif kind == "RES":
            proc = resonance(np.array(what[1:]), 0)
        else:
            proc = Sine(1.0, math.exp(what[1]))
        col = proc.avar(m, fs)
        col.setflags(write=False)
        if len(_COLUMNS) > COLUMNS_KEPT:
            _COLUMNS.clear()
        _COLUMNS[key] = col
    return col


COLUMNS_KEPT = 4096
"""Columns kept by _column (a fit asks for a few thousand, about a third of them again)."""


_FIXED: dict[tuple, np.ndarray] = {}


def _fixed(k: str, m: np.ndarray, fs: float, flicker: str, mb: Optional[bytes] = None) -> np.ndarray:
    """The column of an IEEE 952 term without parameters (the fit asks for it thousands of
    times on the same taus): computed once per curve; B's as the samples see it (``flicker``);
    ``mb`` m's bytes where the caller has them."""
    key = (k, flicker if k == "B" else "", fs, m.tobytes() if mb is None else mb)
    col = _FIXED.get(key)
    if col is None:
        proc = {"Q": QN(1.0), "N": WN(1.0), "K": RW(1.0), "R": Ramp(1.0)}.get(k) or Flicker(1.0, flicker)
        col = proc.avar(m, fs)
        col.setflags(write=False)
        if len(_FIXED) > 256:
            _FIXED.clear()
        _FIXED[key] = col
    return col


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
        floor: ArrayLike = 0.0,
        robust: Optional[np.ndarray] = None,
        power: float = 1.0,
    ) -> None:
        from .lsq import _cholesky
        from .terms import octave_correlation

        sd = ref * np.sqrt(2.0 / e)
        S = octave_correlation(t, alpha, kind, power) * (sd[:, None] * sd[None, :])
        diag = S.reshape(-1)[:: t.size + 1]  # a view: the variances
        diag += (floor * ref) ** 2
        self.sd = np.sqrt(diag)
        if robust is not None and (robust != 1.0).any():  # points far off the model: their variance raised
            S = S * np.sqrt(robust[:, None] * robust[None, :])
        self.S = S
        self.Li = np.linalg.inv(_cholesky(S))

    def white(self, v: np.ndarray) -> np.ndarray:
        return self.Li @ v


class _Problem:
    """The points of one curve and their covariance model."""

    def __init__(self, t: np.ndarray, y: np.ndarray, fs: float, edf_of, kind: str, floor: ArrayLike = 0.0) -> None:
        self.t, self.y, self.fs, self.m = t, y, fs, t * fs
        self.edf_of, self.kind = edf_of, kind
        self.floor = np.zeros(t.size) + floor  # the model error of each point (set_floor)
        self.robust = np.ones(t.size)
        self.robust_on = False
        self.sine_on = False
        self.power = 1.0  # the octave correlation's decay (terms.octave_correlation); K's inversion sets its own
        self._weights: dict[tuple, tuple] = {}
        self.set_reference(y)

    def set_reference(self, ref: np.ndarray) -> None:
        key = tuple(np.asarray(v, dtype=np.float64).tobytes() for v in (ref, self.floor, self.robust)) + (self.power,)
        w = self._weights.get(key)  # the selection sets weights it had before (a structure's, restored)
        if w is None:
            r = np.where(ref > 0, ref, self.y)
            alpha = local_alpha(self.t, r)
            e = self.edf_of(alpha)
            gls = _Gls(self.t, r, e, alpha, self.kind, self.floor, self.robust, self.power)
            w = (r, alpha, e, gls, gls.white(self.y))
            for v in (r, alpha, w[4]):
                v.setflags(write=False)
            if len(self._weights) > WEIGHTS_KEPT:
                self._weights.clear()
            self._weights[key] = w
        self.ref, self.alpha, self.e, self.gls, self.yw = w

    def kept(self) -> tuple[np.ndarray, np.ndarray]:
        """The weights' state (reference curve, robust variances), for restore: a trial that
        is not kept leaves the weights as it found them."""
        return self.ref.copy(), self.robust.copy()

    def restore(self, kept: tuple[np.ndarray, np.ndarray]) -> None:
        self.robust = kept[1]
        self.set_reference(kept[0])

    def solve(self, s: Structure, theta: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        A = columns(s, theta, self.m, self.fs)
        Aw = self.gls.white(A)
        c = _nnls(Aw, self.yw) if A.shape[1] else np.zeros(0)
        r = self.yw - Aw @ c
        return c, float((r * r).sum()), A


WEIGHTS_KEPT = 64
"""Weights kept by _Problem.set_reference (each a covariance and its inverse factor)."""


RES_TAUS = 5.0
"""A resonance's ADEV hump (a sinusoid's peak at 0.371 / f0) lies within this many shortest taus
(f0 at least 0.074 fs), where the band limit lives: a slower oscillation is the sinusoid's (whose
range ends at 0.093 fs)."""
RES_Q = (5.0, 200.0)
"""The resonance's quality factor Q = pi f0 T: a broader peak is a Gauss-Markov's or the band
limit's shape, a narrower one a sinusoid to the octave taus."""


def resonance(theta: np.ndarray, i: int, sigma: float = 1.0) -> Resonance:
    """The resonance of theta[i] (log f0) and theta[i + 1] (log Q)."""
    f0 = math.exp(theta[i])
    return Resonance(sigma, f0, math.exp(theta[i + 1]) / (math.pi * f0))


def bounds(s: Structure, t: np.ndarray, fs: float) -> list[tuple[float, float]]:
    out = []
    if s.lp:
        out.append((math.log(max(0.5 / (2 * math.pi * t[-1]), fs / 5000.0)), math.log(FC_CEILING[s.shape] * fs)))
    for _ in range(s.ngm):  # a faster GM is white noise to these taus: N's, not a GM's
        out.append((math.log(t[0] * GM_T_MIN), math.log(t[-1] * 4.0)))
    if s.res:  # a mode whose hump (a sinusoid's ADEV peak at 0.371 / f0) is on the first octaves
        out.append((math.log(0.371 / (RES_TAUS * t[0])), math.log(0.49 * fs)))
        out.append((math.log(RES_Q[0]), math.log(RES_Q[1])))
    if s.sine:  # its ADEV peaks at 0.371 / f0: inside the measured taus
        out.append((math.log(0.371 * 4 / t[-1]), math.log(min(0.371 / (4 * t[0]), 0.45 * fs))))
    return out


def _optimize(p: _Problem, s: Structure, theta0: np.ndarray, new: Optional[int]) -> tuple[np.ndarray, float]:
    """Nonlinear parameters minimizing chi2: a grid on the new one (others held),
    then a bounded joint polish."""
    bnds = bounds(s, p.t, p.fs)
    if not bnds:
        return theta0, p.solve(s, theta0)[1]
    theta = np.array(theta0, dtype=np.float64)
    lims = (np.array([b[0] for b in bnds]), np.array([b[1] for b in bnds]))
    memo: dict[bytes, float] = {}

    def f(th: np.ndarray) -> float:
        th = _clip(s, th, lims)
        key = th.tobytes()
        if key not in memo:  # the start and the best point are asked for again
            memo[key] = p.solve(s, th)[1]
        return memo[key]

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
            options={"xatol": NM_XATOL},
        )
        theta = np.array([r.x]) if r.fun <= f(theta) else theta
    else:
        x, fun = nelder_mead(f, theta, NM_XATOL, NM_FATOL, NM_MAXFEV * theta.size)
        if fun <= f(theta):
            theta = np.asarray(x)
    theta = _clip(s, theta, lims)
    return theta, f(theta)


NM_XATOL, NM_FATOL, NM_MAXFEV = 1e-2, 1e-3, 20
"""Nelder-Mead's tolerances: 1 % in fc and T (far inside their intervals) and a
thousandth of chi2 (the selection's tests act on differences of several units); at most
NM_MAXFEV evaluations per parameter (every search starts from a grid's best point or a
fitted structure's: on 36 real channels 20 and 30 give the same N and structures)."""
GM_LP_FACTOR = 10.0
"""With a band limit, a GM's T is at least this many of the filter's time constants
1 / (2 pi fc): a faster GM only reshapes the filter's bend."""


def _clip(s: Structure, th: np.ndarray, lims: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    th = np.minimum(np.maximum(th, lims[0]), lims[1])  # numpy.clip's own rule, without its wrapper
    if s.lp and s.ngm:
        th[1 : 1 + s.ngm] = np.maximum(th[1 : 1 + s.ngm], math.log(GM_LP_FACTOR / (2 * math.pi)) - th[0])
    return th


def fit_structure(
    p: _Problem, s: Structure, theta0: np.ndarray, new: Optional[int], rounds: int = 2
) -> tuple[np.ndarray, np.ndarray, float]:
    """(theta, c, chi2) of a structure, the weights iterated with its model."""
    theta = theta0
    for _ in range(rounds):
        theta, _ = _optimize(p, s, theta, new)
        new = None
        settle(p, s, theta)
    c, chi2, _ = p.solve(s, theta)
    return theta, c, chi2


def settle(p: _Problem, s: Structure, theta: np.ndarray) -> None:
    """The weights (reference curve, robust variances) set to the model of s at theta."""
    c, _, A = p.solve(s, theta)
    mod = A @ c
    p.set_reference(mod)
    if p.robust_on:
        z = (p.y - mod) / p.gls.sd
        far = np.abs(z) > ROBUST_Z
        # a model that leaves most points far off is wrong, not the points: with all of them
        # capped it would be judged only by the few it fits (a runaway to any structure)
        p.robust = np.maximum(1.0, (z / ROBUST_Z) ** 2) if np.mean(far) <= ROBUST_SHARE else np.ones(z.size)
        p.set_reference(mod)


ROBUST_SHARE = 1.0 / 3.0
"""At most this share of the points may be counted as far off (ROBUST_Z) at once."""
ROBUST_Z = 3.0
"""A point more than this many sd off the model gets its variance raised so that it
counts as ROBUST_Z sd (capped influence: a resonance or a hump the catalogue lacks
cannot pull the other terms)."""


FIT_LEVEL = 0.95
"""A model misfits when its chi2 exceeds this point of chi2 with its degrees of freedom:
below it, chi2/dof above 1 is chance, and the points' own variances (known from their
EDF) stand; the intervals then depend on the record's length and the model only."""


def residual_dof(p: _Problem, c: np.ndarray, theta: np.ndarray) -> int:
    """The degrees of freedom a fit leaves: the points less the terms it keeps (c > 0) and its
    nonlinear parameters, at least 1."""
    return max(p.t.size - int(np.sum(c > 0)) - theta.size, 1)


def misfits(chi2: float, dof: int) -> bool:
    """chi2 beyond what chance gives a model that is the truth (FIT_LEVEL point)."""
    return chi2 > float(dist.chi2_ppf(FIT_LEVEL, max(dof, 1)))


def _log_parts(p: _Problem, mod: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(residuals of log AVAR less their chance mean, their chance variance, their correlation):
    Bartlett and Kendall 1946, log of chi2_nu / nu has mean psi(nu / 2) - log(nu / 2) and
    variance psi'(nu / 2); correlated between octaves as the estimates are."""
    from scipy import special

    from .terms import octave_correlation

    half = p.e / 2.0
    bias = special.digamma(half) - np.log(half)
    u = np.log(p.y) - np.log(np.maximum(mod, 1e-300)) - bias
    return u, special.polygamma(1, half), octave_correlation(p.t, p.alpha, p.kind)


def _quad(u: np.ndarray, var: np.ndarray, C: np.ndarray) -> float:
    from .lsq import _cholesky

    sd = np.sqrt(var)
    r = np.linalg.solve(_cholesky(C * (sd[:, None] * sd[None, :])), u)
    return float(r @ r)


def log_chi2(p: _Problem, mod: np.ndarray) -> float:
    """chi2 of the model ``mod`` on log AVAR (_log_parts), with the model error and the
    capped influence of points far off as in p's weights.  Where nu is large it is the chi2
    of the weights; on the last octaves (nu of 1 to 5, estimates skewed far from the normal)
    it does not charge a point 5 times its mean 4 times what the chi-squared distribution
    gives it."""
    u, v, C = _log_parts(p, mod)
    return _quad(u, (v + p.floor**2) * p.robust, C)


LOCAL_OCTAVES = 2
"""The model error is judged on windows of this many octaves either side of each point
(five octaves: a line's or a resonance's ADEV hump and its flanks; on the six real units
windows of three octaves left the accelerometers' N moving when averaged down by 10 on 7
more channels)."""


def local_floor(p: _Problem, mod: np.ndarray, dof: int) -> np.ndarray:
    """The model error each point is granted by its own region of the curve: for each window
    of LOCAL_OCTAVES either side of a point, the least relative error (AVAR, up to 2
    MODEL_ERR, the same on the window's points) that brings the window's chi2 on log AVAR
    (its octaves correlated) to its expectation (its points times dof / points: the fitted
    parameters' share), granted only where that chi2 is beyond chance at the FIT_LEVEL
    point corrected for the number of windows (Sidak: on a curve the model fits, no window
    is granted anything but by the chance FIT_LEVEL allows the whole curve); a point in
    several such windows keeps the largest error, a point in none has 0."""
    u, v, C = _log_parts(p, mod)
    n = p.t.size
    v = v * p.robust
    level = FIT_LEVEL ** (1.0 / n)
    out = np.zeros(n)
    for w in _windows(n):
        expect = (w.stop - w.start) * max(dof, 1) / n
        if _quad(u[w], v[w], C[w, w]) > float(dist.chi2_ppf(level, expect)):
            out[w] = np.maximum(out[w], _least_error(u[w], v[w], C[w, w], expect))
    return out


def _windows(n: int) -> list[slice]:
    return [slice(max(i - LOCAL_OCTAVES, 0), min(i + LOCAL_OCTAVES + 1, n)) for i in range(n)]


def _least_error(u: np.ndarray, v: np.ndarray, C: np.ndarray, expect: float) -> float:
    """The least relative error (up to 2 MODEL_ERR) that brings chi2 on log AVAR to ``expect``."""
    top = 2.0 * MODEL_ERR
    if _quad(u, v + top**2, C) >= expect:
        return top
    lo, hi = 0.0, top
    for _ in range(BISECT):
        mid = 0.5 * (lo + hi)
        if _quad(u, v + mid**2, C) > expect:
            lo = mid
        else:
            hi = mid
    return hi


BISECT = 8
"""Bisection steps of a model error (to 2 MODEL_ERR / 256: 0.04 % of AVAR)."""


def set_floor(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, dof: int) -> np.ndarray:
    """The model error of each point (relative sd of AVAR, up to 2 MODEL_ERR; set in p): none
    when the model misfits no more than chance allows (``misfits``, on log AVAR:
    ``log_chi2``); else first each region's own (``local_floor``: a misfit is granted where
    it lives, so a line or an excess at long taus neither widens N's interval nor hides a
    short-tau term), then, if the curve still misfits beyond chance (a misfit spread thinly
    over it), the least error on every point beside it that brings chi2/dof to 1."""
    A = columns(s, theta, p.m, p.fs)
    mod = A @ c
    none = np.zeros(p.t.size)

    def red(f: np.ndarray) -> float:
        p.floor = f
        p.set_reference(mod)
        return float(np.sum((p.yw - p.gls.white(A) @ c) ** 2)) / dof

    red(none)  # the weights of this model with no model error: chance's own variances
    if not misfits(log_chi2(p, mod), dof):  # judged on log AVAR: the last octaves' skew is chance
        return none
    local = local_floor(p, mod, dof)
    red(local)
    top = 2.0 * MODEL_ERR
    # where a region's misfit is beyond the largest error granted, that region's model is
    # wrong there, not the rest of the curve: the rest is judged by itself
    rest = local < top
    if not rest.any() or not _misfits_on(p, mod, rest, dof):
        return local
    # a misfit no window shows beyond chance: granted on the points whose window's chi2
    # exceeds its expectation (all of them if none does), the least that brings chi2/dof to 1
    spread = _over(p, mod, dof) & rest
    spread = spread if spread.any() else rest

    def with_(g: float) -> np.ndarray:
        return np.where(spread, np.maximum(local, g), local)

    lo, hi = 0.0, top
    if red(with_(top)) >= 1.0:
        lo = top
    for _ in range(BISECT if lo < top else 0):
        mid = 0.5 * (lo + hi)
        if red(with_(mid)) > 1.0:
            lo = mid
        else:
            hi = mid
    red(with_(hi))
    return with_(hi)


def _over(p: _Problem, mod: np.ndarray, dof: int) -> np.ndarray:
    """The points whose window's chi2 on log AVAR (p's model error in it) exceeds its expectation."""
    u, v, C = _log_parts(p, mod)
    v = (v + p.floor**2) * p.robust
    n = p.t.size
    out = np.zeros(n, dtype=bool)
    for i, w in enumerate(_windows(n)):
        out[i] = _quad(u[w], v[w], C[w, w]) > (w.stop - w.start) * max(dof, 1) / n
    return out


def _misfits_on(p: _Problem, mod: np.ndarray, keep: np.ndarray, dof: int) -> bool:
    """``misfits`` of the points ``keep`` alone (their share of dof), on log AVAR."""
    u, v, C = _log_parts(p, mod)
    chi2 = _quad(u[keep], ((v + p.floor**2) * p.robust)[keep], C[np.ix_(keep, keep)])
    return misfits(chi2, max(int(round(dof * keep.sum() / p.t.size)), 1))


def covariance(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, Aw: np.ndarray, inflate: float
) -> tuple[np.ndarray, np.ndarray]:
    """sd of every c and every log fc / log T: the inverse of J'J, J the Jacobian of the
    whitened residuals (active c analytically, fc and T numerically), widened by ``inflate``."""
    act = np.flatnonzero(c > 0)
    J = [Aw[:, j] for j in act]
    free = free_parameters(p, s, theta)
    for i in range(theta.size):
        if not free[i]:  # at its search's bound: held there, not traded (its sd 0)
            J.append(np.zeros(p.t.size))
            continue
        h = 1e-4
        th = theta.copy()
        th[i] += h
        J.append((p.gls.white(columns(s, th, p.m, p.fs)) @ c - Aw @ c) / h)
    J = np.stack(J, axis=1) if J else np.zeros((p.t.size, 0))
    cov = _least_squares(J)[1] * inflate
    sd_c = np.zeros(c.size)
    sd_c[act] = np.sqrt(np.maximum(np.diag(cov)[: act.size], 0.0))
    sd_th = np.sqrt(np.maximum(np.diag(cov)[act.size :], 0.0))
    return sd_c, sd_th


def free_parameters(p: _Problem, s: Structure, theta: np.ndarray) -> np.ndarray:
    """The nonlinear parameters the covariance counts free: all but a resonance's frequency or
    quality at its search's bound (curve.bounds), where the constraint holds it (the curve
    would take a broader or narrower peak than the catalogue's resonance; on real
    accelerometers its quality sat at 5 or 200).  Counted free, that unpinned parameter's trade
    with the band limit and N widened N's interval from 2-5 % to 15-32 %.  The band limit's
    cutoff at its ceiling and a GM's time at its bound stay free: their forms' trade with N
    is what _selection_variance and the profile bounds carry."""
    free = np.ones(theta.size, dtype=bool)
    if s.res:
        i = s.res_at()
        for j, (lo, hi) in zip((i, i + 1), bounds(s, p.t, p.fs)[i : i + 2]):
            free[j] = lo + PIN_MARGIN < theta[j] < hi - PIN_MARGIN
    return free


PIN_MARGIN = 0.01
"""A log parameter this close to its search's bound is at the bound (1 %)."""
