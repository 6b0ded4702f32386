"""The document of ``imu-allan dynamic`` and its text, CSV and heat-map renderings.

JSON contract (docs/dynamic.md; keys may be added, none renamed):
``{"windows": [{"t0_s", "t1_s", "temp", "adev": {ch: [...]}, "taus_s": [...],
"departs": {ch: bool}, ...}], "warmup_s": {ch: number or null}, ...}``.
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from ..analysis.dynamic import MIN_EFFECT, WARMUP_SHARE, Verdict, Windows, temperature_bins
from ..analysis.windows import adev_list as _devs
from ..analysis.windows import json_num as _num
from ..stats.edf import chi2_interval


def build_doc(ws: Windows, v: Verdict, name: str, tool: str, notes: list[str]) -> dict[str, Any]:
    """The ``dynamic --json`` document."""
    taus = [float(t) for t in ws.taus]
    windows = [_window(ws, v, w, taus) for w in range(len(ws.t0))]
    bins = [
        {
            "temp": b["temp"],
            "windows": b["windows"],
            "adev": {ch: _devs(b["var"][c]) for c, ch in enumerate(ws.channels)},
        }
        for b in temperature_bins(ws)
    ]
    return {
        "tool": tool,
        "source": _source(ws, name, len(windows)),
        "test": _test(ws, v),
        "taus_s": taus,
        "whole": {"adev": {ch: _devs(ws.whole[c]) for c, ch in enumerate(ws.channels)}},
        "windows": windows,
        "warmup_s": dict(v.warmup_s),
        "warmup_fit": {ch: _fit(v.transient.get(ch)) for ch in ws.channels},
        "stationary": {
            ch: {
                "stationary": v.stationary[ch],
                "departing_windows": int(v.departs[:, c].sum()),
                "tau_range_s": list(v.tau_range_s[ch]) if v.tau_range_s[ch] else None,
            }
            for c, ch in enumerate(ws.channels)
        },
        "temp_bins": bins,
        "notes": notes + list(ws.notes),
    }


def _fit(f: Any) -> Optional[dict[str, Any]]:
    """How a warm-up's end was found (analysis/transient.py): the fitted shape,
    the amplitude's time constant, where it stops, where the departing windows
    alone end."""
    if f is None:
        return None
    return {"shape": f.shape, "decay_s": f.decay_s, "stop_s": f.stop_s, "stretch_s": f.stretch_s}


def _window(ws: Windows, v: Verdict, w: int, taus: list[float]) -> dict[str, Any]:
    """One window of the document: its span, temperature, and per channel its
    deviations with intervals, EDFs, p-values and whether it departs."""
    t = ws.temp[w]
    item: dict[str, Any] = {
        "t0_s": float(ws.t0[w]),
        "t1_s": float(ws.t1[w]),
        "temp": t["mean"] if t else None,
        "temp_range": [t["min"], t["max"]] if t else None,
        "taus_s": taus,
        "adev": {},
        "low": {},
        "high": {},
        "edf": {},
        "p": {},
        "departs": {},
        "departs_at": {},
        "p_min": {},
    }
    for c, ch in enumerate(ws.channels):
        low, high = chi2_interval(ws.var[w, c], ws.edf[w, c], v.level)
        item["adev"][ch] = _devs(ws.var[w, c])
        item["low"][ch], item["high"][ch] = _devs(low), _devs(high)
        item["edf"][ch] = [_num(e) for e in ws.edf[w, c]]
        item["p"][ch] = [_num(p) for p in v.p[w, c]]
        item["departs"][ch] = bool(v.departs[w, c])
        item["departs_at"][ch] = [bool(h) for h in v.hit[w, c]]
        item["p_min"][ch] = _num(np.nanmin(v.p[w, c])) if np.isfinite(v.p[w, c]).any() else None
    if ws.pairs is not None:
        item["pairs"] = {ch: [int(p) for p in ws.pairs[w, c]] for c, ch in enumerate(ws.channels)}
    return item


def _source(ws: Windows, name: str, windows: int) -> dict[str, Any]:
    return {
        "file": name,
        "kind": ws.source,
        "fs_hz": ws.fs,
        "duration_s": float(ws.t1.max()) if len(ws.t1) else 0.0,
        "windows": windows,
        "window_overlap": ws.overlap,
        "estimator": (
            "non-overlapping (the device's exact sums, report minus report)"
            if ws.source == "device reports"
            else "overlapping, sliding windows"
        ),
    }


def _test(ws: Windows, v: Verdict) -> dict[str, Any]:
    """How a window is said to depart, in words, with its levels."""
    return {
        "level": v.level,
        "method": (
            "each window's variance at each tau against the pooled variance of the "
            "windows that do not depart (none overlapping it): F test with "
            "Greenhall's EDFs, two-sided; a window departs when a tau's p-value is "
            "below the per-point level, Sidak-corrected over every window and tau "
            f"tested and its deviation differs by more than {MIN_EFFECT:.0%}; the first "
            "window also alone, one-sided (a warm-up adds variance), Sidak over its "
            f"taus, at {WARMUP_SHARE:.0%} of the budget, the other test at the rest: a "
            f"stationary channel is flagged with probability at most {1 - v.level:.2g}"
        ),
        "min_effect": MIN_EFFECT,
        "per_point_level": {ch: float(v.threshold[c]) for c, ch in enumerate(ws.channels)},
        "first_window_level": {
            ch: (_num(v.lead_threshold[c]) if v.lead_threshold is not None else None)
            for c, ch in enumerate(ws.channels)
        },
    }


def _fmt_s(s: Optional[float]) -> str:
    if s is None:
        return "-"
    if s >= 7200:
        return f"{s / 3600:.1f} h"
    if s >= 120:
        return f"{s / 60:.0f} min"
    return f"{s:.0f} s"


def verdict_lines(doc: dict[str, Any]) -> list[str]:
    """Per channel: warm-up, and stationary or not (with the taus affected)."""
    out = []
    for ch, st in doc["stationary"].items():
        warm = doc["warmup_s"][ch]
        text = f"  {ch}: "
        text += f"warm-up {_fmt_s(warm)} ({warm:.0f} s)" if warm is not None else "no warm-up"
        if st["stationary"]:
            text += "; stationary after it" if warm is not None else "; stationary"
        else:
            tr = st["tau_range_s"]
            taus = f" at tau {tr[0]:.3g}-{tr[1]:.3g} s" if tr else ""
            text += f"; NOT stationary: {st['departing_windows']} of {doc['source']['windows']} windows depart{taus}"
        out.append(text)
        fit = (doc.get("warmup_fit") or {}).get(ch)
        if warm is not None and fit:  # the windows alone depart less long than a weak transient lasts
            out.append(f"    (windows alone depart to {fit['stretch_s']:.0f} s; fitted transient: {fit['shape']})")
    return out


def text(doc: dict[str, Any]) -> str:
    src, test = doc["source"], doc["test"]
    lines = [
        f"{doc['tool']}: {src['file']}",
        f"{src['windows']} windows from {src['kind']} ({src['estimator']}), "
        f"{_fmt_s(src['duration_s'])} at {src['fs_hz']:g} Hz",
        f"test: a window departs when its deviation at some tau lies beyond its interval "
        f"against the rest (F test, {test['level']:.0%} confidence per channel over all "
        f"windows and taus)",
        "",
    ]
    lines += ["warm-up and stationarity:"] + verdict_lines(doc) + [""]
    chans = list(doc["warmup_s"])
    lines.append("window          temp   departs    ADEV / whole record at the most departing tau")
    for w in doc["windows"]:
        t = f"{w['temp']:.1f}" if w["temp"] is not None else "-"
        dep = [ch for ch in chans if w["departs"][ch]]
        worst = ""
        for ch in dep[:3]:
            p = [x if x is not None else 2.0 for x in w["p"][ch]]
            k = int(np.argmin(p))
            a, whole = w["adev"][ch][k], doc["whole"]["adev"][ch][k]
            if a is not None and whole:
                worst += f" {ch} {a / whole:.2f}x@{doc['taus_s'][k]:.3g}s"
        lines.append(f"{w['t0_s']:7.0f}-{w['t1_s']:<7.0f} {t:>5}  {' '.join(dep) or '-':<10}{worst}")
    for b in doc["temp_bins"]:
        lines.append(f"temperature {b['temp'][0]:g}-{b['temp'][1]:g} (codes): {b['windows']} windows")
    lines += [f"note: {n}" for n in doc["notes"]]
    return "\n".join(lines) + "\n"


CSV_HEAD = "t0_s,t1_s,temp,channel,tau_s,adev,low,high,edf,p,departs"


def csv(doc: dict[str, Any]) -> str:
    out = [CSV_HEAD]

    def f(v: Any) -> str:
        return "" if v is None else f"{v:.6g}"

    for w in doc["windows"]:
        for ch in doc["warmup_s"]:
            for k, tau in enumerate(w["taus_s"]):
                out.append(
                    ",".join(
                        [
                            f(w["t0_s"]),
                            f(w["t1_s"]),
                            f(w["temp"]),
                            ch,
                            f(tau),
                            f(w["adev"][ch][k]),
                            f(w["low"][ch][k]),
                            f(w["high"][ch][k]),
                            f(w["edf"][ch][k]),
                            f(w["p"][ch][k]),
                            str(int(w["departs"][ch])),
                        ]
                    )
                )
    return "\n".join(out) + "\n"


def plot(doc: dict[str, Any], path: str) -> str:
    """Heat map per channel: log2 of ADEV(window, tau) / ADEV(whole record, tau),
    points that depart crossed, the warm-up's end a vertical line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    chans = list(doc["warmup_s"])
    rows = math.ceil(len(chans) / 2)
    fig, axes = plt.subplots(rows, 2, figsize=(12, 3.2 * rows + 1.2), squeeze=False, sharex=True)
    taus = np.array(doc["taus_s"])
    t_edges = np.array([w["t0_s"] for w in doc["windows"]] + [doc["windows"][-1]["t1_s"]])
    if doc["source"]["window_overlap"] > 0:  # sliding windows: each drawn at its centre, one step wide
        mids = np.array([(w["t0_s"] + w["t1_s"]) / 2 for w in doc["windows"]])
        step = np.diff(mids).mean() if mids.size > 1 else 1.0
        t_edges = np.concatenate((mids - step / 2, [mids[-1] + step / 2]))
    tau_edges = np.concatenate((taus / math.sqrt(2), [taus[-1] * math.sqrt(2)]))
    norm = TwoSlopeNorm(vmin=-1.0, vcenter=0.0, vmax=1.0)
    mesh = None
    for i, ch in enumerate(chans):
        ax = axes[i // 2][i % 2]
        whole = np.array([np.nan if v is None else v for v in doc["whole"]["adev"][ch]])
        z = np.full((taus.size, len(doc["windows"])), np.nan)
        for w, win in enumerate(doc["windows"]):
            a = np.array([np.nan if v is None else v for v in win["adev"][ch]])
            with np.errstate(invalid="ignore", divide="ignore"):
                z[:, w] = np.log2(a / whole)
        mesh = ax.pcolormesh(t_edges, tau_edges, np.clip(z, -1, 1), cmap="RdBu_r", norm=norm, shading="flat")
        centres = (t_edges[:-1] + t_edges[1:]) / 2
        for w, win in enumerate(doc["windows"]):
            hit = [k for k, h in enumerate(win["departs_at"][ch]) if h]
            if hit:
                ax.plot([centres[w]] * len(hit), taus[hit], "kx", ms=5)
        warm = doc["warmup_s"][ch]
        if warm is not None:
            ax.axvline(warm, color="k", lw=1.5, ls="--")
            ax.text(warm, tau_edges[-1], f" warm-up ends {warm:.0f} s", va="top", fontsize=8)
        st = doc["stationary"][ch]
        state = "stationary" if st["stationary"] else "NOT stationary"
        ax.set_title(
            f"{ch}: {state}" + (" after the warm-up" if warm is not None and st["stationary"] else ""), fontsize=10
        )
        ax.set_yscale("log")
        ax.set_ylabel("tau (s)")
        if i // 2 == rows - 1:
            ax.set_xlabel("time since the start of the run (s)")
    for j in range(len(chans), rows * 2):
        axes[j // 2][j % 2].axis("off")
    fig.suptitle(
        f"Allan deviation in each window, relative to the whole record: {doc['source']['file']}\n"
        f"red: noisier than the whole record, blue: quieter; x: the window departs at that tau "
        f"beyond its interval ({doc['test']['level']:.0%} confidence over the record)",
        fontsize=10,
    )
    if mesh is not None:
        cb = fig.colorbar(mesh, ax=axes, shrink=0.8, ticks=[-1, -0.5, 0, 0.5, 1])
        cb.ax.set_yticklabels(["0.5x or less", "0.71x", "1x", "1.41x", "2x or more"])
        cb.set_label("ADEV(window) / ADEV(whole record)")
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
