"""Noise terms that hold on real recordings: the IEEE 952 fit of terms.py,
made robust.

A real sensor's Allan curve carries more than the five IEEE 952 terms
(correlated noise at short tau from the sensor's own filter and decimation,
Gauss-Markov humps, oscillations, drift), and a curve of a million samples
is so precise at short tau that a plain weighted fit of the five terms is
pulled by whatever it cannot model: chi2/dof in the thousands, B dropped or
placed above every point. Three steps, each a published practice:

1. *Model error in the weights* (Jurado et al. 2019 weight the AV
   regression by each estimate's variance; GMWM, Guerrier et al. 2013, by
   the inverse covariance of the estimates): each point's standard deviation
   is the statistical one (chi-squared with its EDF, correlated between
   taus; terms.py) plus, in quadrature, a model error of MODEL_ERR of the
   deviation. Without it, the points of highest EDF (short tau) decide
   everything and a 2 % misfit there outweighs the whole floor.
2. *Fit where the terms explain the curve* (IEEE Std 952-1997 Annex C and
   El-Sheimy et al. 2008 read each term on the part of the curve where it
   dominates): points whose 95 % interval, widened by TOL, does not hold the
   fitted model are set aside one at a time, worst first, and the fit is
   redone; the runs of points set aside are named and described (a
   correlated short-tau region, a hump, an oscillation, a rise).
3. *Each term under the curve*: a term alone can never exceed the total
   variance, so no coefficient may put its line above the curve's own 95 %
   interval at any point that is not in a short-tau region below the model:
   these are bounds of the constrained fit (bounded least squares), and they
   cap every interval and every upper bound.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

from ..stats.edf import chi2_interval
from .terms import ALPHA, TERMS, EdfFn, FitResult, b_classic, basis, fit_terms, local_alpha, usable_points

MODEL_ERR = 0.05
"""Relative standard deviation of ADEV granted to the five-term model (0.10 in AVAR)."""
TOL = 0.10
"""A point is unexplained when the model lies outside its 95 % interval widened by this (deviation)."""
MIN_KEEP = 4
FLAT_SLOPE = 0.25
FLAT_OCTAVES = 2.0
"""A flat region: ADEV slopes within +-0.25 between neighbouring points over 2 octaves or more."""
SINE_PEAK = 0.371
"""ADEV of a sinusoid of frequency f0 peaks at tau = 0.371 / f0 (El-Sheimy et al. 2008)."""
GM_PEAK = 1.89
"""ADEV of a first-order Gauss-Markov process of correlation time T peaks at tau = 1.89 T."""


def identify(
    tau: ArrayLike, avar: ArrayLike, edf_fn: EdfFn, mask: Optional[np.ndarray] = None, overlapping: bool = True
) -> FitResult:
    """The IEEE 952 terms of the curve (tau, avar), fitted where they explain it.

    Same arguments and result as terms.fit_terms; the result's
    ``unexplained`` lists the tau ranges set aside, and its notes say so.
    """
    tau = np.asarray(tau, dtype=np.float64)
    avar = np.asarray(avar, dtype=np.float64)
    usable = usable_points(tau, avar, mask)
    idx = np.flatnonzero(usable)
    idx = idx[np.argsort(tau[idx])]
    if idx.size < MIN_KEEP + 1:
        return fit_terms(tau, avar, edf_fn, mask=usable, overlapping=overlapping)
    t, y = tau[idx], avar[idx]
    alpha = np.zeros(tau.size, dtype=np.int64)
    alpha[idx] = local_alpha(t, y)
    e = np.asarray(edf_fn(alpha), dtype=np.float64)[idx]
    e = np.where(np.isfinite(e) & (e > 0), e, 1.0)
    lo, hi = chi2_interval(y, e)
    band_lo, band_hi = lo / (1 + TOL) ** 2, hi * (1 + TOL) ** 2
    A = basis(t)
    keep, m = _trim(A, y, e, band_lo, band_hi)
    deficit = ~keep & (y < m)
    ok = ~deficit
    full_mask = np.zeros(tau.size, dtype=bool)
    full_mask[idx[keep]] = True

    def upper_of(model_terms: np.ndarray) -> np.ndarray:
        # the curve's 95 % upper limit with the EDF of the noise type the model says dominates
        # (as the document's intervals are drawn)
        a = np.zeros(tau.size, dtype=np.int64)
        a[idx] = [ALPHA[TERMS[j]] for j in np.argmax(model_terms, axis=1)]
        ee = np.asarray(edf_fn(a), dtype=np.float64)[idx]
        return chi2_interval(y, np.where(np.isfinite(ee) & (ee > 0), ee, 1.0))[1]

    hi_m = upper_of(A * _quick(A, y, e, keep, coef=True))
    caps = np.min(hi_m[ok, None] / A[ok], axis=0)

    flat = _flat(t, y, e)
    sig = {"B": flat} if flat else None

    def fit_at(floor: float) -> FitResult:
        return fit_terms(
            tau, avar, edf_fn, mask=full_mask, overlapping=overlapping, floor=floor, caps=caps, signature=sig
        )

    floor = _floor(fit_at)
    fit = fit_at(floor)
    if fit.coef.any():  # the final model may call other noise types dominant: hold its intervals too
        hi_m = upper_of(A * fit.coef)
        caps2 = np.minimum(caps, np.min(hi_m[ok, None] / A[ok], axis=0))
        if np.any(caps2 < caps * (1 - 1e-9)):
            caps = caps2
            fit = fit_at(floor)
    fit.notes.insert(
        0,
        f"model error granted to the terms: {floor / 2 * 100:.2g} % of the deviation "
        f"(the least that brings chi2/dof to 1, at most {MODEL_ERR * 100:g} %)",
    )
    hi = hi_m
    model = fit.model(t)
    fit.unexplained = _regions(t, y, model, keep)
    for r in fit.unexplained:
        fit.notes.append(r["text"])
    for k, term in fit.terms.items():
        j = TERMS.index(k)
        if (
            term.value is not None
            and term.high is not None
            and not term.note
            and term.high >= math.sqrt(caps[j]) * (1 - 1e-9)
        ):
            tj = float(t[~deficit][np.argmin(hi[~deficit] / A[~deficit, j])])
            term.note = f"its 95 % interval stops where its line meets the curve's upper 95 % limit (at {tj:.3g} s)"
    e_full = np.full(tau.size, np.nan)
    e_full[idx] = e
    fit.b_classic = b_classic(tau, avar, usable, e_full)  # over the whole curve, not the kept points
    return fit


def _trim(
    A: np.ndarray, y: np.ndarray, e: np.ndarray, band_lo: np.ndarray, band_hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The points the terms explain: drop the worst point outside its widened
    95 % band, one at a time, refitting each time; returns (keep, model)."""
    keep = np.ones(y.size, dtype=bool)
    m = _quick(A, y, e, keep)
    while keep.sum() > MIN_KEEP:
        # excess first: other processes only add variance, so a point above the terms
        # is more likely theirs than a point below (only a filter takes variance away)
        excess = np.where(keep, np.log(band_lo / m), 0.0)
        deficit = np.where(keep, np.log(m / band_hi), 0.0)
        bad = excess if excess.max() > 0.0 else deficit
        worst = int(np.argmax(bad))
        if bad[worst] <= 0.0:
            break
        keep[worst] = False
        m = _quick(A, y, e, keep)
    return keep, m


def _flat(t: np.ndarray, y: np.ndarray, e: np.ndarray) -> Optional[tuple[float, float]]:
    """The curve's flat region: from its lowest point (of EDF >= 10), the neighbours
    reached with ADEV slopes within +-FLAT_SLOPE, if they span FLAT_OCTAVES or more."""
    ok = np.flatnonzero(e >= 10.0)
    if ok.size == 0:
        return None
    i0 = int(ok[np.argmin(y[ok])])
    slope = 0.5 * np.diff(np.log(y)) / np.diff(np.log(t))
    a = b = i0
    while a > 0 and abs(slope[a - 1]) <= FLAT_SLOPE:
        a -= 1
    while b < t.size - 1 and abs(slope[b]) <= FLAT_SLOPE:
        b += 1
    if math.log2(t[b] / t[a]) < FLAT_OCTAVES - 1e-9:
        return None
    return float(t[a]), float(t[b])


def _floor(fit_at) -> float:
    """The model error (relative, in AVAR) that makes chi2/dof = 1: 0 when the terms
    already fit within the statistical scatter, at most 2 MODEL_ERR (beyond that the
    intervals are widened by chi2/dof, terms.py)."""
    top = 2.0 * MODEL_ERR
    if fit_at(top).chi2_red >= 1.0:
        return top
    if fit_at(0.0).chi2_red <= 1.0:
        return 0.0
    lo, hi = 0.0, top
    for _ in range(6):  # to 1/64 of MODEL_ERR
        mid = 0.5 * (lo + hi)
        if fit_at(mid).chi2_red > 1.0:
            lo = mid
        else:
            hi = mid
    return hi


def _quick(A: np.ndarray, y: np.ndarray, e: np.ndarray, keep: np.ndarray, coef: bool = False) -> np.ndarray:
    """Model AVAR at every point from a diagonal-weight NNLS on the kept points
    (model-based weights, three rounds): fast enough to redo per point set aside."""
    from .lsq import _nnls

    ref = y.copy()
    c = np.zeros(A.shape[1])
    for _ in range(3):
        sd = ref * np.sqrt(2.0 / e + (2.0 * MODEL_ERR) ** 2)
        w = 1.0 / sd[keep]
        c = _nnls(A[keep] * w[:, None], y[keep] * w)
        mod = A @ c
        ref = np.where(mod > 0, mod, y)
    return c if coef else A @ c


def _regions(
    t: np.ndarray, y: np.ndarray, model: np.ndarray, keep: np.ndarray, tol: Optional[np.ndarray] = None
) -> list[dict]:
    """Runs of points set aside, described by where they lie and their shape (``tol``: each
    point's widening, where it is not TOL)."""
    out: list[dict] = []
    n = t.size
    r = np.sqrt(y / np.where(model > 0, model, np.nan))  # deviation ratio curve / terms
    for i, j in runs(~np.asarray(keep, dtype=bool)):
        sel = slice(i, j + 1)
        rr = r[sel]
        span = (float(t[i]), float(t[j]))
        where = f"{span[0]:.3g} s" if i == j else f"{span[0]:.3g} .. {span[1]:.3g} s"
        if np.nanmedian(rr) < 1.0:
            low = float(np.nanmin(rr))
            if i == 0:
                kind = "short-tau correlation"
                text = (
                    f"{where}: the curve lies below the terms (down to {low:.2f} of them): samples "
                    "correlated at short tau, by the sensor's own low-pass filter or decimation"
                )
            else:
                kind = "dip"
                text = (
                    f"{where}: the curve dips below the terms (down to {low:.2f} of them): the "
                    "null of an oscillation, or a filtered band"
                )
            ratio = low
        else:
            p = i + int(np.nanargmax(rr))
            ratio = float(r[p])
            if p == n - 1:
                kind = "rise"
                text = (
                    f"{where}: the curve rises above the terms at long tau (up to {ratio:.2f} times "
                    "them): drift, temperature, or a slow Gauss-Markov process"
                )
            else:
                # how the excess over the terms falls after its peak (ADEV slope)
                ex0, ex1 = y[p] - model[p], y[p + 1] - model[p + 1]
                fall = 0.5 * math.log(ex1 / ex0) / math.log(t[p + 1] / t[p]) if ex1 > 0 else -math.inf
                if fall <= -0.75:
                    kind = "oscillation"
                    text = (
                        f"{where}: a hump up to {ratio:.2f} times the terms, peaking at {t[p]:.3g} s, "
                        f"its excess falling {_slope(fall)}: an oscillation of period about "
                        f"{t[p] / SINE_PEAK:.3g} s (a sinusoid's ADEV peaks at 0.371 T)"
                    )
                else:
                    kind = "hump"
                    text = (
                        f"{where}: a hump up to {ratio:.2f} times the terms, peaking at {t[p]:.3g} s: "
                        f"a Gauss-Markov process of correlation time about {t[p] / GM_PEAK:.3g} s "
                        "(its ADEV peaks at 1.89 T)"
                    )
        out.append(
            {
                "tau_s": [span[0], span[1]],
                "kind": kind,
                "ratio": ratio,
                "text": f"not explained by the terms (outside the points' 95 % intervals widened by "
                f"{_widening(tol, sel)}), left out of the fit: {text}",
            }
        )
    return out


def runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True in ``flag``."""
    e = np.diff(np.concatenate(([0], np.asarray(flag, dtype=np.int8), [0])))
    return [(int(i), int(j) - 1) for i, j in zip(np.flatnonzero(e == 1), np.flatnonzero(e == -1))]


def _widening(tol: Optional[np.ndarray], sel: slice) -> str:
    if tol is None:
        return f"{TOL * 100:g} %"
    w = tol[sel] if tol.ndim else tol
    return f"{float(np.max(w)) * 100:.2g} %: two sd of the model error granted there, at least {MODEL_ERR * 100:g} %"


def _slope(mu: float) -> str:
    return "to nothing at the next point" if not math.isfinite(mu) else f"as tau^{mu:.2g}"
