"""The over-bounding white noise + random walk pair: what an estimator that models
each axis as N and K only (Kalibr, OpenVINS, VINS-Fusion) should be given so that
the effects it does not model (bias instability, Gauss-Markov humps, filters,
oscillations) are covered up to a horizon (docs/analysis.md, "over-bounding pair").

The pair (N, K) has the Allan variance N^2 / tau + K^2 tau / 3 (IEEE Std 952
annex C).  It over-bounds the measured curve when that is at or above the upper
end of every octave point's 95 % interval, U_i, from 1/fs up to the horizon:

    a / tau_i + b tau_i / 3 >= U_i,   a = N^2 >= 0,  b = K^2 >= 0.

The constraints are linear in (a, b); among the pairs that meet them, "smallest"
is the one whose Allan variance exceeds the limit least on average over the
octaves: it minimises sum_i (a / tau_i + b tau_i / 3) / U_i (each octave counts
once; no fitted value enters the choice).  A linear programme in two unknowns:
its optimum is a vertex of the feasible region, found here by enumerating the
vertices (intersections of two constraints, or of one with an axis), exactly.
The optimum touches the limit at one or two taus, where it is tight.
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

HORIZON_S = 100.0
"""Default horizon (s), or a tenth of the record when that is shorter: the
octave points beyond a tenth of the record have few degrees of freedom."""
HORIZON_FRACTION = 0.1
PAIR_TERMS = ("N", "K")


def default_horizon(duration_s: Optional[float]) -> float:
    return min(HORIZON_S, HORIZON_FRACTION * duration_s) if duration_s else HORIZON_S


def overbound_pair(tau: np.ndarray, upper: np.ndarray) -> tuple[float, float]:
    """(a, b) = (N^2, K^2) of the smallest pair with a / tau + b tau / 3 >= upper at
    every point (module docstring): the vertex of least sum of ratios."""
    tau = np.asarray(tau, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    if tau.size == 0:
        raise ValueError("no point to over-bound")
    ca, cb = 1.0 / tau, tau / 3.0  # constraint i: ca_i a + cb_i b >= upper_i
    cands = [(float(np.max(upper / ca)), 0.0), (0.0, float(np.max(upper / cb)))]
    for i in range(tau.size):
        for j in range(i + 1, tau.size):
            det = ca[i] * cb[j] - ca[j] * cb[i]
            if det != 0.0:
                a = (upper[i] * cb[j] - upper[j] * cb[i]) / det
                b = (ca[i] * upper[j] - ca[j] * upper[i]) / det
                if a >= 0.0 and b >= 0.0:
                    cands.append((float(a), float(b)))
    wa, wb = float(np.sum(ca / upper)), float(np.sum(cb / upper))
    best: Optional[tuple[float, float]] = None
    for a, b in cands:
        worst = float(np.min((ca * a + cb * b) / upper))
        if worst < 1.0 - 1e-9:
            continue
        if best is None or wa * a + wb * b < wa * best[0] + wb * best[1]:
            best = (a, b)
    assert best is not None  # the axis vertices are always feasible
    a, b = best
    short = float(np.min((ca * a + cb * b) / upper))
    if short < 1.0:  # rounding in the intersection: scale up onto the limit
        a, b = a / short, b / short
    return a, b


def pair_adev(tau: np.ndarray, n: float, k: float) -> np.ndarray:
    """Allan deviation of white noise N plus random walk K."""
    tau = np.asarray(tau, dtype=np.float64)
    return np.sqrt(n * n / tau + k * k * tau / 3.0)


def channel_overbound(ch: dict[str, Any], fs: float, horizon: float) -> Optional[dict[str, Any]]:
    """The ``overbound`` object of one channel of ``analyze``'s document, in the
    channel's units, from its fit's octave points (deviation, upper 95 % limit)."""
    pts = [
        p
        for p in (ch.get("fit") or {}).get("octave_points") or []
        if p.get("high") is not None and p["high"] > 0 and 1.0 / fs * (1 - 1e-9) <= p["tau_s"] <= horizon * (1 + 1e-9)
    ]
    if not pts:
        return None
    tau = np.array([p["tau_s"] for p in pts])
    upper = np.array([p["high"] for p in pts]) ** 2
    a, b = overbound_pair(tau, upper)
    n, k = math.sqrt(a), math.sqrt(b)
    ratio = pair_adev(tau, n, k) / np.sqrt(upper)
    touches = [float(t) for t, r in zip(tau, ratio) if r <= 1.0 + 1e-6]
    terms = ch.get("terms") or {}
    infl = {}
    for name, v in (("N", n), ("K", k)):
        t = terms.get(name)
        infl[name] = v / t["value"] if t and t.get("value") else None
    return {
        "N": n,
        "K": k,
        "horizon_s": horizon,
        "inflation_N": infl["N"],
        "inflation_K": infl["K"],
        "tau_max_s": float(tau.max()),
        "touches_s": touches,
        "why": _why(terms, n, k, infl, horizon, touches),
    }


def _why(
    terms: dict[str, Any], n: float, k: float, infl: dict[str, Optional[float]], horizon: float, touches: list[float]
) -> str:
    """One sentence: what the pair covers that the fitted N and K do not, and where it is tight."""
    others = []
    for name, t in terms.items():
        if name in PAIR_TERMS or name == "LP" or not t or not t.get("tau_range_s"):  # LP lowers the curve
            continue
        lo, hi = t["tau_range_s"]
        if lo <= horizon:
            label = {"B": "bias instability B", "Q": "quantization Q", "R": "rate ramp R"}
            what = label.get(name, {"SIN": "an oscillation", "RES": "a resonance"}.get(name, f"Gauss-Markov {name}"))
            others.append(f"{what} ({lo:.3g}-{min(hi, horizon):.3g} s)")
    factors = " and ".join(f"{name} x{f:.3g}" if f is not None else f"{name} (not fitted)" for name, f in infl.items())
    cover = (
        "it must also cover " + ", ".join(others) + f" to the {horizon:.3g} s horizon"
        if others
        else f"no other term to the {horizon:.3g} s horizon: it covers the points' 95 % upper limits only"
    )
    where = ", ".join(f"{t:.3g} s" for t in touches)
    return f"{factors} over the fit: {cover}; it touches the 95 % upper limit at {where}"


def add_to_doc(doc: dict[str, Any], horizon: Optional[float] = None) -> None:
    """Adds ``overbound`` to every channel of ``analyze``'s document (and its SI
    version to the channel's ``si``): --horizon, or the default."""
    fs = (doc.get("source") or {}).get("fs_hz")
    duration = (doc.get("source") or {}).get("duration_s")
    if not fs:
        return
    h = horizon if horizon is not None else default_horizon(duration)
    for ch in doc.get("channels", {}).values():
        ob = channel_overbound(ch, fs, h)
        ch["overbound"] = ob
        if "si" in ch:
            f = math.pi / 180.0 if ch.get("unit") == "deg/s" else 1.0
            ch["si"]["overbound"] = (
                None
                if ob is None
                else {**{k: ob[k] for k in ob if k not in ("N", "K")}, "N": ob["N"] * f, "K": ob["K"] * f}
            )


def analysis_text(doc: dict[str, Any]) -> str:
    """The block of ``analyze``'s text: per channel the pair, its factors over the fit and why."""
    lines = []
    for name, ch in doc.get("channels", {}).items():
        ob = ch.get("overbound")
        if not ob:
            continue
        units = ch.get("term_units") or {}
        pair = []
        for k in PAIR_TERMS:
            f = ob[f"inflation_{k}"]
            pair.append(f"{k} {ob[k]:.4g} {units.get(k, '')} ({f'x{f:.3g} the fit' if f else 'not in the fit'})")
        lines.append(f"  {name}: " + ", ".join(pair))
        lines += ["      " + part for part in ob["why"].split(" over the fit: ", 1)[-1].split("; ")]
    if not lines:
        return ""
    head = (
        "Over-bounding white noise + random walk pair (the smallest whose ADEV covers the curve's\n"
        "95 % upper limit to the horizon; --noise overbound puts it in --kalibr, --openvins, --vins):"
    )
    return "\n".join([head] + lines) + "\n"
