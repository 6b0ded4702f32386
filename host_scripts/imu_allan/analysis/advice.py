"""How long to record: the interval each noise term has now, and the recording
time after which it would be +-10 % and +-25 % (docs/dynamic.md).

An estimate under stated assumptions: the sensor stays as it was (the fitted
model holds), and every point that carries a term gains degrees of freedom in
proportion to the recording time (true of both Allan estimators at a fixed
tau once the record is many taus long).  A term's interval is read as that of
a deviation with some equivalent EDF nu (the chi-squared interval of NIST SP
1065 eq. 45, whose relative half-width falls as about 1/sqrt(2 nu)); the time
for a target half-width is the time now times nu(target) / nu(now).

On the device alone (``device_advice``) the terms are the device's N and B
with the summary's uncertainty 100 / sqrt(2 pairs) % (docs/protocol.md), and
a level has pairs = floor(n / m) - 1 after n samples: the time after which the
level of each term holds enough pairs is exact, given that the term stays at
the same level.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional

import numpy as np
from scipy import optimize

from ..stats import dist

LEVEL = 0.95
TARGETS_PCT = (10, 25)


def halfwidth(nu: float, level: float = LEVEL) -> float:
    """Relative half-width of the ``level`` interval of a deviation estimated
    with ``nu`` degrees of freedom: (sqrt(nu/chi2_lo) - sqrt(nu/chi2_hi)) / 2."""
    a = 1.0 - level
    hi = math.sqrt(nu / dist.chi2_ppf(a / 2, nu))
    lo = math.sqrt(nu / dist.chi2_ppf(1 - a / 2, nu))
    return (hi - lo) / 2


def edf_for(rel_halfwidth: float, level: float = LEVEL) -> float:
    """The EDF whose interval has this relative half-width (inverse of ``halfwidth``)."""
    f = lambda lg: math.log(halfwidth(math.exp(lg), level)) - math.log(rel_halfwidth)  # noqa: E731
    lo, hi = math.log(0.5), math.log(1e13)
    if f(lo) < 0:
        return 0.5
    if f(hi) > 0:
        return 1e13
    return math.exp(optimize.brentq(f, lo, hi, xtol=1e-10))


def record_for(pct_now: float, duration_s: float, target_pct: float, level: float = LEVEL) -> float:
    """Recording time (s, from the start) after which a term now +-``pct_now`` % would be +-``target_pct`` %."""
    return duration_s * edf_for(target_pct / 100, level) / edf_for(pct_now / 100, level)


def term_interval_pct(term: dict[str, Any]) -> Optional[float]:
    """Half the width of a term's interval, in % of its value."""
    v, lo, hi = term.get("value"), term.get("low"), term.get("high")
    if not v or lo is None or hi is None or v <= 0 or hi < lo:
        return None
    return 100.0 * (hi - lo) / (2.0 * v)


NEIGHBOUR_CORR = 0.5
"""Correlation taken between the estimates of neighbouring octaves (measured
0.35-0.68 by simulation, docs/analysis.md section 5); with 0.5 the interval
predicted from the points' EDFs matches the one the fit gives, on white noise
(N) and on white plus flicker noise (B), within about 10 %."""


def term_edf(
    curve: list[dict[str, Any]], tau_range: Optional[list[float]], term: str, overlapping: bool
) -> Optional[float]:
    """The degrees of freedom behind a term: the EDFs of the fitted octave points
    in its tau range, summed, times (1 - r) / (1 + r) for the correlation r of
    neighbouring octaves (the number of independent points in a chain of them)."""
    if not tau_range:
        return None
    lo, hi = tau_range[0] * (1 - 1e-9), tau_range[1] * (1 + 1e-9)
    edfs = [p["edf"] for p in curve if p.get("used") and p.get("edf") and lo <= p["tau_s"] <= hi]
    if not edfs:
        return None
    r = NEIGHBOUR_CORR
    return sum(edfs) * (1 - r) / (1 + r) if len(edfs) > 1 else edfs[0]


def _term_names(fit: Any) -> list[str]:
    """The fitted processes' term names, in the order of ``fit.fitted`` (as fit.components names them)."""
    names, gm = [], 0
    for p in fit.fitted:
        name = {"LP": "N", "S": "SIN"}.get(p.name, p.name)
        if name == "GM":
            gm += 1
            name = f"GM{gm}"
        names.append(name)
    return names


def _jacobian(fit: Any, t: np.ndarray) -> np.ndarray:
    """d AVAR / d log(parameter) at tau ``t`` for every parameter of the fitted model: each
    process's squared amplitude (its AVAR itself) first, then its free parameters (numerically)."""
    m = t * fit.fs
    h = 1e-4
    cols, extra = [], []
    for p in fit.fitted:
        base = p.avar(m, fit.fs)
        cols.append(base)
        extra.extend((q.avar(m, fit.fs) - base) / h for q in _nudged(fit, p, h))
    return np.stack(cols + extra, axis=1)


def _nudged(fit: Any, p: Any, h: float) -> list:
    """p with each parameter the fit counts free raised by h in its log.  A resonance's are the
    fit's own, its frequency (at its quality) and its quality, and one the fit held at its
    search's bound (curve.free_parameters; its interval then a point) is not traded: counted
    free, it widened a real accelerometer's predicted N from the fit's +-3 % to +-23 %, and a
    time was advised for +-10 % that the record already gave."""
    if p.name == "RES":
        x, out = fit.terms["RES"].extra, []
        if x["f0_low"] < x["f0_high"]:
            out.append(dataclasses.replace(p, f0=p.f0 * math.exp(h), T=p.T * math.exp(-h)))
        if x["quality_low"] < x["quality_high"]:
            out.append(dataclasses.replace(p, T=p.T * math.exp(h)))
        return out
    return [
        p.__class__(**{**p.params(), f.name: getattr(p, f.name) * math.exp(h)})
        for f in dataclasses.fields(p)[1:]
        if isinstance(getattr(p, f.name), float) and f.name != "order"
    ]


def predicted_pct(
    fit: Any, points: list[dict[str, Any]], scale: float, overlapping: bool, model_error: bool = True
) -> dict[str, float]:
    """The interval (+-%, 95 %) each fitted term would have on a record ``scale`` times as long,
    were the sensor the fitted model: the generalized least squares of the fit (the points'
    chi-squared variances from their EDF, correlated between octaves) and, with
    ``model_error``, the model error the fit granted (``fit.model_error``, the same share of
    every point however long the record, and ``fit.widened``): at scale 1 the fit's own interval.

    ``points``: the fit's octave points now (tau_s, edf, used). A point keeps its tau and its
    EDF grows by ``scale`` (EDF ~ N/m once the record is many taus long); each doubling of the
    record adds the next octave, whose EDF is the longest point's now (the same fraction of the
    record, hence about the same EDF)."""
    from ..noise import curve as F
    from ..noise.terms import local_alpha

    used = [p for p in points if p.get("used") and p.get("edf")]
    if len(used) < 2 or not list(fit.fitted):
        return {}
    tau = np.array([p["tau_s"] for p in used])
    edf = np.array([p["edf"] for p in used]) * scale
    for i in range(1, int(math.floor(math.log2(scale) + 1e-9)) + 1):
        tau = np.append(tau, tau[-1] * 2)
        edf = np.append(edf, used[-1]["edf"] * scale / 2**i)
    ref = fit.model(tau)
    alpha = local_alpha(tau, ref)
    floor, widened = (getattr(fit, "model_error", 0.0), getattr(fit, "widened", 1.0)) if model_error else (0.0, 1.0)
    gls = F._Gls(tau, ref, edf, alpha, "overlapping" if overlapping else "nonoverlapping", floor)
    Jw = gls.white(_jacobian(fit, tau))
    scale_cols = np.linalg.norm(Jw, axis=0)
    scale_cols[scale_cols == 0] = 1.0
    cov = np.linalg.pinv((Jw / scale_cols).T @ (Jw / scale_cols)) / np.outer(scale_cols, scale_cols) * widened
    out = {}
    for j, name in enumerate(_term_names(fit)):
        rel = math.sqrt(max(cov[j, j], 0.0))  # sd of log c, c the squared amplitude
        if rel > 0:
            out[name] = 100.0 * halfwidth(2.0 / rel**2)
    return out


def record_for_target(
    fit: Any,
    points: list[dict[str, Any]],
    duration: float,
    overlapping: bool,
    targets=TARGETS_PCT,
    model_error: bool = False,
    aims: Optional[dict[str, tuple[float, ...]]] = None,
    ratios: Optional[dict[str, float]] = None,
) -> dict[str, dict[str, Optional[float]]]:
    """Per term: the predicted +-% now (``pct``) and the recording time (s) for each target
    (and, as ``check<i>``, the time its +-% would be ``aims[name][i]`` times what it is now:
    the checks), under the fitted model and, with
    ``model_error``, the model error the fit granted (None: a model error the record's length
    cannot beat): found on a quarter-octave grid of longer
    records and interpolated in log-log; for a target already met, the shorter record whose
    EDFs give it (every EDF in proportion).  ``ratios``: per term, the fit's interval over the
    one its points' EDFs give (at least 1), which a longer record keeps: the times are those
    of the prediction times it (K's interval is also judged under the structures the curve
    cannot tell apart and by test inversion: on white noise and a walk about 1.1 times)."""
    scales = 2.0 ** (np.arange(0, 4 * 24 + 1) / 4.0)
    preds: list[dict[str, float]] = []
    for sc in scales:  # until every term reaches the smallest target
        preds.append(predicted_pct(fit, points, float(sc), overlapping, model_error))
        if all(v * (ratios or {}).get(k, 1.0) <= min(targets) for k, v in preds[-1].items()):
            break
    scales = scales[: len(preds)]
    out: dict[str, dict[str, Optional[float]]] = {}
    for name, now in preds[0].items():
        r = (ratios or {}).get(name, 1.0)
        curve = np.array([p.get(name, math.inf) for p in preds]) * r
        item: dict[str, Optional[float]] = {"pct": now}
        for target in targets:
            if now * r <= target:
                item[target] = duration * edf_for(target / 100) / edf_for(now * r / 100)
            else:
                item[target] = _crossing(scales, curve, target, duration)
        for i, factor in enumerate((aims or {}).get(name, ())):
            item[f"check{i}"] = _crossing(scales, curve, now * r * factor, duration) if factor < 1 else None
        out[name] = item
    return out


def _crossing(scales: np.ndarray, pct: np.ndarray, target: float, duration: float) -> Optional[float]:
    """The record length (s) where the predicted +-% falls to ``target`` (None: beyond the grid)."""
    below = np.flatnonzero(pct <= target)
    if below.size == 0:
        return None
    i = int(below[0])
    x0, x1 = math.log(scales[i - 1]), math.log(scales[i])
    y0, y1 = math.log(pct[i - 1]), math.log(pct[i])
    x = x0 + (math.log(target) - y0) * (x1 - x0) / (y1 - y0) if y1 != y0 else x1
    return float(math.exp(x) * duration)


def add_to_analysis(doc: dict[str, Any], level: float = LEVEL, fits: Optional[dict[str, Any]] = None) -> None:
    """Adds to every identified term of ``analyze``'s document ``interval_pct`` (its
    interval now), ``expected_pct`` (the interval the points' EDFs give under the fitted
    model, without its model error) and ``record_s_for_10pct``, ``record_s_for_25pct``:
    the recording time (s from the start) after which it would be +-10 % and +-25 %
    (None: the fit's model error keeps it wider however long the record), and
    ``recheck_s_for_10pct``, ``recheck_s_for_25pct``: where that time is rough (the term
    now over ROUGH_RATIO times the target), the check to record to and ask again at (None:
    the time is firm, follow it).

    With the channels' ``fits`` (analyze's): from the fit's own least squares under
    the fitted model (``record_for_target``); for a term whose interval is mostly the
    fit's model error (over MODEL_ERROR_RATIO times ``expected_pct``), with that model
    error, which recording longer keeps. A smaller model error is left out of the times:
    it may be chance (a true model's chi2 passes its 95 % point on one record in twenty),
    and counted it would lengthen the advice for nothing (it is counted only for a target
    the EDFs alone call met while the interval is not). Without fits: from ``edf``, the degrees of freedom
    of the points in the term's tau range (``term_edf``)."""
    duration = (doc.get("source") or {}).get("duration_s")
    for ch_name, ch in doc.get("channels", {}).items():
        overlapping = (ch.get("fit") or {}).get("statistic") == "oadev"
        points = (ch.get("fit") or {}).get("octave_points") or ch.get("curve") or []
        fit = (fits or {}).get(ch_name)
        usable = fit is not None and duration and hasattr(fit, "fitted")
        terms = {k: t for k, t in (ch.get("terms") or {}).items() if t}
        for term in terms.values():
            term["interval_pct"] = term_interval_pct(term)
        aims = {
            k: tuple(check_aim(t["interval_pct"], x) / (t["interval_pct"] or 1) for x in TARGETS_PCT)
            for k, t in terms.items()
        }
        model = record_for_target(fit, points, duration, overlapping, aims=aims) if usable else {}
        ratios = _ratios(terms, model)
        if ratios:  # the fit's interval wider than its points' EDFs give, by a share a longer record keeps
            model = record_for_target(fit, points, duration, overlapping, aims=aims, ratios=ratios)
        granted = usable and (getattr(fit, "model_error", 0.0) > 0 or getattr(fit, "widened", 1.0) > 1)
        with_error = (
            record_for_target(fit, points, duration, overlapping, TARGETS_PCT, True, aims) if granted else model
        )
        for name, term in terms.items():
            nu = term_edf(points, term.get("tau_range_s"), name, overlapping)
            term["edf"] = nu
            if model:  # a term the prediction leaves out (LP: its interval is fc's, no variance's): none
                exp = term["expected_pct"] = model.get(name, {}).get("pct")
                pct = term["interval_pct"]
                # mostly model error (the text's mark): the times count it; a smaller one may be chance
                times = with_error if exp and pct and pct > MODEL_ERROR_RATIO * exp else model
                for i, target in enumerate(TARGETS_PCT):
                    t = times.get(name, {}).get(target)
                    if pct and pct > target and t is not None and t <= duration:  # met by EDFs, not by the interval
                        t = with_error.get(name, {}).get(target)
                    term[f"record_s_for_{target}pct"] = t
                    term[f"recheck_s_for_{target}pct"] = times.get(name, {}).get(f"check{i}")
                _stage(term, duration)
                continue
            term["expected_pct"] = 100 * halfwidth(nu, level) if nu else None
            for target, factor in zip(TARGETS_PCT, aims[name]):
                exp = term["expected_pct"]
                for aim, key in ((target, "record"), (exp * factor if exp else 0.0, "recheck")):
                    t = duration * edf_for(aim / 100, level) / nu if nu and duration and aim else None
                    term[f"{key}_s_for_{target}pct"] = t
            _stage(term, duration)


def _ratios(terms: dict[str, Any], model: dict[str, dict[str, Optional[float]]]) -> dict[str, float]:
    """Per term, its interval now over the one the points' EDFs give (``model``'s pct), where
    that is above 1 and not the model error's (at most MODEL_ERROR_RATIO): the part of the
    interval the fit adds beyond the EDFs (structures it cannot tell apart, a test inversion)
    scales with it as the record grows."""
    out = {}
    for name, term in terms.items():
        exp, pct = model.get(name, {}).get("pct"), term.get("interval_pct")
        if exp and pct and exp < pct <= MODEL_ERROR_RATIO * exp:
            out[name] = pct / exp
    return out


def _stage(term: dict[str, Any], duration: float) -> None:
    """Keeps ``recheck_s_for_<target>pct`` only where the time for the target is rough (the
    term now over ROUGH_RATIO times it): elsewhere None, and the time for the target is the one
    to follow. A check the prediction puts at or after that time is moved half-way to it."""
    pct = term.get("interval_pct")
    for target in TARGETS_PCT:
        key, final = f"recheck_s_for_{target}pct", term.get(f"record_s_for_{target}pct")
        t = term.get(key)
        if pct is None or pct <= ROUGH_RATIO * target or final is None or final <= duration:
            term[key] = None  # a firm time, or none to follow
        elif t is None or t <= duration or t >= final:  # the check not before the time: half-way (log)
            term[key] = math.sqrt(duration * final)


MODEL_ERROR_RATIO = 1.5
"""A term's interval this much wider than its points' EDFs give is mostly the fit's
model error (noise/fit.py), which does not shrink with time: the text says so."""

ROUGH_RATIO = 1.35
"""A time for a target is rough from a term now over this many times the target: the
term's own error now moves the time (the time goes as about the square of the interval
now), and a longer fit may take another structure, so the interval the advised record
then gives scatters wider than +-10 % of the target (docs/dynamic.md, section 4,
measures how much). The advice is then staged: record to ``recheck_s_for_<target>pct``
and ask again."""

STAGE_RATIO = 1.25
"""Where a time is rough, the check is at the time the term would be this many times the
target: close enough that the time asked there is firm (asked from under 1.35 times the
target, the advised record landed within +-10 % of it on 58 of 60 simulated seeds; from
over 1.35 times, on 8 of 12), far enough that the
term's own error now seldom carries it past the target."""

MAX_STEP = 3.0
"""A check never asks the term to shrink by more than this factor in one step: the farther
the extrapolation, the wider its landing (from +-49 %, a check aimed at +-12.5 % landed at
+-8.9 %, past the target)."""


def check_aim(pct: Optional[float], target: float) -> float:
    """The +-% a rough time's check aims at: STAGE_RATIO times the target, or the term's
    +-% now over MAX_STEP if that is wider. The prediction is asked for the same ratio to its
    own +-% now: a term whose interval is wider than the prediction's (a model error the
    times leave out) is taken to stay that much wider up to the check."""
    return max(STAGE_RATIO * target, (pct or 0.0) / MAX_STEP)


def fmt_time(s: Optional[float]) -> str:
    if s is None:
        return "?"
    if s >= 2 * 86400:
        return f"{s / 86400:.1f} d"
    if s >= 5400:
        return f"{s / 3600:.1f} h"
    if s >= 120:
        return f"{s / 60:.0f} min"
    return f"{s:.0f} s"


def analysis_text(doc: dict[str, Any]) -> str:
    """The advice block of ``analyze``'s text."""
    duration = (doc.get("source") or {}).get("duration_s") or 0.0
    lines = [
        "Recording length (an estimate: the fitted model holds, and a longer record is fitted",
        f"with it; each point's EDF grows with time; 95 % intervals; recorded {fmt_time(duration)}):",
    ]
    marked = rough = False
    for name, ch in doc.get("channels", {}).items():
        parts = []
        for k, term in (ch.get("terms") or {}).items():
            if not term or term.get("interval_pct") is None:
                continue
            pct, t10, t25 = term["interval_pct"], term["record_s_for_10pct"], term["record_s_for_25pct"]
            part = f"{k} +-{pct:.2g} % now"
            exp = term.get("expected_pct")
            if exp and pct > MODEL_ERROR_RATIO * exp:  # the fit granted model error: time does not shrink it
                part += " [model error]"
                marked = True
            for tgt, t in ((25, t25), (10, t10)):  # from the interval now, model error included
                if pct <= tgt or exp is None:
                    continue
                if t is None:
                    part += f", +-{tgt} % not by recording longer"
                    break
                if t > duration:
                    part += f", +-{tgt} % after about {fmt_time(t - duration)} more"
                    if pct > ROUGH_RATIO * tgt:
                        check = term.get(f"recheck_s_for_{tgt}pct")
                        part += f" (rough: ask again in {fmt_time(check - duration)})" if check else " (rough)"
                        rough = True
            parts.append(part)
        if parts:
            lines.append(f"  {name}: " + "; ".join(parts))
    if marked:
        lines.append("  [model error]: the interval is over 1.5 times what its points' EDFs give")
        lines.append("  (expected_pct in --json): the fit's model error, which recording longer keeps;")
        lines.append("  the times count it")
    if rough:
        lines.append(f"  (rough): the term is over {ROUGH_RATIO:g} times that target now, and its own error")
        lines.append(f"  moves the time: record to the check (where the term should be {STAGE_RATIO:g} times the")
        lines.append(f"  target, or its +-% now divided by {MAX_STEP:g}), ask again there and follow that")
        lines.append("  time (docs/dynamic.md, 4)")
    return "\n".join(lines) + "\n" if len(lines) > 2 else ""


# ---- from the device's reports alone --------------------------------------------------------


def pairs_for(pct: float) -> int:
    """Pairs a level needs for the summary's uncertainty 100 / sqrt(2 pairs) to reach ``pct``."""
    return math.ceil((100.0 / pct) ** 2 / 2.0 - 1e-9)


def device_advice(report: Any) -> dict[str, dict[str, dict[str, Any]]]:
    """Per channel and term (N, B) of a device report: the level, its pairs, +-% now
    (100 / sqrt(2 pairs)), and the run time (s since the reset) after which the
    level holds the pairs for +-10 % and +-25 %: (pairs + 1) m / fs."""
    h = report.header
    fs = float(h.fs_hz)
    rows = {(r.channel, r.level): r for r in report.rows}
    out: dict[str, dict[str, dict[str, Any]]] = {}
    levels = {ch: {k: getattr(t, k).level for k in ("N", "B")} for ch, t in report.terms.items()}
    if not levels:  # no T lines (an older firmware, or the host's emulation): the device's rule
        from .check import expected_terms

        for ch in sorted({r.channel for r in report.rows}):
            levels[ch] = {k: (v[0] if v else None) for k, v in expected_terms(report, ch).items()}
    for ch, lv in levels.items():
        out[ch] = {}
        for name in ("N", "B"):
            level = lv[name]
            row = rows.get((ch, level)) if level is not None else None
            if row is None or row.pairs < 1:
                continue
            item = {
                "level": level,
                "tau_s": row.m / fs,
                "pairs": row.pairs,
                "pct": 100.0 / math.sqrt(2 * row.pairs),
                "now_s": h.n / fs,
            }
            for target in TARGETS_PCT:
                item[f"record_s_for_{target}pct"] = (pairs_for(target) + 1) * row.m / fs
            out[ch][name] = item
    return out


def monitor_line(report: Any, columns: int = 80) -> str:
    """One line for the monitor: the worst channel's B (and N) now, and the time
    still needed for +-10 %: 'record: B +-23 % now (gx); +-10 % after about 2.4 h more'."""
    adv = device_advice(report) if report is not None else {}
    worst = max(((ch, a["B"]) for ch, a in adv.items() if "B" in a), key=lambda x: x[1]["pct"], default=None)
    if worst is None:
        return "record: no noise terms yet (the device sends them once level 0 has 8 pairs)"[:columns]
    ch, b = worst
    more = b["record_s_for_10pct"] - b["now_s"]
    text = f"record: B +-{b['pct']:.0f} % now (worst {ch}, tau {b['tau_s']:.3g} s); "
    text += f"+-10 % after about {fmt_time(more)} more" if more > 0 else "+-10 % reached"
    n_pct = max((a["N"]["pct"] for a in adv.values() if "N" in a), default=None)
    if n_pct is not None:
        tail = f"; N +-{n_pct:.2g} %"
        if len(text) + len(tail) <= columns:
            text += tail
    return text[:columns]
