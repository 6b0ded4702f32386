"""The whole-curve fit: a sum of catalogue processes fitted to every octave
point of an Allan variance curve, weighted by the estimates' covariance.

The model (processes.py; u the channel's rate unit, m = tau fs):

    AVAR(m) = Q^2 q(m) + N^2 w(m; fc) + B^2 b + K^2 k(m) + R^2 r(m) + sum_j s_j^2 g(m; T_j) [+ A^2 s(m; f0)]

each column the exact discrete-time AVAR of its process at unit size (w the
white noise, or, with a band limit, the low-passed white noise of cutoff fc,
order 1 or 2, normalized to unit LOW-FREQUENCY density; g a Gauss-Markov
process of correlation time T_j; s a sinusoid of frequency f0).  The problem
(columns, weights by the estimates' covariance with a model error where the
catalogue falls short, the fit of one structure) is curve.py's; which
processes the curve needs, select.py's.  Here: the result.  Intervals (95 %):
from the covariance of all parameters (Jacobian of the whitened residuals),
widened by chi2/dof only when the model misfits beyond chance (curve.misfits),
chi-squared shaped for the c (never below 0), log-normal for fc, T and f0;
an absent IEEE 952 term gets a 95 % upper bound; the IEEE 952 slope reading
stays beside the fit (reading.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

from ..stats.dist import Z95
from .blas import one_thread
from .curve import (
    LINEAR,
    MODEL_ERR,
    Structure,
    _Problem,
    columns,
    covariance,
    free_parameters,
    residual_dof,
    set_floor,
)
from .identify import runs
from .kinterval import k_interval
from .lsq import _least_squares
from .processes import FC_CEILING, LP, WN, Model
from .reading import _compare, _linear_term, _unexplained, slope_reading, to_model
from .select import LP_BEND, LP_FORMS, choose, shown
from .terms import TERMS, EdfFn, FitResult, Term, b_classic, fit_points, points_edf


@dataclass
class CurveFit(FitResult):
    """FitResult of the whole-curve fit: ``terms`` holds Q N B K R and, when
    fitted, LP (fc, order) and GM1, GM2 (tau_c); ``fitted`` the catalogue
    model; ``slope`` the IEEE 952 slope reading beside it."""

    fs: float = 1.0
    fitted: Model = field(default_factory=Model)
    structure: Structure = field(default_factory=Structure)
    slope: dict = field(default_factory=dict)
    model_error: float = 0.0
    """The largest relative sd of AVAR granted to a point as model error (curve.set_floor), 0
    when the model fits within chance; with ``widened``, the factor on the covariance beyond it."""
    model_errors: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The model error granted to each point of the curve (0 where the model fits within chance
    or the point is not fitted): the tau regions where the model misfits."""
    widened: float = 1.0

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


@one_thread  # its matrices are tens of points across: BLAS threads only wait (blas.py)
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
    used, idx, fitted = fit_points(tau, avar, mask)
    if fs is None:
        fs = 1.0 / float(tau[idx].min()) if idx.size else 1.0
    if idx.size < 2:
        terms = {k: Term(k, None, None, None, None, 0.0, math.inf, "no data") for k in TERMS}
        nothing = ["fewer than 2 usable points: nothing to fit"]
        return CurveFit(
            terms,
            np.zeros(5),
            np.zeros((5, 5)),
            math.nan,
            fitted,
            *_blank(tau),
            None,
            nothing,
            fs=fs,
        )
    edf_of = points_edf(edf_fn, idx, tau.size)
    kind = "overlapping" if overlapping else "nonoverlapping"
    lin = tuple(k for k in LINEAR if k in allowed)
    p, s, theta = choose(tau[idx], avar[idx], fs, edf_of, kind, lin, extended)
    res = _result(p, s, theta, fitted, tau.size, lin)
    e = p.edf_of(p.alpha)
    res.alpha[idx], res.edf[idx] = p.alpha, e
    errors = np.zeros(tau.size)
    errors[idx] = res.model_errors
    res.model_errors = errors
    res.b_classic = b_classic(tau, avar, used, res.edf)
    return res


def _blank(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(tau.size, np.int64), np.full(tau.size, np.nan)


def _upper(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, k: str) -> Optional[float]:
    """95 % upper bound of an absent IEEE term: unconstrained LS with it added."""
    s2 = replace(s, linear=tuple(x for x in LINEAR if x in s.linear or x == k))
    A = p.gls.white(columns(s2, theta, p.m, p.fs))
    names = s2.names()
    old = s.names()
    keep = [i for i, n in enumerate(names) if n == k or (n in old and c[old.index(n)] > 0)]
    cc, cov = _least_squares(A[:, keep], p.yw)
    j = keep.index(names.index(k))
    return math.sqrt(max(float(cc[j]), 0.0) + Z95 * math.sqrt(max(float(cov[j, j]), 0.0)))


def _result(
    p: _Problem, s: Structure, theta: np.ndarray, fitted: np.ndarray, size: int, lin: tuple[str, ...] = LINEAR
) -> CurveFit:
    """The fit of structure s read as terms, intervals, notes (``size`` input points)."""
    from .curve import log_chi2, misfits

    c, chi2, A = p.solve(s, theta)
    dof = residual_dof(p, c, theta)
    notes: list[str] = []
    floor = set_floor(p, s, theta, c, dof)
    if floor.any():
        c, chi2, A = p.solve(s, theta)
        notes.append(_error_note(p.t, floor))
    chi2_red = chi2 / dof
    # chi2/dof above 1 by chance (judged on log AVAR too: curve.log_chi2): no widening
    inflate = max(1.0, chi2_red) if misfits(chi2, dof) and misfits(log_chi2(p, A @ c), dof) else 1.0
    if chi2_red > 2.0 and inflate > 1.0:
        notes.append(
            f"the model fits the curve only to chi2/dof = {chi2_red:.3g} (> 2): intervals are widened accordingly"
        )
    sd_c, sd_th = covariance(p, s, theta, c, p.gls.white(A), inflate)
    sel = _selection_variance(p, s, theta, c, lin, inflate)
    sd_c = np.sqrt(sd_c**2 + sel)
    res = CurveFit(
        {},
        np.zeros(5),
        np.zeros((5, 5)),
        chi2_red,
        fitted,
        *_blank(np.zeros(size)),
        None,
        notes,
        fs=p.fs,
        fitted=to_model(s, theta, c),
        structure=s,
        model_error=float(floor.max()),
        model_errors=floor,
        widened=inflate,
    )
    grid = np.exp(np.linspace(math.log(p.t[0]), math.log(p.t[-1]), 200))
    comps = res.components(grid)
    total = sum(comps.values()) if comps else np.zeros(grid.size)

    def term(name: str) -> Term:
        k = s.names().index(name)
        # K's coefficient may sit under 1.96 sd while the curve shows the walk plainly
        # (select.shown): then its chi-squared shaped interval, not a bound
        rise = name == "K" and 0 < c[k] < Z95 * sd_c[k] and shown(p, s, theta, "K")
        return _linear_term(name, c[k], sd_c[k], comps.get(name), total, grid, shown=rise)

    res.terms = _ieee_terms(p, s, theta, c, term)
    if "K" in lin:
        j = s.names().index("K") if "K" in s.names() else -1
        alts = _k_alternatives(p, s, theta, c, lin)
        _k_interval(p, s, theta, res.terms["K"], (sel[j], c[j]) if j >= 0 else (0.0, 0.0), alts)
        if res.terms["K"].value is None:
            _gm_as_walk(p, s, theta, c, (sd_c, sd_th), res.terms["K"])
    res.terms.update(_nonlinear_terms(p, s, theta, c, sd_th, term))
    names = s.names()
    res.coef = np.array([c[names.index(k)] if k in names else 0.0 for k in TERMS])
    res.slope = slope_reading(p.t, p.y, p.edf_of(p.alpha))
    _compare(res, notes)
    # a point's allowance is the model error granted to it (two sd of the deviation, as TOL is
    # twice the model error of one for every point), at least the MODEL_ERR any point may be
    # granted: a region the fit holds to its chance variances is not excused by another's error
    res.unexplained = _unexplained(p, A @ c, p.edf_of(p.alpha), tol=np.maximum(floor, MODEL_ERR))
    off = p.robust > 1.0
    if off.any():
        notes.append(
            "points far off the model (more than 3 sd) counted as 3 sd: " + ", ".join(f"{v:.3g} s" for v in p.t[off])
        )
    notes.extend(r["text"] for r in res.unexplained)
    return res


def _error_note(t: np.ndarray, floor: np.ndarray) -> str:
    """The model error granted, by the tau regions that needed it."""
    parts = []
    for i, j in runs(floor > 0):
        top = float(floor[i : j + 1].max())
        parts.append(f"up to {top / 2 * 100:.2g} % at {t[i]:.3g}" + (f"-{t[j]:.3g} s" if j > i else " s"))
    return (
        "model error granted to the processes where they misfit beyond chance (of the deviation): "
        + ", ".join(parts)
        + f" (the least that brings chi2/dof to 1 there, at most {MODEL_ERR * 100:g} %)"
    )


def _selection_variance(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, lin: tuple[str, ...], red: float
) -> np.ndarray:
    """The variance the choice of structure adds to each coefficient: the structures one
    IEEE 952 term away (each term dropped or added; Q not beside a band limit), for a band
    limit white N and the catalogue's other band-limit forms (their cutoffs refitted), and
    without its last Gauss-Markov process, weighted by their Akaike weights (QAIC:
    chi2 / red + 2 parameters), sum_i w_i (c_i - c_mean)^2 (Burnham and Anderson's
    unconditional variance, the part beyond the chosen model's own), over the structures
    that hold the term.  The band limit's form and a GM trade with N by a few per cent
    on a real part (its bend's tail reaches the taus N is read on): the interval says so."""
    names = s.names()
    alts = [(s, theta)]
    for k in lin:
        if k == "Q" and s.lp:
            continue
        present = k in s.linear and c[names.index(k)] > 0
        lin2 = tuple(x for x in LINEAR if (x in s.linear and x != k) or (x == k and not present))
        alts.append((replace(s, linear=lin2), theta))
    if s.lp:
        alts.append((replace(s, lp=0), theta[1:]))
        for shape, order in LP_FORMS:
            if (shape, order) != (s.shape, s.lp):
                s2 = replace(s, lp=order, shape=shape)
                alts.append((s2, _refit(p, s2, theta)))
    if s.res:
        s2, th2 = replace(s, res=0), np.delete(theta, [s.res_at(), s.res_at() + 1])
        alts.append((s2, _refit(p, s2, th2) if s.lp else th2))  # the band limit it trades with, refitted
        alts.extend(_res_range(p, s, theta))
    if s.ngm:  # the last GM (the newest: the one the selection judged last)
        i = (1 if s.lp else 0) + s.ngm - 1
        alts.append((replace(s, ngm=s.ngm - 1), np.delete(theta, i)))
    aic, coefs = [], []
    for s2, th2 in alts:
        c2, chi2, _ = p.solve(s2, th2)
        aic.append(chi2 / red + 2.0 * (np.sum(c2 > 0) + th2.size))
        n2 = s2.names()
        coefs.append([c2[n2.index(k)] if k in n2 else 0.0 for k in names])
    w = np.exp(-0.5 * (np.array(aic) - min(aic)))
    cs = np.array(coefs)
    out = np.zeros(len(names))
    for j in range(len(names)):  # given the term present: whether it is, the selection test said
        wj = np.where(cs[:, j] > 0, w, 0.0)
        if wj.sum() > 0:
            wj = wj / wj.sum()
            out[j] = wj @ (cs[:, j] - wj @ cs[:, j]) ** 2
    return out


FORM_FC = 2.5


def _res_range(p: _Problem, s: Structure, theta: np.ndarray) -> list[tuple[Structure, np.ndarray]]:
    """A resonance's frequency or quality held at its search's bound (curve.free_parameters): the same
    structure with it across its range (RES_STEPS values), the resonance's other parameter
    and the band limit's cutoff it trades with refitted, for _selection_variance: what the
    curve does not pin enters N's interval by what the curve allows (Akaike weights), not
    by the linear trade of a parameter the curve cannot see (on the real accelerometers N
    moves by about 1 % across the quality's range, where that trade gave 15-32 %)."""
    from scipy import optimize

    from .curve import bounds

    lims, out = bounds(s, p.t, p.fs), []
    i = s.res_at()
    for j in np.flatnonzero(~free_parameters(p, s, theta)):
        others = [k for k in ((0,) if s.lp else ()) + (i, i + 1) if k != j]
        for v in np.linspace(*lims[j], RES_STEPS):
            th = theta.copy()
            th[j] = v
            r = optimize.minimize(
                _chi2_at, theta[others], args=(p, s, th, others), bounds=[lims[k] for k in others], method="L-BFGS-B"
            )
            th[others] = r.x
            out.append((s, th))
    return out


def _chi2_at(x: np.ndarray, p: _Problem, s: Structure, th: np.ndarray, idx: list) -> float:
    """chi2 of s with th's parameters idx set to x (th changed in place)."""
    th[idx] = x
    return p.solve(s, th)[1]


RES_STEPS = 4
"""Values across a resonance parameter's range for its share of the selection variance (the
quality's search grid: select._res_grid)."""


def _refit(p: _Problem, s: Structure, theta: np.ndarray) -> np.ndarray:
    """The cutoff of the band limit of s refitted under p's weights, the GMs' T held
    (p left as it is): a bounded scalar search over log fc within a factor FORM_FC of the
    chosen form's (the forms' cutoffs on one curve differ by less: 26-44 Hz on a real part)."""
    from scipy import optimize

    from .curve import bounds

    lo, hi = bounds(s, p.t, p.fs)[0]
    mid = min(max(theta[0], lo), hi)  # a cutoff above fs / 2 (averaged samples) is beyond a point form's
    lo, hi = max(lo, mid - math.log(FORM_FC)), min(hi, mid + math.log(FORM_FC))
    th = np.array(theta, dtype=np.float64)

    def f(x: float) -> float:
        th[0] = x
        return p.solve(s, th)[1]

    r = optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-2})
    th[0] = r.x
    return th


def _ieee_terms(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, term) -> dict[str, Term]:
    """Q N B K R: each fitted one with its interval, each absent one with its upper bound."""
    names = s.names()
    out: dict[str, Term] = {}
    for k in TERMS:
        if k in names and c[names.index(k)] > 0:
            out[k] = term(k)
        else:
            up = _upper(p, s, theta, c, k)
            why = (
                "left out of the fit"
                if up is None
                else f"not in the data (the model does without it; at most {up:.3g})"
            )
            out[k] = Term(k, None, None, None, None, 0.0, 0.0 if up is None else up, why)
    return out


def _k_interval(p: _Problem, s: Structure, theta: np.ndarray, t: Term, fitted: tuple[float, float], alts: list) -> None:
    """K's 95 % interval, or its bound, widened to the test inversion's where that reaches
    further (kinterval.k_interval: each K judged under the weights of its own model, the
    structure's choice in the variance, relative): the interval from the fitted model's
    covariance is as narrow as the fit is low at the curve's end; where a GM or flicker stands
    beside K, the alternatives' spread may reach further in it.  ``fitted``: the choice of
    structure's variance of K^2 and K^2 itself.  ``alts``: structures (and their parameters)
    the curve cannot tell from s where K is read (_k_alternatives), whose inversions are
    joined to s's."""
    sel, c = fitted
    extra = sel / c**2 if c > 0 else 0.0
    lo, hi = k_interval(p, s, theta, extra, c)
    for s2, th2 in alts:
        lo_b, hi_b = k_interval(p, s2, th2, extra, c)
        if hi_b > 0:
            lo, hi = (min(lo, lo_b), max(hi, hi_b)) if hi > 0 else (lo_b, hi_b)
    if t.value is None:
        _raise_bound(t, hi)
        return
    if hi > 0:
        t.low, t.high = min(lo, t.low), max(hi, t.high)
        t.upper = t.high


def _raise_bound(t: Term, top: float) -> None:
    """An absent term's bound raised to ``top`` where that is higher, its note saying so."""
    if top > t.upper:
        t.note = t.note.replace(f"at most {t.upper:.3g}", f"at most {top:.3g}")
        t.upper = top


def _k_alternatives(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, lin: tuple[str, ...]) -> list:
    """The structures K's interval is also judged under.  Flicker beside K where B is allowed
    and left out: near the crossing of white noise and the walk a sensor's own flicker (or a
    low-frequency excess like it) and K's line trade, and where the selection drops B the walk
    takes that excess (K 8-11 % high inside +-8 % on real gyros with a walk added).  Without
    the Gauss-Markov processes that stand in for part of the walk beside K (_walk_gms): their
    rise is the walk's as much as theirs (a walk of 0.1 beside a GM on textbook white noise
    read K = 0.05 inside 0.036-0.084)."""
    names, out = s.names(), []
    if "B" in lin and ("B" not in names or c[names.index("B")] <= 0):
        out.append((replace(s, linear=tuple(x for x in LINEAR if x in s.linear or x == "B")), theta))
    if "K" in names and c[names.index("K")] > 0:
        js = [j for j, _, _ in _walk_gms(p, s, theta, c, 4.0)]
        if js:
            i0 = 1 if s.lp else 0
            out.append((replace(s, ngm=s.ngm - len(js)), np.delete(theta, [i0 + j for j in js])))
    return out


def _walk_gms(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, under: float) -> list:
    """(index, T, K of its walk line) of each Gauss-Markov process of s that rises as a walk
    (IEEE Std 952-1997 annex C: under T a GM of variance s^2 is a walk of K = s sqrt(2 / T))
    whose line meets white noise's at T / ``under`` or earlier, the model rising from T / 2
    to the curve's end (no fall of the GM seen)."""
    names = s.names()
    i0 = 1 if s.lp else 0
    n2 = c[names.index("N")] if "N" in names else 0.0
    model = columns(s, theta, p.m, p.fs) @ c
    out = []
    for j in range(s.ngm):
        k = names.index(f"GM{j + 1}")
        if c[k] <= 0:
            continue
        T = math.exp(theta[i0 + j])
        k_eq = math.sqrt(2.0 * c[k] / T)
        if math.sqrt(3.0 * n2) / k_eq <= T / under and not np.any(np.diff(model[p.t >= T / 2.0]) < 0):
            out.append((j, T, k_eq))
    return out


def _gm_as_walk(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, sd: tuple[np.ndarray, np.ndarray], t: Term
) -> None:
    """An absent K read from the walk a Gauss-Markov process of s stands for (``sd``: the sd of
    c and of theta).  Under its correlation time T a GM of variance s^2 rises as a rate random
    walk of K = s sqrt(2 / T) (IEEE Std 952-1997 annex C).  Where a ramp carries the rise on
    past T, the model rising to the curve's end (no fall of the GM seen), the two are a walk's
    realization with a trend of its own, low at mid taus and high at the end: walks of K = 0.1
    and 0.3 added to a real gyro were read so, K absent "at most" 0.8 and 0.9 of the truth.
    Where the GM's walk line meets white noise's two octaves or more under T / 2, K is read
    as that walk, its interval the GM's variance and T at their 95 % ends; one octave under,
    K's bound reaches it (read there, a GM of T = 120 s and a ramp on textbook white noise
    gave a K of their own)."""
    names = s.names()
    if "R" not in names or c[names.index("R")] <= 0:
        return
    i0 = 1 if s.lp else 0
    n = math.sqrt(c[names.index("N")]) if "N" in names else 0.0
    alive = [j for j in range(s.ngm) if c[names.index(f"GM{j + 1}")] > 0]  # named as _nonlinear_terms does
    for j, T, k_eq in _walk_gms(p, s, theta, c, 4.0):
        k = names.index(f"GM{j + 1}")
        t_lo, t_hi = _lognormal(T, sd[1][i0 + j])
        top = math.sqrt(2.0 * (c[k] + Z95 * sd[0][k]) / t_lo)
        cross = math.sqrt(3.0) * n / k_eq  # where its walk line meets N's
        if cross > T / 8:  # an octave of the walk's rise shown, not two: K's bound reaches it
            _raise_bound(t, top)
            continue
        t.value, t.estimate = k_eq, k_eq
        t.low, t.high, t.upper = math.sqrt(2.0 * max(c[k] - Z95 * sd[0][k], 0.0) / t_hi), top, top
        t.tau_range = (cross, T / 2.0)
        t.note = (
            f"read from GM{alive.index(j) + 1} (correlation time {T:.3g} s), which rises as a rate random walk "
            "under it (K = sd sqrt(2 / T)), the ramp R carrying the rise on past it: a walk's realization with a trend"
        )
        return


def _nonlinear_terms(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, sd_th: np.ndarray, term
) -> dict[str, Term]:
    """LP (fc, order), GM1, GM2 (tau_c), RES (f0, quality) and SIN (f0), with log-normal intervals."""
    names = s.names()
    out: dict[str, Term] = {}
    i_th = 0
    if s.lp:
        fc, sd = math.exp(theta[0]), sd_th[0]
        lo, hi = _lognormal(fc, sd)
        hi = min(hi, max(0.5, FC_CEILING[s.shape]) * p.fs)
        rng = (float(p.t[0]), _bend_end(s, fc, p.t, p.fs))
        note = (
            f"the white noise N reaches the samples through {LP_WORDS[s.shape, s.lp]} of {fc:.3g} Hz: "
            f"the curve bends under N's line (by {LP_BEND / 2 * 100:g} % of the deviation or more) up to {rng[1]:.3g} s"
        )
        extra = {"fc": fc, "fc_low": lo, "fc_high": hi, "order": s.lp, "shape": s.shape}
        out["LP"] = Term("LP", fc, lo, hi, rng, fc, hi, note, extra=extra)
        i_th = 1
    alive = [j for j in range(s.ngm) if c[names.index(f"GM{j + 1}")] > 0]
    for n_out, j in enumerate(alive):
        t = term(f"GM{j + 1}")
        T, sdT = math.exp(theta[i_th + j]), sd_th[i_th + j]
        t.name = f"GM{n_out + 1}"
        lo, hi = _lognormal(T, sdT)
        t.extra = {"tau_c": T, "tau_c_low": lo, "tau_c_high": hi}
        if T > p.t[-1]:
            k_eq = math.sqrt(c[names.index(f"GM{j + 1}")]) * math.sqrt(2.0 / T)
            t.note = (t.note + "; " if t.note else "") + (
                f"its correlation time {T:.3g} s is longer than the curve's last tau: over these taus it "
                f"acts as a rate random walk K = {k_eq:.3g}"
            )
        out[t.name] = t
    if s.res and c[names.index("RES")] > 0:
        out["RES"] = _res_term(s, theta, c, sd_th, term("RES"))
    if s.sine and c[names.index("SIN")] > 0:
        t = term("SIN")
        f0, sdf = math.exp(theta[-1]), sd_th[-1]
        lo, hi = _lognormal(f0, sdf)
        t.extra = {"f0_hz": f0, "f0_low": lo, "f0_high": hi}
        t.note = (t.note + "; " if t.note else "") + (
            f"an oscillation of {f0:.3g} Hz (period {1 / f0:.3g} s), amplitude {math.sqrt(c[names.index('SIN')]):.3g}"
        )
        out["SIN"] = t
    return out


def _res_term(s: Structure, theta: np.ndarray, c: np.ndarray, sd_th: np.ndarray, t: Term) -> Term:
    """The resonance: sd (value), frequency and quality with log-normal intervals."""
    i = s.res_at()
    f0, q = math.exp(theta[i]), math.exp(theta[i + 1])
    f_lo, f_hi = _lognormal(f0, sd_th[i])
    q_lo, q_hi = _lognormal(q, sd_th[i + 1])
    t.extra = {"f0_hz": f0, "f0_low": f_lo, "f0_high": f_hi, "quality": q, "quality_low": q_lo, "quality_high": q_hi}
    t.extra["tau_c"] = q / (math.pi * f0)
    sd = math.sqrt(c[s.names().index("RES")])
    held = [w for w, v in (("frequency", sd_th[i]), ("quality", sd_th[i + 1])) if v == 0]
    t.note = (t.note + "; " if t.note else "") + (
        f"a resonance of {f0:.3g} Hz (quality {q:.3g}: a mode rung by the bench), sd {sd:.3g}; "
        "what it adds to the short taus is not white noise, N is read under it"
        + (f"; its {' and '.join(held)} at the search's bound (the curve does not pin it there)" if held else "")
    )
    return t


LP_WORDS = {
    ("pole", 1): "a one-pole low-pass",
    ("pole", 2): "a two-pole low-pass",
    ("pole", 4): "a four-pole low-pass",
    ("average", 1): "a moving average",
    ("average", 2): "two moving averages in cascade (a Bartlett window)",
    ("pole_mean", 1): "a one-pole low-pass averaged over each sample",
    ("pole_mean", 2): "a two-pole low-pass averaged over each sample",
}


def _bend_end(s: Structure, fc: float, t: np.ndarray, fs: float) -> float:
    """The longest tau at which the band limit holds the curve LP_BEND (AVAR) or more
    under N's line: the short-tau region it names (a bend fades as 1 / tau, not at 1 / fc)."""
    grid = np.exp(np.linspace(math.log(t[0]), math.log(t[-1]), 400))
    m = np.maximum(np.rint(grid * fs), 1.0)
    ratio = LP(1.0, fc, s.lp, s.shape).avar(m, fs) / WN(1.0).avar(m, fs)
    bent = np.flatnonzero(ratio <= 1.0 - LP_BEND)
    return float(grid[bent[-1]]) if bent.size else float(t[0])


def _lognormal(v: float, sd: float) -> tuple[float, float]:
    """95 % interval of a positive parameter whose log has sd ``sd`` (an unconstrained
    one, sd of hundreds, gives 0 .. inf rather than an overflow)."""
    z = min(Z95 * sd, 700.0)
    return v * math.exp(-z), v * math.exp(z)
