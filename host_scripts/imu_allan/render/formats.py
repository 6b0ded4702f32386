"""The analysis and device documents as files for other programs: JSON, CSV
(the device's Allan tables, the noise terms, the curves) and the YAML of
Kalibr and imu_utils.  The text for a person is text.py."""

from __future__ import annotations

import csv
import io
import json
import math
from typing import Any, Optional

from ..errors import InputError
from .text import ACC, GYRO, NAMES, Doc, literature_value


def to_json(doc: dict[str, Any]) -> str:
    """JSON text of a document (every float finite: NaN is an error)."""
    return json.dumps(doc, indent=1, allow_nan=False) + "\n"


# ---- CSV -----------------------------------------------------------------------------------

CSV_COLUMNS = ("channel", "level", "m", "tau_s", "pairs", "covers", "acc", "avar", "adev", "flags")


def to_csv(reports: list[Doc], with_seq: bool = False) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow((("seq",) if with_seq else ()) + CSV_COLUMNS)
    for rep in reports:
        for r in rep["rows"]:
            vals = [r[c] for c in CSV_COLUMNS]
            vals[-1] = "+".join(r["flags"])
            vals = ["" if v is None else repr(v) if isinstance(v, float) else v for v in vals]
            w.writerow(([rep["header"].get("seq")] if with_seq else []) + vals)
    return buf.getvalue()


TERM_CSV = (
    "channel",
    "unit",
    "term",
    "name",
    "value",
    "low",
    "high",
    "term_unit",
    "tau_min_s",
    "tau_max_s",
    "identifiable",
    "upper_bound",
    "lit_value",
    "lit_low",
    "lit_high",
    "lit_unit",
    "note",
)


def terms_csv(doc: dict[str, Any]) -> str:
    from ..noise.terms import TERMS  # here: noise.terms imports scipy, which decode never needs

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(TERM_CSV)
    for ch, c in doc["channels"].items():
        for k in TERMS:
            t = c["terms"][k]
            lu, lf = literature_value(c, k)
            ub = c["upper_bounds"].get(k)
            if t is None:
                w.writerow(
                    [
                        ch,
                        c["unit"],
                        k,
                        NAMES[k],
                        "",
                        "",
                        "",
                        c["term_units"][k],
                        "",
                        "",
                        "no",
                        _r(ub),
                        "",
                        "",
                        "",
                        lu,
                        c["term_notes"].get(k, ""),
                    ]
                )
            else:
                rng = t["tau_range_s"] or [None, None]
                w.writerow(
                    [
                        ch,
                        c["unit"],
                        k,
                        NAMES[k],
                        _r(t["value"]),
                        _r(t["low"]),
                        _r(t["high"]),
                        c["term_units"][k],
                        _r(rng[0]),
                        _r(rng[1]),
                        "yes",
                        _r(ub),
                        _r(t["value"] * lf),
                        _r(t["low"] * lf),
                        _r(t["high"] * lf),
                        lu,
                        c["term_notes"].get(k, ""),
                    ]
                )
    return buf.getvalue()


def curves_csv(doc: dict[str, Any]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(("channel", "unit", "statistic", "tau_s", "dev", "low", "high", "edf", "noise", "flags"))
    for ch, c in doc["channels"].items():
        main = c["fit"]["statistic"].split()[0]
        sets = [(main, c["curve"])] + list(c.get("curves", {}).items())
        if c.get("device"):
            sets.append(("device_adev", c["device"]["curve"]))
        if c.get("model"):
            sets.append(("model_" + main, c["model"]["curve"]))
        for name, pts in sets:
            for p in pts:
                w.writerow(
                    [
                        ch,
                        c["unit"],
                        name,
                        _r(p["tau_s"]),
                        _r(p.get("dev")),
                        _r(p.get("low")),
                        _r(p.get("high")),
                        _r(p.get("edf")),
                        p.get("noise", ""),
                        "+".join(p.get("flags", [])),
                    ]
                )
    return buf.getvalue()


def _r(v: Optional[float]) -> str:
    return "" if v is None else repr(float(v))


# ---- Kalibr and imu_utils ---------------------------------------------------------------


NOISE_CHOICES = ("fitted", "overbound")
"""Which N and K the estimators' files carry (--noise): the fitted terms, or the
smallest pair that over-bounds the measured curve up to the horizon (overbound.py)."""


def _axis_values(
    doc: dict[str, Any], axes: tuple[str, ...], term: str, noise: str = "fitted"
) -> list[tuple[str, float, bool, str]]:
    """(axis, value in SI, identified?, note) for the axes present in physical units."""
    out = []
    for ch in axes:
        c = doc["channels"].get(ch)
        if c is None or c["unit"] == "count":
            continue
        if noise == "overbound" and term in ("N", "K"):
            ob = c["si"].get("overbound")
            if ob is not None:
                out.append((ch, ob[term], True, ""))
            continue
        t = c["si"]["terms"][term]
        factor = math.pi / 180.0 if c["unit"] == "deg/s" else 1.0
        slow = _slow_gm_as_k(doc, c) if term == "K" else None
        if t is not None and slow is not None:
            out.append((ch, math.hypot(t["value"], slow[0]), True, slow[1]))
        elif slow is not None:
            out.append((ch, slow[0], True, slow[1]))
        elif t is not None:
            out.append((ch, t["value"], True, ""))
        else:
            ub = c["upper_bounds"].get(term)
            if ub is not None:
                out.append((ch, ub * factor, False, "95 % upper bound: not identifiable"))
    return out


def _pair_comment(doc: dict[str, Any], noise: str) -> list[str]:
    """The comment lines that say which N and K pair a file carries."""
    if noise == "overbound":
        hs = sorted({c["overbound"]["horizon_s"] for c in doc["channels"].values() if c.get("overbound")})
        h = "/".join(f"{v:.3g}" for v in hs) or "?"
        return [
            "# Pair carried: OVERBOUND (--noise overbound): the smallest white noise N + random walk K",
            "#   whose Allan deviation is at or above the measured curve's 95 % upper limit at every",
            f"#   octave tau from 1/rate to {h} s (bias instability, Gauss-Markov humps and filters",
            "#   covered); the fitted values and the factors are in analyze --json (overbound).",
        ]
    return [
        "# Pair carried: FITTED (--noise fitted): the IEEE 952 N and K fitted to the curve. They",
        "#   leave out what the estimator does not model (bias instability, Gauss-Markov humps);",
        "#   --noise overbound gives the smallest pair that covers them (instead of a blind x10).",
    ]


def _slow_gm_as_k(doc: dict[str, Any], c: dict[str, Any]) -> Optional[tuple[float, str]]:
    """A Gauss-Markov process whose correlation time is longer than the record is, to
    an estimator running over the record, a bias random walk of K = sigma sqrt(2 / T)
    (its PSD 2 sigma^2 / (T w^2) above 1 / T); in SI units, with the note to say so."""
    dur = doc["source"].get("duration_s") or 0.0
    ks = []
    for k, t in c["si"]["terms"].items():
        if k.startswith("GM") and t is not None and t.get("tau_c") and t["tau_c"] > dur:
            ks.append((t["value"] * math.sqrt(2.0 / t["tau_c"]), k, t["tau_c"]))
    if not ks:
        return None
    v = math.sqrt(sum(x[0] ** 2 for x in ks))
    return v, "includes " + ", ".join(f"{k} (tau_c {T:.3g} s, longer than the record) as K" for _, k, T in ks)


def _worst(vals: list[tuple[str, float, bool, str]]) -> Optional[tuple[str, float, bool, str]]:
    return max(vals, key=lambda v: v[1]) if vals else None


def _need_physical(doc: dict[str, Any], what: str) -> None:
    if not any(c["unit"] != "count" for c in doc["channels"].values()):
        raise InputError(f"{what} needs channels in physical units: use the thesis profile or --scale")


GROUPS = (
    ("accelerometer", ACC, "m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)"),
    ("gyroscope", GYRO, "rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"),
)
"""The estimators' two sensors: their axes and the units of N and K (SI, continuous time)."""


def _per_axis(axes: tuple[str, ...], nv: list, kv: list, unit_n: str, unit_k: str, extra: Any = None) -> list[str]:
    """A comment line per axis: N and K (and ``extra(n, k)``, e.g. the discrete values)."""
    lines = []
    for ch in axes:
        n_ = next((v for v in nv if v[0] == ch), None)
        k_ = next((v for v in kv if v[0] == ch), None)
        if n_ is None and k_ is None:
            continue
        part = [f"#   {ch}:"]
        if n_:
            part.append(f"N {n_[1]:.4g} {unit_n}")
        if k_:
            part.append(f"K {k_[1]:.4g} {unit_k}" + (f" ({k_[3]})" if not k_[2] else ""))
        if extra is not None:
            part.append(extra(n_[1] if n_ else None, k_[1] if k_ else None))
        lines.append(" ".join(part))
    return lines


def _estimator_file(
    doc: dict[str, Any], what: str, noise: str, head: list[str], key: Any, extra: Any, indent: str = ""
) -> tuple[list[str], list[str]]:
    """The comment lines and the key lines of an estimator's file: per sensor, the
    worst axis's N and K (``key(group, 'N'|'K', value, unit, axis, note)`` writes a line)."""
    _need_physical(doc, what)
    lines = head + _pair_comment(doc, noise)
    body = []
    for group, axes, unit_n, unit_k in GROUPS:
        nv, kv = _axis_values(doc, axes, "N", noise), _axis_values(doc, axes, "K", noise)
        if not nv and not kv:
            lines.append(f"# {group}: no channel in physical units, left out")
            continue
        lines.append(f"# {group} per axis:")
        lines += _per_axis(axes, nv, kv, unit_n, unit_k, extra)
        wn, wk = _worst(nv), _worst(kv)
        if wn:
            body.append(indent + key(group, "N", wn[1], unit_n, wn[0], ""))
        if wk:
            body.append(indent + key(group, "K", wk[1], unit_k, wk[0], "" if wk[2] else f" ({wk[3]})"))
    return lines, body


def kalibr_yaml(doc: dict[str, Any], rostopic: str = "/imu0", noise: str = "fitted") -> str:
    fs = doc["source"]["fs_hz"]
    head = [
        f"# Kalibr IMU noise parameters (imu.yaml) from {doc['tool']} on {doc['source']['file']}",
        "# CONTINUOUS-TIME values, as Kalibr's imu.yaml expects (Kalibr discretizes them",
        f"# itself with update_rate: sigma_d = noise_density * sqrt({fs:g}) and",
        f"# sigma_bd = random_walk / sqrt({fs:g})):",
        "#   *_noise_density = N, the white-noise density (IEEE 952 random walk, ADEV at tau = 1 s",
        "#                     on the -1/2 slope); *_random_walk = K, the bias random walk density",
        "#                     (IEEE 952 rate random walk, ADEV at tau = 3 s on the +1/2 slope).",
        "# One value per sensor: the worst axis.",
    ]
    field = {"N": "noise_density", "K": "random_walk"}

    def key(group: str, term: str, v: float, unit: str, axis: str, note: str) -> str:
        return f"{group}_{field[term]}: {v:.6e}   # [{unit}] {term}, worst axis {axis}{note}"

    def discrete(n: Optional[float], k: Optional[float]) -> str:
        return f"[discrete at {fs:g} Hz: {_opt(n, math.sqrt(fs))} {_opt(k, 1 / math.sqrt(fs))}]"

    lines, body = _estimator_file(doc, "--kalibr", noise, head, key, discrete)
    body.append(f"rostopic: {rostopic}")
    body.append(f"update_rate: {fs:.6g}   # [Hz] the rate the noise was measured at")
    return "\n".join(lines + body) + "\n"


def _opt(v: Optional[float], f: float) -> str:
    return "-" if v is None else f"{v * f:.4g}"


OPENVINS_UNITS = {
    "N": ("m / s^2 / sqrt(Hz)", "rad / s / sqrt(Hz)"),
    "K": ("m / s^3 / sqrt(Hz)", "rad / s^2 / sqrt(Hz)"),
}
"""The units OpenVINS' kalibr_imu_chain.yaml writes beside each field (continuous time)."""


def openvins_yaml(doc: dict[str, Any], rostopic: str = "/imu0", noise: str = "fitted") -> str:
    """OpenVINS' ``imu0:`` block (kalibr_imu_chain.yaml): continuous-time N and K."""
    fs = doc["source"]["fs_hz"]
    head = [
        "%YAML:1.0 # need to specify the file type at the top!",
        f"# OpenVINS IMU noise (the imu0 block of kalibr_imu_chain.yaml) from {doc['tool']} on {doc['source']['file']}",
        "# Merge these keys into your kalibr_imu_chain.yaml's imu0 (keep its T_i_b, model and intrinsics).",
        "# CONTINUOUS-TIME values, as OpenVINS reads them (it discretizes with the IMU's dt):",
        "#   *_noise_density = N (white noise), *_random_walk = K (bias random walk); the worst axis.",
    ]
    field = {"N": "noise_density", "K": "random_walk"}

    def key(group: str, term: str, v: float, unit: str, axis: str, note: str) -> str:
        u = OPENVINS_UNITS[term][0 if group == "accelerometer" else 1]
        return f"{group}_{field[term]}: {v:.6e}   # [ {u} ] {term}, worst axis {axis}{note}"

    lines, body = _estimator_file(doc, "--openvins", noise, head, key, None, indent="  ")
    body += [f"  rostopic: {rostopic}", f"  update_rate: {fs:.6g}   # [Hz] the rate the noise was measured at"]
    return "\n".join(lines + ["imu0:"] + body) + "\n"


def vins_yaml(doc: dict[str, Any], noise: str = "fitted") -> str:
    """VINS-Fusion's ``acc_n acc_w gyr_n gyr_w``: discrete-time standard deviations at the rate measured."""
    fs = doc["source"]["fs_hz"]
    r = math.sqrt(fs)
    head = [
        "%YAML:1.0",
        f"# VINS-Fusion IMU noise (the 'imu parameters' of its config) from {doc['tool']} on {doc['source']['file']}",
        "# VINS-Fusion documents these as standard deviations and propagates them per IMU sample",
        "# (its pre-integration adds acc_n^2, gyr_n^2 and acc_w^2, gyr_w^2 times dt^2 at each step):",
        f"# DISCRETE-TIME values at the rate measured, {fs:g} Hz:",
        f"#   acc_n = N sqrt({fs:g}) [m/s^2]    gyr_n = N sqrt({fs:g}) [rad/s]",
        f"#   acc_w = K sqrt({fs:g}) [m/s^3]    gyr_w = K sqrt({fs:g}) [rad/s^2]",
        "# At another IMU rate f multiply all four by sqrt(f / rate). The continuous-time N and K",
        "# (Kalibr's and OpenVINS' units) are per axis below; the worst axis is the one written.",
    ]
    name = {("accelerometer", "N"): "acc_n", ("accelerometer", "K"): "acc_w"}
    name.update({("gyroscope", "N"): "gyr_n", ("gyroscope", "K"): "gyr_w"})

    def key(group: str, term: str, v: float, unit: str, axis: str, note: str) -> str:
        return f"{name[group, term]}: {v * r:.6e}   # {term} {v:.4g} {unit} x sqrt({fs:g}), worst axis {axis}{note}"

    def discrete(n: Optional[float], k: Optional[float]) -> str:
        return f"[x sqrt({fs:g}): {_opt(n, r)} {_opt(k, r)}]"

    lines, body = _estimator_file(doc, "--vins", noise, head, key, discrete)
    order = ("acc_n", "gyr_n", "acc_w", "gyr_w")
    body.sort(key=lambda ln: order.index(ln.split(":")[0]))
    return "\n".join(lines + body + [f"# rate: {fs:g} Hz"]) + "\n"


def imu_utils_yaml(doc: dict[str, Any], name: str = "imu") -> str:
    _need_physical(doc, "--imu-utils")
    fs = doc["source"]["fs_hz"]
    out = [
        "%YAML:1.0",
        "---",
        f"# imu_utils-style noise parameters from {doc['tool']} on {doc['source']['file']}",
        "# Continuous time, as imu_utils documents them (VINS-Fusion's own, discrete: --vins):",
        "#   gyr_n, acc_n = N, white-noise density [rad/s/sqrt(Hz)], [m/s^2/sqrt(Hz)]",
        "#   gyr_w, acc_w = K, bias random-walk density [rad/s^2/sqrt(Hz)], [m/s^3/sqrt(Hz)]",
        "# Caution: imu_utils itself writes into *_w the bias-instability floor (the minimum of",
        "# its fitted ADEV, 0.664 B), not K, and (gyroscope, some versions) N * sqrt(rate) into",
        "# gyr_n. Here *_w is K as the consumers use it; B is given in the comments.",
        "# avg-axis is the mean over the axes (imu_utils' convention); the worst axis is noted.",
        "type: IMU",
        f'name: "{name}"',
    ]
    for key, axes, unit, nk, wk in (
        ("Gyr", GYRO, " rad/s", "gyr_n", "gyr_w"),
        ("Acc", ACC, " m/s^2", "acc_n", "acc_w"),
    ):
        nv, kv = _axis_values(doc, axes, "N"), _axis_values(doc, axes, "K")
        if not nv and not kv:
            out.append(f"# {key}: no channel in physical units, left out")
            continue
        bv = _axis_values(doc, axes, "B")
        out.append(f"{key}:")
        out.append(f'   unit: "{unit}"')
        out.append("   avg-axis:")
        if nv:
            out.append(
                f"      {nk}: {sum(v[1] for v in nv) / len(nv):.10e}   # worst {_worst(nv)[0]}: {_worst(nv)[1]:.4g}"
            )
        if kv:
            out.append(
                f"      {wk}: {sum(v[1] for v in kv) / len(kv):.10e}   # worst {_worst(kv)[0]}: "
                f"{_worst(kv)[1]:.4g}" + ("; includes upper bounds" if any(not v[2] for v in kv) else "")
            )
        for ch, label in zip(axes, ("x-axis", "y-axis", "z-axis")):
            n_ = next((v for v in nv if v[0] == ch), None)
            k_ = next((v for v in kv if v[0] == ch), None)
            b_ = next((v for v in bv if v[0] == ch), None)
            if n_ is None and k_ is None:
                continue
            out.append(f"   {label}:")
            if n_:
                out.append(f"      {nk}: {n_[1]:.10e}")
            if k_:
                out.append(f"      {wk}: {k_[1]:.10e}" + (f"   # {k_[3]}" if not k_[2] else ""))
            if b_:
                out.append(
                    f"      # bias instability B {b_[1]:.4g} {unit.strip()}, ADEV floor 0.664 B = "
                    f"{0.664 * b_[1]:.4g}" + (" (upper bound)" if not b_[2] else "")
                )
    out.append(f"# rate: {fs:g} Hz")
    return "\n".join(out) + "\n"
