"""PNG figures of an analysis document: Allan deviation with 95 % intervals,
fitted terms and their slopes, device points and the thesis model; and the
PSD with the terms' levels. One figure per sensor (accelerometers, gyros),
one panel per axis."""

from __future__ import annotations

import math
import os
import sys
from typing import Any

import numpy as np

from ..errors import InputError
from ..noise.terms import B_READOFF, TERMS, basis
from ..profiles import LITERATURE
from .text import NAMES

COLORS = {"Q": "tab:purple", "N": "tab:blue", "B": "tab:green", "K": "tab:orange", "R": "tab:red"}
SLOPE_LABEL = {"Q": "-1", "N": "-1/2", "B": "0", "K": "+1/2", "R": "+1"}
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
        fig.savefig(path, dpi=130)
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
    finally:
        plt.close(fig)
    return path


def _adev_figure(plt: Any, doc: dict[str, Any], group: str, chans: list[str], directory: str) -> str:
    fig, axes = plt.subplots(1, len(chans), figsize=(5.2 * len(chans), 4.6), squeeze=False)
    src = doc["source"]
    stat = "device non-overlapping ADEV" if src["kind"] == "device-log" else "overlapping ADEV"
    for ax, ch in zip(axes[0], chans):
        c = doc["channels"][ch]
        pts = [p for p in c["curve"] if p["dev"]]
        tau = np.array([p["tau_s"] for p in pts])
        dev = np.array([p["dev"] for p in pts])
        lo = np.array([p["low"] for p in pts])
        hi = np.array([p["high"] for p in pts])
        flagged = np.array([bool(p.get("flags")) for p in pts], dtype=bool)
        ok = ~flagged
        if not pts:  # a constant (stuck) channel: nothing to draw on log axes
            _empty(ax, ch, "constant channel:\nAllan deviation 0 at every tau")
            continue
        edf = np.array([p["edf"] if p.get("edf") is not None else 0.0 for p in pts])
        band = ok & (edf >= MIN_EDF_BAND)
        for r in c["fit"].get("unexplained", []):
            a, b = r["tau_s"]
            ax.axvspan(
                a / 1.19,
                b * 1.19,
                color="tab:red",
                alpha=0.12,
                lw=0,
                label="not explained by the terms (left out of the fit)" if r is c["fit"]["unexplained"][0] else None,
            )
        ax.fill_between(tau[band], lo[band], hi[band], color="0.85", label="95 % interval")
        ax.loglog(tau[ok], dev[ok], "o-", color="k", ms=3.5, lw=1, label=stat)
        few = ok & ~band
        if few.any():
            ax.loglog(
                tau[few],
                dev[few],
                "o",
                mfc="white",
                color="k",
                ms=3.5,
                label=f"EDF < {MIN_EDF_BAND:g} (interval not drawn)",
            )
        if band.any():  # limits from the drawn intervals, not stretched by EDF-1 points
            top = max(float(np.max(hi[band])), float(np.max(dev[ok])))
            bottom = min(float(np.min(lo[band])), float(np.min(dev[ok])))
            ax.set_ylim(bottom / 1.5, top * 1.5)
        if flagged.any():
            ax.loglog(tau[flagged], dev[flagged], "x", color="red", ms=7, label="flagged (not fitted)")
        dv = c.get("device")
        if dv:
            dp = [p for p in dv["curve"] if p["dev"]]
            dt = np.array([p["tau_s"] for p in dp])
            dd = np.array([p["dev"] for p in dp])
            err = np.array([[p["dev"] - p["low"] for p in dp], [p["high"] - p["dev"] for p in dp]])
            ax.errorbar(
                dt,
                dd,
                yerr=err,
                fmt="s",
                mfc="none",
                color="tab:brown",
                ms=5,
                capsize=2,
                label="device (non-overlapping)",
            )
        # the terms over the taus they were fitted on (not extrapolated, not over the ranges left out)
        win = c["fit"].get("tau_window_s") or ([float(tau.min()), float(tau.max())] if tau.size else None)
        grid = np.exp(np.linspace(math.log(win[0]), math.log(win[1]), 200)) if win else tau
        coef = _coef(c)
        comp = c["fit"].get("components")
        if tau.size and comp and comp.get("adev"):
            _components(ax, c, comp, tau, dev, ok)
        elif tau.size and coef.any():
            A = basis(grid)
            total = A @ coef
            ax.loglog(grid, np.sqrt(total), color="tab:cyan", lw=2, alpha=0.8, label="fitted model")
            lu_all = LITERATURE[c["kind"]]
            for j, k in enumerate(TERMS):
                if coef[j] > 0:
                    lu, lf = lu_all[k]
                    v = c["terms"][k]["value"]
                    line = np.sqrt(A[:, j] * coef[j])
                    line[A[:, j] * coef[j] < total / 100.0] = np.nan  # only where it matters (> 1/10 in ADEV)
                    label = f"{k} {NAMES[k]} (slope {SLOPE_LABEL[k]}): {v * lf:.3g} {lu}"
                    if k == "B":  # the flat line is the deviation B makes, not B
                        label = (
                            f"B {NAMES[k]}: {v * lf:.3g} {lu}; line at {B_READOFF:.3f} B = "
                            f"{v * B_READOFF:.3g} {c['unit']}"
                        )
                    ax.loglog(grid, line, "--", color=COLORS[k], lw=1.2, label=label)
        m = c.get("model")
        if m and m.get("curve"):
            fp = m["fit_percent"].get("adev_log10")
            ax.loglog(
                [p["tau_s"] for p in m["curve"]],
                [p["dev"] for p in m["curve"]],
                ":",
                color="0.35",
                lw=1.5,
                label="thesis model, simulated" + (f" (FIT {fp:.1f} %)" if fp is not None else ""),
            )
        ax.set_xlabel("tau [s]")
        ax.set_ylabel(f"Allan deviation [{c['unit']}]")
        ax.set_title(f"{ch}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6.5, loc="best")
    fig.suptitle(f"{group}: {os.path.basename(src['file'])}, {src['n']} samples at {src['fs_hz']:g} Hz")
    fig.tight_layout()
    return _save(plt, fig, os.path.join(directory, f"adev_{group}.png"))


COMPONENT_COLORS = {"LP": "tab:blue", "SIN": "tab:olive"}


def _components(
    ax: Any, c: dict[str, Any], comp: dict[str, Any], tau: np.ndarray, dev: np.ndarray, ok: np.ndarray
) -> None:
    """Each fitted process of the whole-curve fit as its own line under the curve, and a
    residual panel (curve / model) below the axes."""
    grid = np.array(comp["tau_s"], dtype=np.float64)
    total = np.array(comp["total_adev"], dtype=np.float64)
    ax.loglog(grid, total, color="tab:cyan", lw=2, alpha=0.8, label="fitted model")
    lu_all = LITERATURE[c["kind"]]
    for k, line in comp["adev"].items():
        v = np.array(line, dtype=np.float64)
        v[v < total / 10.0] = np.nan  # only where it matters (> 1/10 of the model's deviation)
        t = c["terms"].get(k)
        if k in NAMES and t:
            lu, lf = lu_all[k]
            label = f"{k} {NAMES[k]}: {t['value'] * lf:.3g} {lu}"
            if k == "B":  # the flat line is the deviation B makes, not B
                label = (
                    f"B {NAMES[k]}: {t['value'] * lf:.3g} {lu}; line at {B_READOFF:.3f} B = "
                    f"{t['value'] * B_READOFF:.3g} {c['unit']}"
                )
            if k == "N" and c["terms"].get("LP"):
                label += f" (through a {c['terms']['LP']['fc']:.3g} Hz low-pass)"
        elif k.startswith("GM") and t:
            label = f"{k} Gauss-Markov: sigma {t['value']:.3g} {c['unit']}, tau_c {t['tau_c']:.3g} s"
        elif k == "SIN" and t:
            label = f"oscillation {t['f0_hz']:.3g} Hz"
        else:
            label = k
        ax.loglog(grid, v, "--", color=COLORS.get(k, COMPONENT_COLORS.get(k, "tab:gray")), lw=1.2, label=label)
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    rax = make_axes_locatable(ax).append_axes("bottom", size="22%", pad=0.08, sharex=ax)
    sel = ok & (tau >= grid[0] * (1 - 1e-9)) & (tau <= grid[-1] * (1 + 1e-9))
    model = np.exp(np.interp(np.log(tau[sel]), np.log(grid), np.log(total)))
    rax.semilogx(tau[sel], dev[sel] / model, "o-", color="k", ms=2.5, lw=0.8)
    rax.axhline(1.0, color="tab:cyan", lw=1)
    rax.set_ylabel("curve/model", fontsize=7)
    rax.tick_params(labelsize=7)
    rax.grid(True, which="both", alpha=0.3)
    ax.tick_params(labelbottom=False)


def _empty(ax: Any, ch: str, why: str) -> None:
    ax.text(0.5, 0.5, why, ha="center", va="center", transform=ax.transAxes)
    ax.set_title(ch)
    ax.set_xticks([])
    ax.set_yticks([])


def _psd_figure(plt: Any, doc: dict[str, Any], group: str, chans: list[str], directory: str) -> str:
    fig, axes = plt.subplots(1, len(chans), figsize=(5.2 * len(chans), 4.4), squeeze=False)
    for ax, ch in zip(axes[0], chans):
        c = doc["channels"][ch]
        p = c.get("psd")
        if not p or not p["f_hz"]:
            ax.set_visible(False)
            continue
        f = np.array(p["f_hz"])
        if not np.any(np.array(p["psd"], dtype=float) > 0):  # a constant channel
            _empty(ax, ch, "constant channel:\nPSD 0 at every frequency")
            continue
        ax.loglog(f, np.array(p["psd"], dtype=float), color="k", lw=1, label="Welch PSD")
        m = c.get("model")
        if m and m.get("psd"):
            fp = m["fit_percent"].get("psd_log10")
            ax.loglog(
                f,
                np.array(m["psd"], dtype=float),
                ":",
                color="0.35",
                lw=1.5,
                label="thesis model" + (f" (FIT {fp:.1f} %)" if fp is not None else ""),
            )
        data = np.array(p["psd"], dtype=float)
        floor = np.nanmin(data[data > 0]) / 10.0 if np.any(data > 0) else 0.0
        for k, vals in p["terms"].items():
            v = np.array(vals, dtype=float)
            v[v < floor] = np.nan
            t = c["terms"].get(k)
            what = f"{k} level {PSD_LEVEL[k]}" + (f", {k} = {t['value']:.3g} {c['term_units'][k]}" if t else "")
            if k == "N" and t:
                what += f": {2 * t['value'] ** 2:.3g} {p['unit']}"
            ax.loglog(f, v, "--", color=COLORS[k], lw=1.2, label=what)
        ax.set_xlabel("f [Hz]")
        ax.set_ylabel(f"PSD [{p['unit']}]")
        ax.set_title(ch)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    src = doc["source"]
    fig.suptitle(
        f"{group}: {os.path.basename(src['file'])}, power spectral density (one-sided, Welch), "
        f"{src['n']} samples at {src['fs_hz']:g} Hz"
    )
    fig.tight_layout()
    return _save(plt, fig, os.path.join(directory, f"psd_{group}.png"))


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
