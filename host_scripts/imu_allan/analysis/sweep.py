"""``imu-allan sweep``: the device's on-device results at several sample rates,
and how each noise term depends on the rate.

For each rate the device (a board on a serial port, or the real firmware in
the simulator fed by the continuous sensor model, sensor.py; the two devices
are sweep_devices.py) is set with
``rate``, its accumulators cleared with ``reset``, left to sample for the
given seconds, and asked for a ``report``. Only that final on-device report
is used: the noise terms are fitted to the device's non-overlapping
octave curve exactly as ``imu-allan analyze LOG`` does (analysis.py), and
the thesis' derived figures are computed from them (model.py):

    sigma_sensor  Allan deviation at tau0 = 1/Fs (the device's level 0): the
                  standard deviation of the series when the samples are white
    N_tau0        the thesis' read-off of N: ADEV(tau0) sqrt(tau0)
    sigma_AVRW    N sqrt(Fs)      white noise per sample of the thesis model
    sigma_BIAS    1.0755 B        the Gauss-Markov sigma standing for B
    sigma_ARRW    K / sqrt(Fs)    random-walk step per sample

Dependence on Fs: each quantity q(Fs) is fitted as a power law
q = c Fs^b by weighted least squares on log q (weights from each value's
95 % interval); the interval of b is 95 % (Student t with n - 2 degrees of
freedom when the scatter exceeds the intervals, which then widens it). A
quantity "does not depend on Fs" when the interval of b holds 0; a power law
that does not fit (chi-squared p < 0.01) is flagged: the dependence changes
along the range (for instance the aliasing knee near the sensor's bandwidth).

Resumable: every finished rate is written to ``DIR/sweep.json``; the same
command run again skips the rates already there.
"""

from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

from ..channels import CHANNELS
from ..errors import InputError
from ..stats import dist
from ..stats.dist import Z95

STATE = "sweep.json"
STATE_VERSION = 1
QUANTITIES = ("N", "N_tau0", "B", "K", "sigma_sensor", "sigma_AVRW", "sigma_BIAS", "sigma_ARRW")
GM_PER_B = 0.6642824702679406 / 0.6173643
"""sigma of the Gauss-Markov process whose ADEV peak sits on the flicker floor 0.664 B (model.py)."""


@dataclass
class SweepConfig:
    source: str  # "sim" or "port:<name>"
    rates: list[float]
    seconds: float
    profile: str = "counts"
    model: Optional[dict[str, Any]] = None
    seed: int = 1
    average: int = 1
    fit_from: Optional[float] = None  # s: fit the terms only at tau >= fit_from
    terms: Optional[tuple[str, ...]] = None  # the terms allowed in the fit (default all five)

    def key(self) -> dict[str, Any]:
        """What must match for a saved rate to be reused."""
        return {
            "source": self.source,
            "seconds": self.seconds,
            "profile": self.profile,
            "model": self.model,
            "seed": self.seed,
            "average": self.average,
            "fit_from": self.fit_from,
            "terms": list(self.terms) if self.terms else None,
        }


@dataclass
class Sweep:
    config: SweepConfig
    directory: str
    results: dict[str, Any] = field(default_factory=dict)

    @property
    def state_path(self) -> str:
        return os.path.join(self.directory, STATE)


def rate_key(fs: float) -> str:
    return f"{fs:g}"


def open_sweep(config: SweepConfig, directory: str, restart: bool = False) -> Sweep:
    """The sweep in ``directory``: rates already measured with the same settings are kept."""
    try:
        os.makedirs(directory, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create '{directory}': {exc.strerror or exc}") from None
    sw = Sweep(config, directory)
    if os.path.exists(sw.state_path) and not restart:
        try:
            with open(sw.state_path) as f:
                doc = json.load(f)
        except (OSError, json.JSONDecodeError) as exc:
            raise InputError(
                f"'{sw.state_path}': unreadable sweep state ({exc}); remove it or give --restart"
            ) from None
        if doc.get("version") != STATE_VERSION or doc.get("config") != config.key():
            raise InputError(
                f"'{sw.state_path}' holds a sweep with other settings "
                "(source, seconds, model, seed, average, profile, --fit-from or --terms): use another --dir, "
                "or --restart to discard it"
            )
        sw.results = {k: v for k, v in doc.get("rates", {}).items()}
    return sw


def save(sw: Sweep) -> None:
    tmp = sw.state_path + ".tmp"
    with open(tmp, "w") as f:
        json.dump({"version": STATE_VERSION, "config": sw.config.key(), "rates": sw.results}, f, indent=1)
    os.replace(tmp, sw.state_path)


Measure = Callable[[float, str], dict[str, Any]]
"""(rate, log path) -> extra facts; writes the device log of that rate."""


def run(sw: Sweep, measure: Measure, say: Callable[[str], None]) -> None:
    """Measure every rate not yet in the state, saving after each."""
    todo = [r for r in sw.config.rates if rate_key(r) not in sw.results]
    done = [r for r in sw.config.rates if rate_key(r) in sw.results]
    if done:
        say(f"resuming: {len(done)} rate(s) already measured ({', '.join(rate_key(r) for r in done)} Hz)")
    for i, fs in enumerate(todo):
        say(f"rate {rate_key(fs)} Hz ({i + 1} of {len(todo)}): {sw.config.seconds:g} s of samples")
        log = os.path.join(sw.directory, f"rate-{rate_key(fs)}.log")
        extra = measure(fs, log)
        res = analyze_log(log, fs, sw.config.profile, sw.config.seed, sw.config.fit_from, sw.config.terms)
        res.update(extra)
        sw.results[rate_key(fs)] = res
        save(sw)


# ---- one rate: the device's final report -> terms ---------------------------------------------


def analyze_log(
    log: str,
    fs: float,
    profile_name: str,
    seed: int,
    fit_from: Optional[float] = None,
    allowed: Optional[tuple[str, ...]] = None,
) -> dict[str, Any]:
    """Terms and the thesis' figures from the last complete report of ``log``;
    with ``fit_from`` (s), the terms are fitted only to the points at tau >= fit_from."""
    from ..profiles import build_profile
    from ..sources.detect import load
    from .pipeline import Options, analyze

    src = load(log)
    rep = src.report
    if rep is None:
        raise InputError(f"'{log}': no complete device report (the device did not answer 'report'?)")
    hdr = rep.header
    if abs(float(hdr.fs_hz) - fs) > 1e-9 * fs:
        raise InputError(f"'{log}': the report says fs={hdr.fs_hz} Hz, not {fs:g} Hz")
    notes = []
    if hdr.drops:
        notes.append(f"the device dropped {hdr.drops} sample sets at {fs:g} Hz")
    clips = hdr.clips or {}
    clipped = {ch: v for ch, v in clips.items() if ch in CHANNELS and v}
    if clipped:
        notes.append(
            f"codes at 0 or 1023 at {fs:g} Hz: "
            + ", ".join(f"{ch} {v}" for ch, v in clipped.items())
            + " (the clipped channels' terms are biased low)"
        )
    profile = build_profile(profile_name, {}, None)
    doc = analyze(src, profile, Options(fs=fs, seed=seed)).doc
    chans = {}
    for ch, c in doc["channels"].items():
        chans[ch] = {
            "unit": c["unit"],
            "terms": c["terms"],
            "upper_bounds": c["upper_bounds"],
            "term_units": c["term_units"],
            "b_classic": c["b_classic"],
            "fit_percent": (c.get("model") or {}).get("fit_percent", {}).get("adev_log10"),
            "chi2_dof": c["fit"]["chi2_dof"],
            "fit_notes": c["fit"]["notes"],
        }
        if fit_from or allowed:
            refit(chans[ch], rep, ch, fs, profile.scale(ch).per_count ** 2, fit_from or 0.0, allowed)
        chans[ch]["derived"] = derived({**c, "terms": chans[ch]["terms"]}, fs)
    return {
        "fs_hz": fs,
        "n": hdr.n,
        "drops": hdr.drops,
        "clips": hdr.clips,
        "temp": hdr.temp,
        "log": os.path.basename(log),
        "channels": chans,
        "notes": notes,
    }


def refit(
    out: dict[str, Any],
    rep: Any,
    ch: str,
    fs: float,
    k2: float,
    fit_from: float,
    allowed: Optional[tuple[str, ...]] = None,
) -> None:
    """The IEEE 952 fit of the device curve restricted to tau >= fit_from and to the
    ``allowed`` terms (replaces the terms)."""
    from ..noise import terms
    from ..noise.fit import fit_curve
    from ..stats import edf
    from .pipeline import device_curve, term_json

    cv = device_curve(rep, ch)
    tau = cv.ms / fs
    mask = np.array([not f for f in cv.flags], dtype=bool) & (tau >= fit_from * (1 - 1e-9))
    fit = fit_curve(
        tau,
        cv.var * k2,
        edf.edf_function(cv.ms, cv.N, cv.stride),
        fs=fs,
        mask=mask,
        overlapping=False,
        allowed=tuple(allowed or terms.TERMS),
    )
    out["terms"] = {k: term_json(t) for k, t in fit.terms.items()}
    out["upper_bounds"] = {
        k: (t.upper if math.isfinite(t.upper) else None) for k, t in fit.terms.items() if k in terms.TERMS
    }
    out["chi2_dof"] = fit.chi2_red if math.isfinite(fit.chi2_red) else None
    out["fit_notes"] = fit.notes + [
        f"terms {','.join(allowed or terms.TERMS)} fitted at tau >= "
        f"{fit_from:g} s (FIT% is of the fit of all terms over the whole curve)"
    ]


def _scaled(term: Optional[dict[str, Any]], f: float) -> Optional[dict[str, Any]]:
    if not term or term.get("value") is None:
        return None
    return {k: (term[k] * f if term.get(k) is not None else None) for k in ("value", "low", "high")}


def derived(c: dict[str, Any], fs: float) -> dict[str, Optional[dict[str, Any]]]:
    """The thesis' figures of one channel (value, low, high), from the fitted terms and level 0."""
    t = c["terms"]
    p0 = next((p for p in c["curve"] if p["m"] == 1 and p["dev"]), None)
    sensor = None if p0 is None else {"value": p0["dev"], "low": p0["low"], "high": p0["high"]}
    r = math.sqrt(1.0 / fs)
    return {
        "sigma_sensor": sensor,
        "N_tau0": _scaled(sensor, r),
        "sigma_AVRW": _scaled(t.get("N"), math.sqrt(fs)),
        "sigma_BIAS": _scaled(t.get("B"), GM_PER_B),
        "sigma_ARRW": _scaled(t.get("K"), r),
    }


def quantity(res: dict[str, Any], ch: str, q: str) -> Optional[dict[str, Any]]:
    c = res["channels"].get(ch)
    if c is None:
        return None
    return c["terms"].get(q) if q in ("N", "B", "K", "Q", "R") else c["derived"].get(q)


# ---- dependence on Fs ------------------------------------------------------------------------


def power_law(fs: list[float], vals: list[dict[str, Any]]) -> Optional[dict[str, Any]]:
    """Weighted fit of log q = a + b log Fs; b with its 95 % interval."""
    pts = [(f, v) for f, v in zip(fs, vals) if v and v.get("value") and v["value"] > 0]
    if len(pts) < 2:
        return None
    x = np.log([f for f, _ in pts])
    y = np.log([v["value"] for _, v in pts])
    sd = []
    for _, v in pts:
        lo, hi = v.get("low"), v.get("high")
        s = (math.log(hi) - math.log(lo)) / (2 * Z95) if lo and hi and lo > 0 and hi > lo else 0.0
        sd.append(max(s, 1e-4))
    w = 1.0 / np.square(sd)
    X = np.stack([np.ones_like(x), x], axis=1)
    cov = np.linalg.inv(X.T @ (X * w[:, None]))
    coef = cov @ (X.T @ (w * y))
    n = len(pts)
    out: dict[str, Any] = {"points": n}
    if n > 2:
        chi2 = float(np.sum(w * (y - X @ coef) ** 2))
        dof = n - 2
        red = chi2 / dof
        p = float(dist.chi2_sf(chi2, dof))
        q = dist.t_ppf(0.975, dof) if red > 1 else Z95
        var_b = cov[1, 1] * max(red, 1.0)
        out.update({"chi2_dof": red, "p_value": p, "power_law_fits": p >= 0.01})
    else:
        q, var_b = Z95, cov[1, 1]
    b, half = float(coef[1]), float(q * math.sqrt(var_b))
    out.update(
        {
            "exponent": b,
            "low": b - half,
            "high": b + half,
            "verdict": "independent of Fs"
            if b - half <= 0 <= b + half
            else ("grows with Fs" if b > 0 else "falls with Fs"),
        }
    )
    return out


def dependence(results: dict[str, Any], channels: list[str]) -> dict[str, Any]:
    keys = sorted(results, key=float)
    fs = [float(k) for k in keys]
    out: dict[str, Any] = {}
    for ch in channels:
        out[ch] = {}
        for q in QUANTITIES:
            fit = power_law(fs, [quantity(results[k], ch, q) for k in keys])
            if fit is not None:
                out[ch][q] = fit
    return out


def document(sw: Sweep) -> dict[str, Any]:
    rates = {k: sw.results[k] for k in sorted(sw.results, key=float) if float(k) in [float(r) for r in sw.config.rates]}
    chans = [c for c in CHANNELS if any(c in r["channels"] for r in rates.values())]
    return {
        "tool": "imu-allan sweep",
        "source": sw.config.source,
        "seconds": sw.config.seconds,
        "profile": sw.config.profile,
        "average": sw.config.average,
        "fit_from": sw.config.fit_from,
        "terms": list(sw.config.terms) if sw.config.terms else None,
        "rates": rates,
        "dependence": dependence(rates, chans),
        "definitions": {
            "sigma_sensor": "ADEV at tau0 = 1/Fs (device level 0)",
            "N_tau0": "the thesis' read-off of N: ADEV(tau0) sqrt(tau0)",
            "sigma_AVRW": "N sqrt(Fs)",
            "sigma_BIAS": "1.0755 B (Gauss-Markov sigma)",
            "sigma_ARRW": "K / sqrt(Fs)",
            "exponent": "b of q = c Fs^b, weighted least squares on log q, 95 % interval",
        },
    }


# ---- text ---------------------------------------------------------------------------------------


def _v(v: Optional[dict[str, Any]], interval: bool = True) -> str:
    if not v or v.get("value") is None:
        return "-"
    if interval and v.get("low") is not None and v.get("high") is not None:
        return f"{v['value']:.3g} [{v['low']:.2g}, {v['high']:.2g}]"
    return f"{v['value']:.3g}"


def text(doc: dict[str, Any]) -> str:
    lines = []
    for k, res in doc["rates"].items():
        lines.append(f"Fs = {k} Hz: n {res['n']} samples, drops {res['drops']}, temp code {res.get('temp')}")
        head = (
            "ch",
            "N [95 %]",
            "B [95 %]",
            "K [95 %]",
            "N_tau0",
            "sigma_sensor",
            "sigma_BIAS",
            "sigma_AVRW",
            "sigma_ARRW",
            "FIT%",
        )
        rows = [head]
        for ch, c in res["channels"].items():
            t, d = c["terms"], c["derived"]
            fit = c.get("fit_percent")
            rows.append(
                (
                    ch,
                    _v(t.get("N")),
                    _v(t.get("B")),
                    _v(t.get("K")),
                    _v(d["N_tau0"], False),
                    _v(d["sigma_sensor"], False),
                    _v(d["sigma_BIAS"], False),
                    _v(d["sigma_AVRW"], False),
                    _v(d["sigma_ARRW"], False),
                    "-" if fit is None else f"{fit:.1f}",
                )
            )
        widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
        lines += ["  " + "  ".join(s.rjust(w) for s, w in zip(r, widths)) for r in rows]
        lines += [f"  note: {n}" for n in res.get("notes", [])]
        law = (res.get("sim") or {}).get("N_law")
        if law:
            lines.append("  the model's N by the aliasing law: " + "  ".join(f"{ch} {v:.3g}" for ch, v in law.items()))
        lines.append("")
    units = next(iter(doc["rates"].values()))["channels"] if doc["rates"] else {}
    if units:
        u = next(iter(units.values()))
        lines.append(
            f"units: N {u['term_units'].get('N')}, B {u['term_units'].get('B')}, "
            f"K {u['term_units'].get('K')}, sigmas {u['unit']}"
        )
        lines.append("")
    lines.append("Dependence on Fs (power law q ~ Fs^b, b with its 95 % interval):")
    for ch, qs in doc["dependence"].items():
        parts = []
        for q, f in qs.items():
            s = (
                f"{q} {f['verdict'].replace(' with Fs', '').replace(' of Fs', '')} "
                f"(b = {f['exponent']:+.2f} [{f['low']:+.2f}, {f['high']:+.2f}]"
            )
            if f.get("power_law_fits") is False:
                s += ", not one power law"
            parts.append(s + ")")
        lines.append(f"  {ch}: " + "; ".join(parts) if parts else f"  {ch}: fewer than 2 rates")
    if not doc.get("fit_from") and any(
        (qs.get("B") or {}).get("verdict") == "grows with Fs" for qs in doc["dependence"].values()
    ):
        lines.append(
            "note: a B that grows with Fs is usually the sensor's analog low-pass, whose "
            "correlation near tau0 the IEEE 952 terms take for bias instability: fit above it "
            "with --terms N,B,K --fit-from 0.2 (docs/thesis-questions.md)"
        )
    return "\n".join(lines) + "\n"


def say_stderr(msg: str) -> None:
    if sys.stderr.isatty():
        print(f"imu-allan sweep: {msg}", file=sys.stderr)
