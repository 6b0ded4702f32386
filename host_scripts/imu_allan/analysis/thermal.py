"""``imu-allan thermal``: the bias of each channel against temperature, and the
noise terms before and after removing it (the thesis' section 9: "thermal
modelling of the error models").

Regression. The samples are cut into about ``BLOCKS`` consecutive blocks;
each block's mean bias is regressed on its mean temperature, by ordinary
least squares, linear (b = c0 + c1 T) and quadratic (+ c2 T^2). The noise
left after the fit is correlated from block to block (bias instability,
random walks), which would make textbook intervals too narrow: the
residuals' lag-1 autocorrelation rho gives the effective number of
independent blocks n_eff = n (1 - rho) / (1 + rho) (the AR(1) correction,
e.g. Bretherton et al. 1999, J. Climate 12, 1990), and the intervals are
Student-t with n_eff - p degrees of freedom. The quadratic term is kept
when an F-test (95 %) on the same n_eff supports it.

A temperature that only ever rises cannot tell a thermal bias from a drift
that happens at the same time (a rate random walk, say); a cycle up and
down can. The result says which kind of profile it saw.

Removal. The fitted bias, evaluated on the block-mean temperature
interpolated to every sample (so that the temperature channel's own noise
is not injected), minus its value at the mean temperature, is subtracted;
the Allan deviation and the IEEE 952 terms are computed before and after
(analysis.py: overlapping octave ADEV, GLS fit, 95 % intervals).

Terms against temperature: N and B of the corrected series in ``SEGMENTS``
consecutive segments, each at its mean temperature, and the slope of each
against temperature (weighted least squares, 95 % interval): the thesis'
third task, whether the Allan parameters themselves depend on temperature.

The thesis' noise model (white + Gauss-Markov + rate random walk, model.py)
of the corrected series, plus the thermal term, is the thermal noise
model; its FIT% on log10 ADEV is given for the raw series with and without
the thermal term, and the thermal term's FIT% on the block means.
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np
from scipy.linalg import solve_triangular

from ..channels import CHANNELS
from ..errors import InputError
from ..stats import dist
from ..stats.dist import Z95

CHI2_1_95 = 3.841458820694124
SEGMENTS = 3
"""Consecutive segments in which N and B are measured against their mean temperature."""
BLOCKS = 400
"""Blocks for the regression: enough points, each averaging a lot of white noise."""


def read_with_temperature(path: str) -> tuple[np.ndarray, Optional[float], str]:
    """(7, n) codes of a rows file or a raw/both capture, its fs if a header says, its kind.

    Read through the one file reader (sources.load); only the sources that
    carry the temperature column (rows files, captures with samples) qualify."""
    from ..sources.detect import load

    src = load(path)
    s = src.samples
    if s is None:
        raise InputError(
            f"'{src.name}': a device capture without raw rows or binary frames "
            "(the thermal study needs the samples: mode raw or both)"
        )
    if s.open_temperature is None:
        raise InputError(
            f"'{src.name}': no temperature column (a {s.kind} file; the thermal study "
            "reads rows files and device captures)"
        )
    chans = [b for b in s.open_blocks()]
    temps = [t for t in s.open_temperature()]
    if not chans:
        return np.zeros((len(s.channels) + 1, 0), dtype=np.uint16), s.fs, s.kind
    return np.vstack([np.concatenate(chans, axis=1), np.concatenate(temps)[None, :]]), s.fs, s.kind


FLICKER_T_MIN, FLICKER_RATIO = 1e-3, 8.0


def block_covariance(centres: np.ndarray, D: float, terms: dict[str, Optional[float]]) -> np.ndarray:
    """Covariance of block means (duration D s, centres in s) of a noise with IEEE 952
    terms N (white), B (flicker, as a bank of OU processes spaced by 8, each of variance
    B^2 ln 8 / pi) and K (rate random walk), in the terms' units squared."""
    N, B, K = (terms.get(k) or 0.0 for k in ("N", "B", "K"))
    n = centres.size
    S = np.eye(n) * (N * N / D)
    if B:
        lag = np.abs(centres[:, None] - centres[None, :])
        v = B * B * math.log(FLICKER_RATIO) / math.pi
        T = FLICKER_T_MIN
        t_hi = 4.0 * (centres[-1] + D)
        while T < t_hi:
            x = D / T
            same = 2.0 / (x * x) * (x - 1.0 + math.exp(-x))  # block mean of OU, variance factor
            apart = (math.sinh(x / 2) / (x / 2)) ** 2 if x < 50 else math.inf
            with np.errstate(over="ignore", invalid="ignore"):
                off = np.where(lag > 0, np.exp(-lag / T) * apart, 0.0)
            off = np.nan_to_num(off, nan=0.0, posinf=0.0)
            S += v * (off + np.eye(n) * same)
            T *= FLICKER_RATIO
    if K:
        lo = np.minimum(centres[:, None], centres[None, :])
        S += K * K * (lo - np.eye(n) * D / 6.0)
    return S


def _gls(X: np.ndarray, y: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, int]:
    """GLS with the Cholesky factor L of the covariance: coefficients, their covariance, chi2, dof."""
    Xw = solve_triangular(L, X, lower=True)
    yw = solve_triangular(L, y, lower=True)
    beta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    chi2 = float(np.sum((yw - Xw @ beta) ** 2))
    dof = max(y.size - X.shape[1], 1)
    cov = np.linalg.pinv(Xw.T @ Xw) * max(1.0, chi2 / dof)
    return beta, cov, chi2, dof


def regress(temp: np.ndarray, bias: np.ndarray, S: Optional[np.ndarray] = None) -> dict[str, Any]:
    """Linear and quadratic fits of block-mean bias on block-mean temperature, by GLS with the
    blocks' noise covariance S (identity: ordinary least squares); 95 % intervals."""
    t0 = float(temp.mean())
    dt = temp - t0
    ols = np.eye(bias.size) * max(float(np.var(bias)), 1e-30)
    if S is None or not float(np.trace(S)) > 0:  # a stuck channel has no noise: nothing to weigh by
        S = ols
    X1 = np.stack([np.ones_like(dt), dt], axis=1)
    X2 = np.stack([np.ones_like(dt), dt, dt * dt], axis=1)
    try:
        L = np.linalg.cholesky(S + np.eye(S.shape[0]) * 1e-12 * np.trace(S) / S.shape[0])
    except np.linalg.LinAlgError:  # a covariance the noise terms could not make positive
        L = np.linalg.cholesky(ols)
    b1, cov1, chi1, dof1 = _gls(X1, bias, L)
    b2, cov2, chi2, dof2 = _gls(X2, bias, L)

    def iv(b: np.ndarray, cov: np.ndarray, j: int) -> dict[str, float]:
        half = Z95 * math.sqrt(max(float(cov[j, j]), 0.0))
        return {"value": float(b[j]), "low": float(b[j] - half), "high": float(b[j] + half)}

    out: dict[str, Any] = {"blocks": int(bias.size), "t_ref": t0, "chi2_dof": chi1 / dof1, "linear": iv(b1, cov1, 1)}
    gain = chi1 - chi2
    need = CHI2_1_95 * max(1.0, chi2 / dof2)
    out["quadratic_test"] = {
        "chi2_gain": gain,
        "needed": need,
        "p_value": float(dist.chi2_sf(gain / max(1.0, chi2 / dof2), 1)),
    }
    if gain >= need:
        out["quadratic"] = {"c1": iv(b2, cov2, 1), "c2": iv(b2, cov2, 2)}
        out["coef"] = [float(b2[0]), float(b2[1]), float(b2[2])]
    else:
        out["coef"] = [float(b1[0]), float(b1[1]), 0.0]
    return out


def _stuck_notes(x: np.ndarray) -> list[str]:
    """A note per channel whose every sample is the same code (a stuck or railed channel)."""
    return [
        f"{ch}: every sample is {x[c][0]:g}: a stuck channel (no noise, no temperature "
        "dependence can be measured); its tempco is 0 by construction"
        for c, ch in enumerate(CHANNELS)
        if x.shape[1] and x[c].min() == x[c].max()
    ]


# Block means of the temperature that span fewer codes than this cannot tell a
# tempco apart from the noise: no thermal fit is made (a fit would print
# tempco 0 [0, 0], which reads as a measured zero).
MIN_SPAN_CODES = 3


def study(
    path: str,
    fs: Optional[float] = None,
    temp_scale: Optional[tuple[float, float]] = None,
    profile: str = "counts",
    segments: int = SEGMENTS,
    outliers_mode: str = "replace",
    scales: Optional[dict[str, tuple[float, str]]] = None,
) -> dict[str, Any]:
    """Bias against temperature per channel, and the noise terms before and
    after removing it (``imu-allan thermal``); ``scales`` as analyze's --scale."""
    from ..profiles import build_profile

    codes, fs_file, kind = read_with_temperature(path)
    fs = fs if fs is not None else fs_file
    if fs is None:
        raise InputError("the sample rate is unknown: give --fs HZ (a rows file does not carry it)")
    n = codes.shape[1]
    if n < 4 * BLOCKS // 10:
        raise InputError(f"'{path}': {n} samples: too few for a thermal study")
    if codes.shape[0] < 7:
        raise InputError(f"'{path}': no temperature column")
    scale, off = temp_scale if temp_scale else (1.0, 0.0)
    t_unit = "degC" if temp_scale else "code"
    T = codes[6].astype(np.float64) * scale + off
    L = max(n // BLOCKS, 1)
    nb = n // L
    Tb = T[: nb * L].reshape(nb, L).mean(axis=1)
    centres = (np.arange(nb) + 0.5) * L
    span = float(Tb.max() - Tb.min())
    doc = _skeleton(path, fs, n, T, Tb, t_unit, temp_scale, profile)
    if span < MIN_SPAN_CODES * scale:
        doc["notes"].append(
            f"temperature does not vary (range {span:.3g} {t_unit}, under {MIN_SPAN_CODES} codes): no thermal fit"
        )
        return doc
    d = np.diff(Tb)
    mono = bool(np.all(d >= -3 * scale / math.sqrt(L)) or np.all(d <= 3 * scale / math.sqrt(L)))
    doc["temperature"]["one_way"] = mono
    notes = doc["notes"]
    if mono:
        notes.append(
            "the temperature went one way only (a ramp): a drift of the bias at the same time "
            "(e.g. rate random walk) is indistinguishable from a thermal bias; a cycle up and "
            "down separates them"
        )
    prof = build_profile(profile, scales or {}, None)
    x = codes[:6].astype(np.float64)
    notes += _stuck_notes(x)
    x, doc["outliers"] = _outliers(path, x, fs, outliers_mode, notes)  # before the block means and the terms
    xb = x[:, : nb * L].reshape(6, nb, L).mean(axis=2)
    T_smooth = np.interp(np.arange(n), centres, Tb)
    t_s = centres / fs
    D = L / fs
    # 1) ordinary least squares; 2) the noise terms of what is left give the blocks'
    # covariance; 3) generalized least squares with it (estimate and intervals)
    regs = [regress(Tb, xb[c]) for c in range(6)]
    noise = _counts_terms(path, kind, _remove(x, regs, T_smooth), fs)
    regs = [regress(Tb, xb[c], block_covariance(t_s, D, noise[ch])) for c, ch in enumerate(CHANNELS)]
    corrected = _remove(x, regs, T_smooth)
    chans = {ch: _channel_doc(regs[c], ch, prof, t_unit, Tb, xb[c], D, noise[ch]) for c, ch in enumerate(CHANNELS)}
    _before_after(chans, path, kind, x, corrected, T_smooth, fs, prof)
    if segments > 1:
        _terms_by_temperature(chans, corrected, T, fs, segments, path, kind, prof, t_unit)
    doc.update(fitted=True, channels=chans)
    return doc


def _skeleton(
    path: str,
    fs: float,
    n: int,
    T: np.ndarray,
    Tb: np.ndarray,
    t_unit: str,
    temp_scale: Optional[tuple[float, float]],
    profile: str,
) -> dict[str, Any]:
    """The thermal document before any fit: the file and its temperature."""
    return {
        "tool": "imu-allan thermal",
        "file": path,
        "fs_hz": fs,
        "n": n,
        "temperature": {
            "unit": t_unit,
            "min": float(Tb.min()),
            "max": float(Tb.max()),
            "mean": float(T.mean()),
            "one_way": None,
            "scale": {"c_per_count": temp_scale[0], "offset_c": temp_scale[1]} if temp_scale else None,
        },
        "profile": profile,
        "fitted": False,
        "channels": {},
        "outliers": None,
        "notes": [],
    }


def _remove(x: np.ndarray, regs: list[dict[str, Any]], T_smooth: np.ndarray) -> np.ndarray:
    """The channels with each one's fitted thermal bias taken out."""
    out = np.empty_like(x)
    for c, reg in enumerate(regs):
        _, c1, c2 = reg["coef"]
        dT = T_smooth - reg["t_ref"]
        out[c] = x[c] - (c1 * dT + c2 * dT * dT)
    return out


def _counts_terms(path: str, kind: str, data: np.ndarray, fs: float) -> dict[str, dict[str, Any]]:
    """N, B, K of each channel in counts (analyze's fit, outliers already handled)."""
    from ..profiles import build_profile
    from ..sources.detect import SampleSource, Source
    from .pipeline import Options, analyze

    n = data.shape[1]
    src = Source(path, SampleSource(kind, path, list(CHANNELS), lambda: iter([data]), False, fs=fs, n_hint=n), None)
    doc = analyze(
        src, build_profile("counts", {}, None), Options(fs=fs, extra_curves=False, model=False, outliers="keep")
    ).doc
    # a term the data cannot pin down still moves the bias: its 95 % upper bound
    # stands for it (conservative intervals rather than too narrow ones)
    bound = lambda c, k, v: (v or {}).get("value") or c["upper_bounds"].get(k)  # noqa: E731
    return {
        ch: {k: bound(c, k, v) for k, v in c["terms"].items() if k in ("N", "B", "K")}
        for ch, c in doc["channels"].items()
    }


def _outliers(path: str, x: np.ndarray, fs: float, mode: str, notes: list[str]) -> tuple[np.ndarray, dict[str, Any]]:
    """Spikes and bursts (outliers.py) found once, before the regression and the
    terms (whose own analyses then keep what they are given): replaced, or kept."""
    from . import outliers

    found = outliers.scan(x, fs)
    why = outliers.mostly_spikes(found, list(CHANNELS))
    if why and mode == "replace":
        raise InputError(f"'{path}': refused: {why}; --outliers keep studies it as it is")
    ev = [e for e in found.events if not e.step]
    if found.count:
        notes.append(
            f"outliers: {found.count} samples in {len(ev)} event{'s' * (len(ev) != 1)} (spikes, bursts) "
            + ("replaced by the line between their neighbours" if mode == "replace" else "kept (--outliers keep)")
        )
    summary = {
        "mode": mode,
        "count": {ch: found.channels[c].count for c, ch in enumerate(CHANNELS)},
        "times_s": [e.start / fs for e in ev],
        "channels": [[CHANNELS[c] for c in e.channels] for e in ev],
    }
    return (outliers.replace(x, found) if mode == "replace" and found.count else x), summary


def _before_after(
    chans: dict[str, Any],
    path: str,
    kind: str,
    x: np.ndarray,
    corrected: np.ndarray,
    T_smooth: np.ndarray,
    fs: float,
    prof: Any,
) -> None:
    """The Allan deviation, terms and FIT% of each channel before and after removing
    its thermal bias, into ``chans``."""
    from ..sources.detect import SampleSource, Source
    from .pipeline import Options, analyze

    n = x.shape[1]
    docs = {}
    for name, data in (("before", x), ("after", corrected)):
        src = Source(
            path, SampleSource(kind, path, list(CHANNELS), lambda d=data: iter([d]), False, fs=fs, n_hint=n), None
        )
        docs[name] = analyze(src, prof, Options(fs=fs, extra_curves=False, seed=1, outliers="keep")).doc
    for ch in CHANNELS:
        b, a = docs["before"]["channels"][ch], docs["after"]["channels"][ch]
        chans[ch]["terms_before"] = b["terms"]
        chans[ch]["terms_after"] = a["terms"]
        chans[ch]["term_units"] = b["term_units"]
        chans[ch]["adev_before"] = [
            {"tau_s": p["tau_s"], "dev": p["dev"], "low": p["low"], "high": p["high"]} for p in b["curve"]
        ]
        chans[ch]["adev_after"] = [
            {"tau_s": p["tau_s"], "dev": p["dev"], "low": p["low"], "high": p["high"]} for p in a["curve"]
        ]
        chans[ch]["fit_percent"] = {
            "noise_model_on_raw": (b.get("model") or {}).get("fit_percent", {}).get("adev_log10"),
            "noise_model_on_corrected": (a.get("model") or {}).get("fit_percent", {}).get("adev_log10"),
            "noise_plus_thermal_on_raw": _with_thermal(a, b, chans[ch], T_smooth, fs, prof.scale(ch).per_count),
        }


def _channel_doc(
    reg: dict[str, Any],
    ch: str,
    prof: Any,
    t_unit: str,
    Tb: np.ndarray,
    xb_c: np.ndarray,
    D: float,
    noise_ch: dict[str, Any],
) -> dict[str, Any]:
    """One channel's thermal regression in the channel's units."""
    k = prof.scale(ch).per_count
    unit = f"{prof.scale(ch).unit}/{t_unit}".replace("count/", "counts/")
    thermal_b = np.array([reg["coef"][1] * (t - reg["t_ref"]) + reg["coef"][2] * (t - reg["t_ref"]) ** 2 for t in Tb])
    return {
        "tempco": {**{kk: v * k for kk, v in reg["linear"].items()}, "unit": unit},
        "model": "quadratic" if "quadratic" in reg else "linear",
        "quadratic": None
        if "quadratic" not in reg
        else {
            "c1": {kk: v * k for kk, v in reg["quadratic"]["c1"].items()},
            "c2": {kk: v * k for kk, v in reg["quadratic"]["c2"].items()},
            "unit_c2": f"{prof.scale(ch).unit}/{t_unit}^2".replace("count/", "counts/"),
            "t_ref": reg["t_ref"],
        },
        "quadratic_test": reg["quadratic_test"],
        "regression": {
            "method": "GLS on block means, covariance from the noise terms "
            "(counts) of the series with the OLS thermal bias removed",
            "blocks": reg["blocks"],
            "block_s": D,
            "chi2_dof": reg["chi2_dof"],
            "noise_terms_counts": noise_ch,
        },
        "thermal_fit_percent_block_means": _fit(xb_c - xb_c.mean(), thermal_b - thermal_b.mean()),
    }


def _terms_by_temperature(
    chans: dict[str, Any],
    data: np.ndarray,
    T: np.ndarray,
    fs: float,
    segments: int,
    path: str,
    kind: str,
    prof: Any,
    t_unit: str,
) -> None:
    """N and B of the thermally corrected series in consecutive segments (each at its own
    mean temperature), and the slope of each against temperature with its 95 % interval."""
    from ..sources.detect import SampleSource, Source
    from .pipeline import Options, analyze

    n = data.shape[1]
    L = n // segments
    temps, docs = [], []
    for i in range(segments):
        seg = data[:, i * L : (i + 1) * L]
        src = Source(
            path, SampleSource(kind, path, list(CHANNELS), lambda d=seg: iter([d]), False, fs=fs, n_hint=L), None
        )
        docs.append(analyze(src, prof, Options(fs=fs, extra_curves=False, model=False, outliers="keep")).doc)
        temps.append(float(T[i * L : (i + 1) * L].mean()))
    for ch in CHANNELS:
        out: dict[str, Any] = {"temperature": temps, "unit": t_unit, "segment_s": L / fs}
        for q in ("N", "B"):
            vals = [d["channels"][ch]["terms"].get(q) for d in docs]
            out[q] = vals
            out[f"{q}_slope"] = linear_slope(temps, vals)
        chans[ch]["terms_by_temperature"] = out


def linear_slope(x: list[float], vals: list[Optional[dict[str, Any]]]) -> Optional[dict[str, Any]]:
    """Weighted least-squares slope of value against x (weights from the 95 % intervals),
    its 95 % interval (Student t, widened by the scatter) and a verdict."""
    pts = [
        (xi, v)
        for xi, v in zip(x, vals)
        if v
        and v.get("value") is not None
        and v.get("low") is not None
        and v.get("high") is not None
        and v["high"] > v["low"]
    ]
    if len(pts) < 2 or np.ptp([p[0] for p in pts]) == 0:
        return None
    xs = np.array([p[0] for p in pts])
    y = np.array([p[1]["value"] for p in pts])
    w = 1.0 / np.square([(p[1]["high"] - p[1]["low"]) / (2 * Z95) for p in pts])
    X = np.stack([np.ones_like(xs), xs - xs.mean()], axis=1)
    cov = np.linalg.inv(X.T @ (X * w[:, None]))
    beta = cov @ (X.T @ (w * y))
    dof = len(pts) - 2
    red = float(np.sum(w * (y - X @ beta) ** 2)) / dof if dof > 0 else 0.0
    q = dist.t_ppf(0.975, dof) if dof > 0 and red > 1 else Z95
    half = float(q * math.sqrt(cov[1, 1] * max(red, 1.0)))
    b = float(beta[1])
    rel = b / float(np.average(y, weights=w))
    return {
        "value": b,
        "low": b - half,
        "high": b + half,
        "relative_per_unit": rel,
        "verdict": "independent of temperature"
        if b - half <= 0 <= b + half
        else ("grows with temperature" if b > 0 else "falls with temperature"),
    }


def _fit(s: np.ndarray, m: np.ndarray) -> Optional[float]:
    from ..noise.model import fit_percent

    return fit_percent(s, m)


def _with_thermal(
    after: dict[str, Any], before: dict[str, Any], ch: dict[str, Any], T: np.ndarray, fs: float, k: float
) -> Optional[float]:
    """FIT% (log10 ADEV) of noise model + thermal term against the raw series' curve."""
    from ..noise import model
    from ..stats.allan import oadev_octave

    mp = (after.get("model") or {}).get("params")
    if not mp:
        return None
    p = model.ModelParams(
        fs=fs,
        white=mp["white_sigma"],
        gm_sigma=mp["gm_sigma"],
        gm_tau=mp["gm_tau_s"],
        rrw=mp["rrw_sigma"],
        quant=mp["Q"],
        ramp=mp["R"],
    )
    sim = np.concatenate(list(model.simulate(p, T.size, seed=7)))
    q = ch["quadratic"]
    c1 = q["c1"]["value"] if q else ch["tempco"]["value"]
    c2 = q["c2"]["value"] if q else 0.0
    dT = T - (q["t_ref"] if q else T.mean())
    sim += c1 * dT + c2 * dT * dT
    tau, dev = oadev_octave(sim, fs)
    ref = {round(pt["tau_s"], 12): pt["dev"] for pt in before["curve"] if pt["dev"]}
    pairs = [(ref[round(t, 12)], v) for t, v in zip(tau, dev) if round(t, 12) in ref and v > 0]
    if not pairs:
        return None
    return model.fit_percent(np.log10([a for a, _ in pairs]), np.log10([b for _, b in pairs]))
