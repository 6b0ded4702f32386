"""The reading of a whole-curve fit (fit.py): each process as a term with its 95 %
interval and tau range, upper bounds of the absent IEEE 952 terms, the IEEE 952
slope reading beside the fit, and the points the model leaves unexplained."""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from ..stats import dist
from ..stats.dist import Z95
from .curve import resonance
from .flicker import Flicker
from .processes import AR1, LP, QN, RW, WN, Model, Ramp, Sine
from .terms import B_FACTOR, Term


def _linear_term(
    k: str, c: float, sd: float, comp: Optional[np.ndarray], total: np.ndarray, grid: np.ndarray, shown: bool = False
) -> Term:
    """The term of coefficient c (sd sd): its value and chi-squared shaped 95 % interval, or,
    when c < 1.96 sd and the selection has not ``shown`` it present, its upper bound only."""
    est = math.sqrt(c)
    if sd > 0:
        nu = 2.0 * (c / sd) ** 2
        q_hi, q_lo = float(dist.chi2_ppf(0.975, nu)), float(dist.chi2_ppf(0.025, nu))
        lo = math.sqrt(c * nu / q_hi) if q_hi > 0 else 0.0
        hi = math.sqrt(c * nu / q_lo) if q_lo > 0 else math.inf
    else:
        lo = hi = est
    note = ""
    rng = None
    if comp is not None:
        share = comp / np.where(total > 0, total, 1.0)
        dom = share >= 0.5
        if dom.any():
            rng = (float(grid[dom][0]), float(grid[dom][-1]))
        else:
            i = int(np.argmax(share))
            near = share >= 0.5 * share[i]  # where it counts most: within half its largest share
            rng = (float(grid[near][0]), float(grid[near][-1]))
            note = (
                f"nowhere the larger part of the curve (at most {share[i] * 100:.0f} %, at {grid[i]:.3g} s); "
                "its range: where its share is at least half that"
            )
    if c < Z95 * sd and not shown:
        # the chi-squared shape assumes an estimate well clear of 0; here, as for a term left
        # out (fit._upper), the bound is the normal one on the square
        hi = math.sqrt(c + Z95 * sd)
        return Term(
            k,
            None,
            None,
            None,
            rng,
            est,
            hi,
            f"not identifiable: its 95 % interval includes 0 (estimate {est:.3g}, at most {hi:.3g})",
        )
    return Term(k, est, lo, hi, rng, est, hi, note)


def _unexplained_all(t: np.ndarray, y: np.ndarray, model: np.ndarray, keep: np.ndarray) -> list[dict]:
    from .identify import _regions

    k = np.zeros(t.size, dtype=bool)
    k[keep] = True
    return _regions(t, y, model, k)


def _unexplained(p: Any, model: np.ndarray, e: np.ndarray, tol: Any = None) -> list[dict]:
    """The runs of points whose 95 % interval, widened by ``tol`` (deviation; per point, or
    identify.TOL), does not hold the model."""
    from ..stats.edf import chi2_interval
    from .identify import TOL, _regions

    w = TOL if tol is None else np.asarray(tol)
    lo, hi = chi2_interval(p.y, e)
    keep = (model >= lo / (1 + w) ** 2) & (model <= hi * (1 + w) ** 2)
    return _regions(p.t, p.y, model, keep, None if tol is None else w)


SLOPE = {"Q": -1.0, "N": -0.5, "B": 0.0, "K": 0.5, "R": 1.0}


def slope_reading(t: np.ndarray, y: np.ndarray, e: np.ndarray, tol: float = 0.125) -> dict[str, dict]:
    """The IEEE 952 slope reading: each term read off the longest run (two or more) of points
    where the ADEV slope (to both neighbours) is within ``tol`` of its own (Q -1,
    N -1/2, B 0, K +1/2, R +1), on points with EDF >= 10."""
    adev = np.sqrt(y)
    lt, la = np.log(t), np.log(adev)
    sl = np.diff(la) / np.diff(lt)
    out: dict[str, dict] = {}
    read = {
        "Q": lambda a, x: a * x / math.sqrt(3),
        "N": lambda a, x: a * np.sqrt(x),
        "B": lambda a, x: a / math.sqrt(B_FACTOR),
        "K": lambda a, x: a * np.sqrt(3 / x),
        "R": lambda a, x: a * math.sqrt(2) / x,
    }
    for k, mu in SLOPE.items():
        ok = np.zeros(t.size, dtype=bool)
        for i in range(t.size):
            nb = [sl[j] for j in (i - 1, i) if 0 <= j < sl.size]
            ok[i] = bool(nb) and all(abs(v - mu) <= tol for v in nb) and e[i] >= 10
        if ok.any():
            pos = np.flatnonzero(ok)
            run = max(np.split(pos, np.flatnonzero(np.diff(pos) > 1) + 1), key=len)
            if run.size < 2:  # one point is no slope
                continue
            vals = read[k](adev[run], t[run])
            v = float(np.min(vals)) if k == "B" else float(np.median(vals))
            out[k] = {"value": v, "tau_s": [float(t[run[0]]), float(t[run[-1]])], "points": int(run.size)}
    return out


def _compare(res: Any, notes: list[str]) -> None:
    for k, r in res.slope.items():
        t = res.terms.get(k)
        if t is None or t.value is None:
            continue
        ratio = t.value / r["value"]
        if abs(math.log(ratio)) > math.log(1.25):
            notes.append(
                f"{k}: the whole-curve fit gives {t.value:.3g}, the IEEE 952 slope reading "
                f"{r['value']:.3g} ({r['tau_s'][0]:.3g} .. {r['tau_s'][1]:.3g} s): the other "
                "processes share those points"
            )


def to_model(s: Any, theta: np.ndarray, c: np.ndarray) -> Model:
    """The catalogue model of a structure and its parameters (terms at 0 left out)."""
    parts = []
    vals = dict(zip(s.names(), c))
    if vals.get("Q", 0) > 0:
        parts.append(QN(math.sqrt(vals["Q"])))
    if vals.get("N", 0) > 0:
        n = math.sqrt(vals["N"])
        parts.append(LP(n, math.exp(theta[0]), s.lp, s.shape) if s.lp else WN(n))
    if vals.get("B", 0) > 0:
        parts.append(Flicker(math.sqrt(vals["B"]), s.flicker()))
    if vals.get("K", 0) > 0:
        parts.append(RW(math.sqrt(vals["K"])))
    if vals.get("R", 0) > 0:
        parts.append(Ramp(math.sqrt(vals["R"])))
    i = 1 if s.lp else 0
    for j in range(s.ngm):
        if vals.get(f"GM{j + 1}", 0) > 0:
            parts.append(AR1(math.sqrt(vals[f"GM{j + 1}"]), math.exp(theta[i + j])))
    if s.res and vals.get("RES", 0) > 0:
        parts.append(resonance(theta, s.res_at(), math.sqrt(vals["RES"])))
    if s.sine and vals.get("SIN", 0) > 0:
        parts.append(Sine(math.sqrt(vals["SIN"]), math.exp(theta[-1])))
    return Model(parts)
