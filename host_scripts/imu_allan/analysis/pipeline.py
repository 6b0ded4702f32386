"""``imu-allan analyze``: from a source (samples and/or a device report) to the
analysis document (the ``--json`` contract; render/text.py prints it for people).

One streaming pass over the samples feeds the octave engine (overlapping and
non-overlapping AVAR, allan.py) and, for files too large to hold, the Welch
PSD. When the samples fit in memory (``memory_budget``), they are also kept
for the other tau grids, MDEV, HDEV, the PSD with pwelch's exact segments and
the thesis' signal FIT%. Then, per channel: the IEEE 952 fit (terms.py) on
the host's overlapping curve (or, for a device log alone, on the device's
non-overlapping one), 95 % chi-squared intervals on every point (EDF from
the dominant noise type, edf.py), the device's points and their agreement
with the host's curve, the PSD with the terms' levels, and the thesis' noise
model simulated from the terms with its FIT% (model.py).

All statistics are float64 in the input's units (ADC counts for codes) and
scaled to the channel's rate unit u at the end (variances times scale^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from .._version import __version__
from ..channels import CHANNELS, CODE_MAX
from ..device.records import DeviceReport, flag_names
from ..errors import InputError
from ..noise import terms
from ..noise.fit import fit_curve as fit_noise
from ..profiles import Profile, term_unit, to_si_rad
from ..sources.detect import Source
from ..stats import allan, edf, psd
from . import overbound
from .host_pass import Curve, HostPass, host_curves, host_pass
from .model_pass import model_all
from .outlier_pass import outliers_doc, outliers_json

LEVEL = 0.95


@dataclass
class Options:
    fs: Optional[float] = None
    taus: str = "octave"
    channels: Optional[list[str]] = None
    model: bool = True
    extra_curves: bool = True
    """MDEV and HDEV beside the Allan deviations (needs the samples in memory)."""
    seed: int = 1
    memory_budget: int = 256 << 20
    """Bytes of float64 samples kept in memory for the in-memory statistics."""
    keep_store: bool = False
    """Leave the samples' store open in the result (``Analysis.store``) for
    more work on the same samples (the warm-up windows); the caller closes it."""
    outliers: str = "replace"
    """Spikes and bursts (outliers.py): replace (interpolated, left out of the
    statistics) or keep (counted and listed only)."""
    horizon: Optional[float] = None
    """Longest tau (s) the over-bounding N + K pair covers (overbound.py; None: its default)."""


@dataclass
class Analysis:
    """The result of ``analyze``: the ``--json`` document (every float finite
    or None, ready for render/text.py) and each channel's fit of the noise terms."""

    doc: dict[str, Any]
    fits: dict[str, terms.FitResult]
    store: Any = None
    """The samples (store.py) when ``Options.keep_store``; ``close()`` frees them."""

    def close(self) -> None:
        if self.store is not None:
            self.store.close()
            self.store = None


def analyze(src: Source, profile: Profile, opts: Options, device: Optional[DeviceReport] = None) -> Analysis:
    """The analysis of ``src`` (samples and/or its device report)."""
    report = device if device is not None else src.report
    fs = _sample_rate(src, report, opts)
    notes: list[str] = list(src.notes) + list(profile.notes)
    samples = src.samples
    chans = _channels(samples.channels if samples is not None else list(CHANNELS), opts.channels)
    doc: dict[str, Any] = {
        "tool": f"imu-allan analyze {__version__}",
        "source": {
            "file": src.name,
            "kind": samples.kind if samples is not None else "device-log",
            "fs_hz": fs,
            "n": None,
            "duration_s": None,
            "device_header": _jsonable(report.header.as_dict()) if report is not None else None,
        },
        "profile": {
            "name": profile.name,
            "channels": {
                c: {
                    "unit": profile.scale(c).unit,
                    "per_count": profile.scale(c).per_count,
                    "source": profile.scale(c).source,
                }
                for c in chans
            },
        },
        "options": {"taus": opts.taus, "level": LEVEL, "model": opts.model, "seed": opts.seed},
        "channels": {},
        "notes": notes,
    }
    host = None
    if samples is not None:
        host = host_pass(samples, chans, fs, opts, notes)
        doc["source"]["n"] = host.n
        doc["source"]["duration_s"] = host.n / fs
        notes.extend(samples.notes)
    elif report is not None:
        doc["source"]["n"] = report.header.n
        doc["source"]["duration_s"] = report.header.n / fs
    fits: dict[str, terms.FitResult] = {}
    fit_curves: dict[str, list[tuple[int, float]]] = {}
    try:
        for c_i, ch in enumerate(chans):
            doc["channels"][ch], fits[ch], fit_curves[ch] = _channel(ch, c_i, profile, fs, host, report, opts, notes)
        for c_i, ch in enumerate(chans):  # after every fit: the PSD ran beside them (host_pass.welch_later)
            if host is not None:
                sc = profile.scale(ch)
                doc["channels"][ch]["psd"] = _psd_json(host, c_i, sc.unit, sc.per_count**2, fits[ch], fs)
        doc["outliers"] = outliers_doc(host.outliers if host is not None else None, chans, opts.outliers)
        if opts.model:
            model_all(doc, fits, fit_curves, chans, profile, fs, host, report, opts)
        overbound.add_to_doc(doc, opts.horizon)
    except BaseException:
        if host is not None:
            host.close()
        raise
    if host is not None and not opts.keep_store:
        host.close()
    return Analysis(_jsonable(doc), fits, host.store if host is not None and opts.keep_store else None)


# ---- input checks -------------------------------------------------------------------


def _sample_rate(src: Source, report: Optional[DeviceReport], opts: Options) -> float:
    known = None
    if report is not None:
        known, where = float(report.header.fs_hz), "the device header"
    elif src.samples is not None and src.samples.fs:
        known, where = float(src.samples.fs), "the time column"
    if opts.fs is not None:
        if known is not None and report is not None and abs(known - opts.fs) > 1e-9 * known:
            raise InputError(f"--fs {opts.fs:g} contradicts {where} (fs={known:g} Hz)")
        return float(opts.fs)
    if known is None:
        raise InputError("the sample rate is unknown: give --fs HZ (a rows file does not carry it)")
    return known


def _channels(available: list[str], wanted: Optional[list[str]]) -> list[str]:
    if not wanted:
        return list(available)
    missing = [c for c in wanted if c not in available]
    if missing:
        raise InputError(f"channel {missing[0]} is not in the input (it has {' '.join(available)})")
    return [c for c in available if c in wanted]


def device_curve(report: DeviceReport, ch: str) -> Curve:
    """The on-device octave AVAR of ``ch`` as a curve (levels with pairs, by m)."""
    rows = sorted((r for r in report.rows if r.channel == ch and r.pairs > 0), key=lambda r: r.level)
    ms = np.array([r.m for r in rows], dtype=np.int64)
    return Curve(
        ms,
        np.array([r.avar for r in rows]),
        np.array([r.covers + 1 for r in rows]),
        ms.copy(),
        [flag_names(r.flags) for r in rows],
    )


# ---- one channel ----------------------------------------------------------------------------


def _channel(
    ch: str,
    c_i: int,
    profile: Profile,
    fs: float,
    host: Optional[HostPass],
    report: Optional[DeviceReport],
    opts: Options,
    notes: list[str],
) -> tuple[dict[str, Any], terms.FitResult, list[tuple[int, float]]]:
    """One channel's JSON object, its fit of the noise terms, and the (m, deviation)
    points of the fit's octave grid (FIT% is computed on them whatever --taus shows)."""
    sc = profile.scale(ch)
    k2 = sc.per_count**2
    curves = host_curves(host, c_i, opts.extra_curves) if host is not None else {}
    dev = device_curve(report, ch) if report is not None else None
    if host is not None:
        main, overlapping, stat = curves["oavar"], True, "oadev"
        res: allan.OctaveResult = host.octave  # the fit's grid, whatever --taus shows
        fitc = Curve(res.ms, res.oavar[:, c_i], np.full(res.ms.size, host.n + 1), res.stride)
        mask = None
    elif dev is not None:
        main, overlapping, stat = dev, False, "adev (device)"
        fitc = dev
        mask = np.array([not f for f in dev.flags], dtype=bool)
    else:  # pragma: no cover - the source always has one
        raise InputError("nothing to analyze")
    if host is not None and not np.any(main.var > 0):
        notes.append(
            f"{ch} is constant (the same code in every sample): Allan deviation 0 at every "
            "tau, no noise term to fit (a stuck or disconnected sensor?)"
        )
    efn = edf.edf_function(fitc.ms, fitc.N, fitc.stride)
    fit = fit_noise(fitc.ms / fs, fitc.var * k2, efn, fs=fs, mask=mask, overlapping=overlapping)
    used = np.isin(main.ms, fitc.ms[fit.used])
    out: dict[str, Any] = {
        "unit": sc.unit,
        "kind": sc.kind,
        "scale_per_count": sc.per_count,
        "term_units": {
            **{k: term_unit(sc, k) for k in terms.TERMS},
            **{k: ("Hz" if k == "LP" else sc.unit) for k in fit.terms if k not in terms.TERMS},
        },
        "terms": {k: term_json(t) for k, t in fit.terms.items()},
        "term_notes": _term_notes(fit, _clipping(ch, c_i, host, report, notes)),
        "upper_bounds": {k: _num(t.upper) for k, t in fit.terms.items() if k in terms.TERMS},
        "b_classic": _b_classic(fit),
        "fit": _fit_json(fit, fitc, stat, fs),
        "curve": _points(main, fs, k2, fit, d=2, modified=False, used=used),
    }
    # the fit's own octave points with their EDFs, whatever grid --taus shows: what the
    # recording-length advice counts (docs/dynamic.md)
    out["fit"]["octave_points"] = [
        {"tau_s": p["tau_s"], "edf": p["edf"], "used": bool(u), "dev": p["dev"], "high": p["high"]}
        for p, u in zip(_points(fitc, fs, k2, fit, d=2, modified=False), fit.used)
    ]
    extra = {}
    for name, d, mod in (("adev", 2, False), ("mdev", 2, True), ("hdev", 3, False)):
        cv = curves.get({"adev": "avar", "mdev": "mvar", "hdev": "hvar"}[name])
        if cv is not None and cv is not main:
            extra[name] = _points(cv, fs, k2, fit, d=d, modified=mod)
    if extra:
        out["curves"] = extra
    out["outliers"] = outliers_json(host.outliers if host is not None else None, c_i, fs, k2, efn, fit)
    if dev is not None and host is not None:
        out["device"] = _device_json(dev, fs, k2, fit, main)
    if host is not None:
        out["psd"] = None  # filled once every channel is fitted (analyze)
    out["si"] = _si_json(sc, out["terms"])
    fl = fitc.flags if fitc.flags else [[] for _ in range(fitc.ms.size)]
    fit_curve = [
        (int(m), float(math.sqrt(v * k2)))
        for m, v, f in zip(fitc.ms, fitc.var, fl)
        if math.isfinite(v) and v > 0 and not f
    ]  # FIT%'s grid
    return out, fit, fit_curve


def _fit_json(fit: terms.FitResult, fitc: Curve, stat: str, fs: float) -> dict[str, Any]:
    """``channels.<ch>.fit``: which curve was fitted, where, and how well."""
    return {
        "statistic": stat,
        "grid": "octave",
        "chi2_dof": _num(fit.chi2_red),
        "tau_window_s": (
            [float(fitc.ms[fit.used].min() / fs), float(fitc.ms[fit.used].max() / fs)] if fit.used.any() else None
        ),
        "points": int(fit.used.sum()),
        "notes": fit.notes,
        "unexplained": [{"tau_s": r["tau_s"], "kind": r["kind"], "ratio": r["ratio"]} for r in fit.unexplained],
        **fit_extras(fit, fitc.ms[fit.used] / fs if fit.used.any() else fitc.ms / fs),
    }


def _psd_json(host: HostPass, c_i: int, unit: str, k2: float, fit: terms.FitResult, fs: float) -> dict[str, Any]:
    """``channels.<ch>.psd``: the Welch PSD in log bins and the terms' levels."""
    f, p = host.psd
    fb, pb = psd.log_bins(f, p[c_i : c_i + 1] * k2)
    lines = psd.term_psd(fb, fit.values(), fs)
    return {
        "method": "Welch (pwelch defaults: Hamming, 8 segments, 50 % overlap)",
        "unit": f"({unit})^2/Hz",
        "f_hz": _list(fb),
        "psd": _list(pb[0]),
        "terms": {k: _list(v) for k, v in lines.items()},
    }


def _si_json(sc: Any, terms_doc: dict[str, Any]) -> dict[str, Any]:
    """``channels.<ch>.si``: the terms with rates in rad/s (gyros) or m/s^2."""
    si = to_si_rad(sc)
    return {
        "unit": "rad/s" if sc.unit == "deg/s" else sc.unit,
        "terms": {
            k: (
                None
                if v is None
                else {
                    kk: (vv * si if isinstance(vv, float) and k != "LP" and kk not in NOT_RATE else vv)
                    for kk, vv in v.items()
                }
            )
            for k, v in terms_doc.items()
        },
    }


def _clipping(
    ch: str, c_i: int, host: Optional[HostPass], report: Optional[DeviceReport], notes: list[str]
) -> Optional[str]:
    """Samples of ``ch`` at code 0 or 1023 (from the samples, else the device
    header): a note for the document, and the one its terms carry."""
    if host is not None and host.clipped is not None:
        k, n = int(host.clipped[c_i]), host.n
    elif host is None and report is not None and report.header.clips is not None:
        k, n = int(report.header.clips[ch]), report.header.n
    else:
        return None
    if k == 0:
        return None
    text = (
        f"{ch} clipped: {k} samples at code 0 or {CODE_MAX} ({100.0 * k / max(n, 1):.3g} % of {n}; "
        "any clipped sample is reported)"
    )
    notes.append(text + ": its deviations and terms are biased")
    return f"clipped channel ({k} samples at code 0 or {CODE_MAX}): biased"


def _term_notes(fit: terms.FitResult, clipped: Optional[str]) -> dict[str, str]:
    out = {k: t.note for k, t in fit.terms.items() if t.note}
    if clipped:
        for k, t in fit.terms.items():
            if t.value is not None:
                out[k] = f"{out[k]}; {clipped}" if k in out else clipped
    return out


NOT_RATE = ("tau_c", "tau_c_low", "tau_c_high", "fc", "fc_low", "fc_high", "order", "tau_range_s")
"""Keys of a term's JSON that are not in the channel's rate unit (not scaled to SI)."""


def term_json(t: terms.Term) -> Optional[dict[str, Any]]:
    """A noise term as the JSON of ``analyze --json`` (None when not identified):
    value, low, high, tau_range_s; a Gauss-Markov process (GM1, GM2, ...) adds
    tau_c (s) and its interval, the band limit (LP, value = fc) fc (Hz) and order."""
    if t.value is None:
        return None
    out = {
        "value": t.value,
        "low": t.low,
        "high": t.high,
        "tau_range_s": [t.tau_range[0], t.tau_range[1]] if t.tau_range else None,
    }
    for k, v in t.extra.items():
        out[k] = _num(v) if isinstance(v, float) else v
    return out


def fit_extras(fit: terms.FitResult, tau: np.ndarray) -> dict[str, Any]:
    """The whole-curve fit's model, its slope-reading cross-check and each fitted
    component's ADEV on a grid over the fitted taus (for plots and users)."""
    comps = getattr(fit, "components", None)
    if comps is None or tau.size == 0:
        return {}
    grid = np.exp(np.linspace(math.log(float(tau.min())), math.log(float(tau.max())), 60))
    parts = comps(grid)
    return {
        "model": repr(fit.fitted),
        "slope_reading": {k: {"value": _num(v["value"]), "tau_s": v["tau_s"]} for k, v in fit.slope.items()},
        "components": {
            "tau_s": _list(grid),
            "adev": {k: _list(np.sqrt(np.maximum(v, 0.0))) for k, v in parts.items()},
            "total_adev": _list(np.sqrt(fit.model(grid))),
        },
    }


def _b_classic(fit: terms.FitResult) -> Optional[dict[str, Any]]:
    b = fit.b_classic
    if b is None:
        return None
    return {
        "value": b["value"],
        "tau_s": b["tau_s"],
        "rule": "min(ADEV) / 0.664 over the points with EDF >= 10 (the thesis' sigma_B)",
    }


def _alphas(fit: terms.FitResult, tau: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Noise type (alpha) and dominant term at each tau, from the fitted model."""
    comps = fit.components(tau) if hasattr(fit, "components") else {}
    if not comps:
        return np.zeros(tau.size, dtype=np.int64), ["N"] * tau.size
    names = list(comps)
    A = np.stack([comps[k] for k in names], axis=1)
    dom = [names[j] for j in np.argmax(A, axis=1)]
    # a Gauss-Markov process counts as flicker (its hump), the band limit as white
    return np.array([terms.ALPHA.get(d, -1) for d in dom], dtype=np.int64), dom


def _points(
    cv: Curve, fs: float, k2: float, fit: terms.FitResult, d: int, modified: bool, used: Optional[np.ndarray] = None
) -> list[dict[str, Any]]:
    tau = cv.ms / fs
    alpha, dom = _alphas(fit, tau)
    if d == 3:
        alpha = np.maximum(alpha, -4)
    e = _edf_for(cv, alpha, d, modified)
    var = cv.var * k2
    lo, hi = edf.chi2_interval(var, e, LEVEL)
    out = []
    for i in range(tau.size):
        ok = bool(np.isfinite(var[i]) and var[i] > 0)
        pt = {
            "tau_s": float(tau[i]),
            "m": int(cv.ms[i]),
            "dev": _num(math.sqrt(var[i])) if ok else None,
            "low": _num(math.sqrt(lo[i])) if ok else None,
            "high": _num(math.sqrt(hi[i])) if ok else None,
            "edf": _num(e[i]),
            "noise": dom[i],
        }
        if int(cv.stride[i]) not in (1, int(cv.ms[i])):
            pt["stride"] = int(cv.stride[i])
        if used is not None:
            pt["used"] = bool(used[i])
        if cv.flags:
            pt["flags"] = cv.flags[i]
        out.append(pt)
    return out


def _edf_for(cv: Curve, alpha: np.ndarray, d: int, modified: bool) -> np.ndarray:
    table = edf.edf_points(
        cv.ms, cv.N, cv.stride, d=d, modified=modified, alphas=tuple(sorted(set(int(a) for a in alpha)))
    )
    out = np.empty(cv.ms.size)
    for a, vals in table.items():
        out[alpha == a] = vals[alpha == a]
    return out


def _device_json(dev: Curve, fs: float, k2: float, fit: terms.FitResult, host: Curve) -> dict[str, Any]:
    pts = _points(dev, fs, k2, fit, d=2, modified=False)
    host_var = {int(m): v * k2 for m, v in zip(host.ms, host.var)}
    checked = within = 0
    outside = []
    for p in pts:
        h = host_var.get(p["m"])
        if p.get("flags") or p["dev"] is None or h is None or not math.isfinite(h):
            continue
        checked += 1
        hv = math.sqrt(h)
        p["host_dev"] = hv
        if p["low"] <= hv <= p["high"]:
            within += 1
        else:
            outside.append(p["tau_s"])
    return {
        "curve": pts,
        "agreement": {
            "checked": checked,
            "within": within,
            "level": LEVEL,
            "outside_tau_s": outside,
            "rule": "host overlapping ADEV inside the 95 % interval of "
            "the device's non-overlapping value (EDF from its pairs)",
        },
    }


# ---- JSON helpers ---------------------------------------------------------------------------


def _num(v: Any) -> Optional[float]:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _list(a: np.ndarray) -> list[Optional[float]]:
    return [_num(v) for v in np.asarray(a).tolist()]


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, float):
        return _num(v)
    return v
