"""PNG figures of an analysis document, in the manner of the published ADIS
and IEEE 952 plots: per sensor (accelerometers, gyros) one figure, one log-log
panel per axis, the Allan deviation with its 95 % intervals, the fitted terms'
lines drawn only over the taus the data cover, the device's points and the
thesis model; and the PSD with the terms' levels.  Each figure has one legend,
below its panels, in plain words with every axis' value."""

from __future__ import annotations

import math
import os
import sys
from typing import Any

import numpy as np

from ..errors import InputError
from ..noise.terms import B_READOFF, TERMS, basis
from ..profiles import LITERATURE
from .answer import num
from .text import NAMES

COLORS = {"Q": "tab:purple", "N": "tab:blue", "B": "tab:green", "K": "tab:orange", "R": "tab:red"}
PLAIN = {
    "Q": "quantization",
    "N": "white noise",
    "B": "bias instability",
    "K": "rate random walk",
    "R": "rate ramp",
}
"""The terms as a reader of a datasheet names them (N is the angle or velocity random walk
that white rate noise makes)."""
SLOPE = {"Q": "-1", "N": "-1/2", "B": "0", "K": "+1/2", "R": "+1"}
PLAIN_GROUP = {"accelerometer": "accelerometers", "gyroscope": "gyroscopes"}
DPI = 130
MIN_EDF_BAND = 3.0
"""Points with fewer degrees of freedom are drawn without their interval (on a log grid
the last points reach EDF 1, whose 95 % interval spans a factor of 30 in deviation)."""
PSD_LEVEL = {
    "Q": "8 Q^2 fs sin^2(pi f/fs)",
    "N": "2 N^2",
    "B": "B^2/(pi f)",
    "K": "K^2/(2 pi^2 f^2)",
    "R": "R^2/(4 pi^3 f^3)",
}


def _mpl() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def pyplot_for(directory: str) -> Any:
    """matplotlib's pyplot (file output only) once ``directory`` exists; one line if
    it cannot be made.  Every command that writes figures starts here."""
    try:
        os.makedirs(directory, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create '{directory}': {exc.strerror or exc}") from None
    return _mpl()


def _groups(doc: dict[str, Any]) -> list[tuple[str, list[str]]]:
    chans = list(doc["channels"])
    out = []
    for name, axes in (("accelerometer", ("ax", "ay", "az")), ("gyroscope", ("gx", "gy", "gz"))):
        sel = [c for c in axes if c in chans]
        if sel:
            out.append((name, sel))
    return out


def _coef(c: dict[str, Any]) -> np.ndarray:
    return np.array([(c["terms"][k]["value"] if c["terms"][k] else 0.0) ** 2 for k in TERMS])


def write_plots(doc: dict[str, Any], directory: str) -> list[str]:
    plt = pyplot_for(directory)
    files = []
    for group, chans in _groups(doc):
        files.append(_adev_figure(plt, doc, group, chans, directory))
        if any("psd" in doc["channels"][c] for c in chans):
            files.append(_psd_figure(plt, doc, group, chans, directory))
        else:
            why = (
                "a device log carries results, not samples"
                if doc["source"]["kind"] == "device-log"
                else "no PSD was computed"
            )
            print(f"imu-allan analyze: {group} PSD plot skipped: {why}", file=sys.stderr)
    return files


def _save(plt: Any, fig: Any, path: str) -> str:
    try:
        fig.savefig(path, dpi=DPI)
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
    finally:
        plt.close(fig)
    return path


class FigureLegend:
    """The one legend of a figure: each kind of line once, its label in plain words
    with every panel's value ("white noise N = 5.26 (gx), 3.9 (gy) deg/sqrt(h)"),
    drawn below the panels, outside the data."""

    def __init__(self, panels: int) -> None:
        self.panels = panels
        self.handles: dict[str, Any] = {}
        self.words: dict[str, str] = {}
        self.values: dict[str, list[tuple[str, str]]] = {}

    def add(self, key: str, handle: Any, words: str, channel: str = "", value: str = "", note: str = "") -> None:
        """A line of ``key``'s kind (the first one drawn stands for all) with one axis'
        value, and a word on it (``note``) put after the axis' name."""
        if key not in self.handles:
            self.handles[key], self.words[key], self.values[key] = handle, words, []
        if value:
            self.values[key].append((channel + (f", {note}" if note else ""), value))

    def labels(self) -> list[str]:
        out = []
        for key, words in self.words.items():
            vals = self.values[key]
            if not vals:
                out.append(words)
            elif len(vals) == 1 and self.panels == 1:
                out.append(words.format(v=vals[0][1]))
            else:
                out.append(words.format(v=", ".join(f"{v} ({ch})" for ch, v in vals)))
        return out

    def draw(self, fig: Any, panel_height_in: float) -> Any:
        """Below the panels: the figure grows by the legend's height, the panels keep theirs."""
        labels = self.labels()
        ncol = 2 if len(labels) > 3 else 1
        rows = math.ceil(len(labels) / ncol)
        legend_in = 0.25 + 0.2 * rows
        w, _ = fig.get_size_inches()
        fig.set_size_inches(w, panel_height_in + legend_in)
        bottom = legend_in / (panel_height_in + legend_in)
        fig.tight_layout(rect=(0, bottom, 1, 0.95))
        return fig.legend(
            list(self.handles.values()),
            labels,
            loc="upper center",
            bbox_to_anchor=(0.5, bottom),
            ncol=ncol,
            fontsize=7.5,
            frameon=False,
        )


def term_words(c: dict[str, Any], k: str) -> tuple[str, str, str]:
    """A fitted line's words (``{v}`` for the values), this channel's value, and a
    word on it (N through a low-pass)."""
    t = c["terms"][k]
    if k in NAMES:
        unit, f = LITERATURE[c["kind"]][k]
        words = f"{PLAIN[k]} {k} = {{v}} {unit}, slope {SLOPE[k]}"
        if k == "B":
            words = f"{PLAIN[k]} {k} = {{v}} {unit}, flat at {B_READOFF:.3f} B"
        lp = c["terms"].get("LP") if k == "N" else None
        return words, num(t["value"] * f), f"through a {num(lp['fc'])} Hz low-pass" if lp else ""
    if k.startswith("GM"):
        return "Gauss-Markov: sigma, correlation time = {v}", f"{num(t['value'])} {c['unit']}, {num(t['tau_c'])} s", ""
    if k == "SIN":
        return "oscillation at {v}", f"{num(t['f0_hz'])} Hz", ""
    if k == "RES":
        return "resonance at {v}", f"{num(t['f0_hz'])} Hz", ""
    return k, "", ""


def _data_range(tau: np.ndarray, ok: np.ndarray) -> tuple[float, float]:
    """The taus the data support: from the shortest to the longest point drawn."""
    t = tau[ok] if ok.any() else tau
    return float(t.min()), float(t.max())


def _within(x: np.ndarray, rng: tuple[float, float]) -> np.ndarray:
    return (x >= rng[0] * (1 - 1e-9)) & (x <= rng[1] * (1 + 1e-9))


def _adev_figure(plt: Any, doc: dict[str, Any], group: str, chans: list[str], directory: str) -> str:
    height = 4.4
    fig, axes = plt.subplots(1, len(chans), figsize=(4.6 * len(chans), height), squeeze=False)
    src = doc["source"]
    legend = FigureLegend(len(chans))
    for ax, ch in zip(axes[0], chans):
        _adev_panel(ax, doc, ch, legend)
    fig.suptitle(
        f"{PLAIN_GROUP[group]}: Allan deviation (IEEE 952) of {os.path.basename(src['file'])}, "
        f"{src['n']} samples at {src['fs_hz']:g} Hz"
    )
    legend.draw(fig, height)
    return _save(plt, fig, os.path.join(directory, f"adev_{group}.png"))


def _adev_panel(ax: Any, doc: dict[str, Any], ch: str, legend: FigureLegend) -> None:
    """One axis' curve, its intervals, the device's points, and the fitted lines over
    the taus of the data only."""
    c = doc["channels"][ch]
    pts = [p for p in c["curve"] if p["dev"]]
    if not pts:  # a constant (stuck) channel: nothing to draw on log axes
        _empty(ax, ch, "constant channel:\nAllan deviation 0 at every tau")
        return
    tau = np.array([p["tau_s"] for p in pts])
    dev = np.array([p["dev"] for p in pts])
    lo, hi = np.array([p["low"] for p in pts]), np.array([p["high"] for p in pts])
    ok = ~np.array([bool(p.get("flags")) for p in pts], dtype=bool)
    edf = np.array([p["edf"] if p.get("edf") is not None else 0.0 for p in pts])
    band = ok & (edf >= MIN_EDF_BAND)
    rng = _data_range(tau, ok)
    _data_artists(ax, doc, c, legend, (tau, dev, lo, hi, ok, band))
    comp = c["fit"].get("components")
    if comp and comp.get("adev"):
        _components(ax, ch, c, comp, legend, (tau, dev, ok), rng)
    else:
        _term_lines(ax, ch, c, legend, rng)
    m = c.get("model")
    if m and m.get("curve"):
        mt = np.array([p["tau_s"] for p in m["curve"]])
        md = np.array([p["dev"] for p in m["curve"]])
        keep = _within(mt, rng)
        (h,) = ax.loglog(mt[keep], md[keep], ":", color="0.35", lw=1.5)
        fp = m["fit_percent"].get("adev_log10")
        legend.add(
            "model", h, "thesis model, simulated from the terms (ADEV FIT% {v})", ch, "-" if fp is None else f"{fp:.1f}"
        )
    ax.set_xlabel("tau [s]")
    ax.set_ylabel(f"Allan deviation [{c['unit']}]")
    ax.set_title(ch)
    ax.grid(True, which="both", alpha=0.3)


def _data_artists(ax: Any, doc: dict[str, Any], c: dict[str, Any], legend: FigureLegend, arrays: tuple) -> None:
    tau, dev, lo, hi, ok, band = arrays
    for r in c["fit"].get("unexplained", []):
        a, b = r["tau_s"]
        h = ax.axvspan(a / 1.19, b * 1.19, color="tab:red", alpha=0.12, lw=0)
        legend.add("unexplained", h, "not explained by the terms (left out of the fit)")
    stat = (
        "the device's non-overlapping Allan deviation"
        if doc["source"]["kind"] == "device-log"
        else "overlapping Allan deviation"
    )
    band_h = ax.fill_between(tau[band], lo[band], hi[band], color="0.85")
    (h,) = ax.loglog(tau[ok], dev[ok], "o-", color="k", ms=3.5, lw=1)
    legend.add("data", h, stat)
    legend.add("interval", band_h, "its 95 % interval")
    few = ok & ~band
    if few.any():
        (h,) = ax.loglog(tau[few], dev[few], "o", mfc="white", color="k", ms=3.5)
        legend.add("few", h, f"fewer than {MIN_EDF_BAND:g} degrees of freedom (interval not drawn)")
    if band.any():  # limits from the drawn intervals, not stretched by EDF-1 points
        top = max(float(np.max(hi[band])), float(np.max(dev[ok])))
        bottom = min(float(np.min(lo[band])), float(np.min(dev[ok])))
        ax.set_ylim(bottom / 1.5, top * 1.5)
    if (~ok).any():
        (h,) = ax.loglog(tau[~ok], dev[~ok], "x", color="red", ms=7)
        legend.add("flagged", h, "flagged by the device (not fitted)")
    dv = c.get("device")
    if dv:
        dp = [p for p in dv["curve"] if p["dev"]]
        err = np.array([[p["dev"] - p["low"] for p in dp], [p["high"] - p["dev"] for p in dp]])
        h = ax.errorbar(
            [p["tau_s"] for p in dp],
            [p["dev"] for p in dp],
            yerr=err,
            fmt="s",
            mfc="none",
            color="tab:brown",
            ms=5,
            capsize=2,
        )
        legend.add("device", h, "the device's points (non-overlapping, 95 % interval)")


def _term_lines(ax: Any, ch: str, c: dict[str, Any], legend: FigureLegend, rng: tuple[float, float]) -> None:
    """The five IEEE 952 terms' lines (a fit without whole-curve components)."""
    coef = _coef(c)
    if not coef.any():
        return
    grid = np.exp(np.linspace(math.log(rng[0]), math.log(rng[1]), 200))
    A = basis(grid)
    total = A @ coef
    (h,) = ax.loglog(grid, np.sqrt(total), color="tab:cyan", lw=2, alpha=0.8)
    legend.add("fit", h, "fitted model (the sum of the terms)")
    for j, k in enumerate(TERMS):
        if coef[j] > 0:
            line = np.sqrt(A[:, j] * coef[j])
            line[A[:, j] * coef[j] < total / 100.0] = np.nan  # only where it matters (> 1/10 in ADEV)
            (h,) = ax.loglog(grid, line, "--", color=COLORS[k], lw=1.2)
            words, value, note = term_words(c, k)
            legend.add(k, h, words, ch, value, note)


COMPONENT_COLORS = {"LP": "tab:blue", "SIN": "tab:olive"}


def _components(
    ax: Any, ch: str, c: dict[str, Any], comp: dict[str, Any], legend: FigureLegend, data: tuple, rng: tuple
) -> None:
    """Each fitted process of the whole-curve fit as its own line under the curve, over
    the data's taus only, and a residual panel (curve / model) below the axes."""
    tau, dev, ok = data
    grid = np.array(comp["tau_s"], dtype=np.float64)
    total = np.array(comp["total_adev"], dtype=np.float64)
    keep = _within(grid, rng)
    (h,) = ax.loglog(grid[keep], total[keep], color="tab:cyan", lw=2, alpha=0.8)
    legend.add("fit", h, "fitted model (the sum of the terms)")
    for k, line in comp["adev"].items():
        v = np.array(line, dtype=np.float64)
        v[v < total / 10.0] = np.nan  # only where it matters (> 1/10 of the model's deviation)
        color = COLORS.get(k, COMPONENT_COLORS.get(k, "tab:gray" if k.startswith("GM") else "tab:pink"))
        (h,) = ax.loglog(grid[keep], v[keep], "--", color=color, lw=1.2)
        if c["terms"].get(k):
            words, value, note = term_words(c, k)
            legend.add("GM" if k.startswith("GM") else k, h, words, ch, value, note)
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    rax = make_axes_locatable(ax).append_axes("bottom", size="22%", pad=0.08, sharex=ax)
    sel = ok & _within(tau, (grid[0], grid[-1]))
    model = np.exp(np.interp(np.log(tau[sel]), np.log(grid), np.log(total)))
    rax.semilogx(tau[sel], dev[sel] / model, "o-", color="k", ms=2.5, lw=0.8)
    rax.axhline(1.0, color="tab:cyan", lw=1)
    rax.set_ylabel("curve/model", fontsize=7)
    rax.tick_params(labelsize=7)
    rax.grid(True, which="both", alpha=0.3)
    ax.tick_params(labelbottom=False)
    ax.set_xlabel("")
    rax.set_xlabel("tau [s]")


def _empty(ax: Any, ch: str, why: str) -> None:
    ax.text(0.5, 0.5, why, ha="center", va="center", transform=ax.transAxes)
    ax.set_title(ch)
    ax.set_xticks([])
    ax.set_yticks([])


def _psd_figure(plt: Any, doc: dict[str, Any], group: str, chans: list[str], directory: str) -> str:
    height = 4.2
    fig, axes = plt.subplots(1, len(chans), figsize=(4.6 * len(chans), height), squeeze=False)
    legend = FigureLegend(len(chans))
    for ax, ch in zip(axes[0], chans):
        _psd_panel(ax, doc, ch, legend)
    src = doc["source"]
    fig.suptitle(
        f"{PLAIN_GROUP[group]}: power spectral density (one-sided, Welch) of "
        f"{os.path.basename(src['file'])}, {src['n']} samples at {src['fs_hz']:g} Hz"
    )
    legend.draw(fig, height)
    return _save(plt, fig, os.path.join(directory, f"psd_{group}.png"))


def _psd_panel(ax: Any, doc: dict[str, Any], ch: str, legend: FigureLegend) -> None:
    c = doc["channels"][ch]
    p = c.get("psd")
    if not p or not p["f_hz"]:
        ax.set_visible(False)
        return
    f = np.array(p["f_hz"])
    data = np.array(p["psd"], dtype=float)
    if not np.any(data > 0):  # a constant channel
        _empty(ax, ch, "constant channel:\nPSD 0 at every frequency")
        return
    (h,) = ax.loglog(f, data, color="k", lw=1)
    legend.add("data", h, "PSD (Welch)")
    m = c.get("model")
    if m and m.get("psd"):
        fp = m["fit_percent"].get("psd_log10")
        (h,) = ax.loglog(f, np.array(m["psd"], dtype=float), ":", color="0.35", lw=1.5)
        legend.add("model", h, "thesis model (PSD FIT% {v})", ch, "-" if fp is None else f"{fp:.1f}")
    floor = np.nanmin(data[data > 0]) / 10.0
    for k, vals in p["terms"].items():
        v = np.array(vals, dtype=float)
        v[v < floor] = np.nan
        (h,) = ax.loglog(f, v, "--", color=COLORS[k], lw=1.2)
        if c["terms"].get(k):
            words, value, note = term_words(c, k)
            legend.add(k, h, f"{words.split(', slope')[0].split(', flat')[0]}; PSD {PSD_LEVEL[k]}", ch, value, note)
    ax.set_xlabel("f [Hz]")
    ax.set_ylabel(f"PSD [{p['unit']}]")
    ax.set_title(ch)
    ax.grid(True, which="both", alpha=0.3)


# ---- the sweep's and the thermal study's figures --------------------------------------------------

SWEEP_PLOTTED = ("N", "N_tau0", "B", "K", "sigma_sensor", "sigma_BIAS")


def sweep_plot(doc: dict[str, Any], directory: str) -> str:
    """terms-vs-fs.png of a sweep document (analysis/sweep.py): one panel per
    quantity, one series per channel, the fitted power laws."""
    from ..analysis.sweep import quantity

    plt = pyplot_for(directory)
    keys = list(doc["rates"])
    fig, axes = plt.subplots(2, 3, figsize=(14, 8))
    for ax, q in zip(axes.flat, SWEEP_PLOTTED):
        for i, ch in enumerate(doc["dependence"]):
            pts = [(float(k), quantity(doc["rates"][k], ch, q)) for k in keys]
            pts = [(f, v) for f, v in pts if v and v.get("value")]
            if not pts:
                continue
            f = np.array([p[0] for p in pts])
            v = np.array([p[1]["value"] for p in pts])
            lo = np.array([p[1].get("low") or p[1]["value"] for p in pts])
            hi = np.array([p[1].get("high") or p[1]["value"] for p in pts])
            color = f"C{i}"
            ax.errorbar(f, v, yerr=[v - lo, hi - v], fmt="o", color=color, ms=4, capsize=2, label=ch)
            fit = doc["dependence"][ch].get(q)
            if fit and len(pts) > 1:
                c = np.exp(np.mean(np.log(v) - fit["exponent"] * np.log(f)))
                ff = np.geomspace(f.min(), f.max(), 20)
                ax.plot(ff, c * ff ** fit["exponent"], "-", color=color, lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(q)
        ax.set_xlabel("Fs, Hz")
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle(
        f"imu-allan sweep ({doc['source']}, {doc['seconds']:g} s per rate, "
        f"{doc['profile']} units): terms against the sample rate"
    )
    fig.tight_layout()
    path = os.path.join(directory, "terms-vs-fs.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def thermal_plot(doc: dict[str, Any], directory: str) -> str:
    """thermal.png of a thermal document (analysis/thermal.py): each channel's
    Allan deviation before and after its thermal bias is removed."""
    plt = pyplot_for(directory)
    fig, axes = plt.subplots(2, 3, figsize=(14, 8))
    for ax, (ch, c) in zip(axes.flat, doc["channels"].items()):
        for key, label in (("adev_before", "raw"), ("adev_after", "thermal bias removed")):
            pts = [p for p in c[key] if p["dev"]]
            ax.loglog([p["tau_s"] for p in pts], [p["dev"] for p in pts], "o-", ms=3, label=label)
        ax.set_title(f"{ch}: tempco {c['tempco']['value']:.3g} {c['tempco']['unit']}")
        ax.set_xlabel("tau, s")
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle(f"imu-allan thermal: {os.path.basename(doc['file'])}")
    fig.tight_layout()
    path = os.path.join(directory, "thermal.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
