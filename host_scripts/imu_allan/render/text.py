"""The text a person reads: tables and summaries (the files for other programs,
JSON, CSV and YAML, are formats.py, from the same documents).

* Allan tables (``decode``, ``reference``, ``monitor``): one document shape
      {"header": {...}, "rows": [row, ...], "errors": {name: count}}
  with rows {"channel", "level", "m", "tau_s", "pairs", "covers", "acc",
  "avar", "adev", "flags"}; avar/adev in ADC counts (code^2, code), null
  when pairs is 0.
* The analysis document (``analyze``): terminal text (see docs/analysis.md
  for every unit and convention).
"""

from __future__ import annotations

import math
import textwrap
from typing import Any, Iterable, Optional

from ..channels import CHANNELS
from ..device.consistency import sig3
from ..device.records import DeviceReport, flag_names
from ..profiles import LITERATURE
from ..sources.source import KIND_NAMES
from .answer import answer_table, device_n_note

NAMES = {"Q": "quantization", "N": "random walk", "B": "bias instability", "K": "rate random walk", "R": "rate ramp"}
ACC, GYRO = ("ax", "ay", "az"), ("gx", "gy", "gz")


# ---- Allan tables: decode, reference, monitor ----------------------------------------

Doc = dict[str, Any]


def report_doc(rep: DeviceReport) -> Doc:
    """A complete device report as the ``{header, rows}`` document of ``decode --json``."""
    fs = rep.header.fs_hz
    doc = {
        "header": rep.header.as_dict(),
        "rows": [row_dict(r.channel, r.level, r.pairs, r.acc, r.avar, fs, flag_names(r.flags)) for r in rep.rows],
    }
    if rep.terms:
        doc["terms"] = terms_doc(rep, fs)
    return doc


def terms_doc(rep: DeviceReport, fs: float) -> dict[str, Any]:
    """The device's own noise terms (T records) as ``decode --json`` shows them:
    ``{ch: {"N": {"value", "tau_s", "pairs", "pct"}, "B": {...}}}``, N in
    count*sqrt(s), B in counts, as printed (3 significant digits), with the
    pairs of the level each was read at and the uncertainty they give,
    100/sqrt(2 pairs) percent (white noise, non-overlapping); a term the device
    could not read off is null."""
    pairs = {(r.channel, r.level): r.pairs for r in rep.rows}

    def one(ch: str, t: Any) -> Optional[dict[str, Any]]:
        if t.level is None:
            return None
        p = pairs.get((ch, t.level), 0)
        return {
            "value": t.value,
            "tau_s": 2**t.level / fs,
            "pairs": p,
            "pct": round(100.0 / (2.0 * p) ** 0.5, 3) if p else None,
        }

    return {ch: {"N": one(ch, t.N), "B": one(ch, t.B)} for ch, t in rep.terms.items()}


def decode_text(docs: list[Doc], total: int, log: str, every: bool, errors: dict[str, int]) -> str:
    """``imu-allan decode``: the last report (or every one) and what was not used."""
    out = []
    for i, d in enumerate(docs):
        which = (
            f"{i + 1} of {total}"
            if every
            else ("the only complete report" if total == 1 else f"the last of {total} complete reports")
        )
        out.append(f"{log}: report seq {d['header']['seq']} ({which})\n")
        out.append(device_header_text(d["header"]) + "\n")
        out.append(table(d["rows"]) + "\n")
    out.append(errors_text(errors))
    return "".join(out)


def reference_doc(cascade: Any, file: str, fs: float) -> Doc:
    """The ``{header, rows}`` document of ``imu-allan reference`` from a
    finished ``stats.reference.OctaveCascade``."""
    pairs, acc, avar = cascade.pairs(), cascade.acc(), cascade.avar()
    rows = [
        row_dict(ch, k, int(pairs[k, c]), acc[k][c], float(avar[k, c]), fs)
        for c, ch in enumerate(CHANNELS)
        for k in range(cascade.levels)
    ]
    header = {"source": "reference", "file": file, "fs_hz": fs, "levels": cascade.levels, "n": cascade.n}
    return {"header": header, "rows": rows}


def reference_text(doc: Doc) -> str:
    h = doc["header"]
    return (
        f"{h['file']}: float64 reference, n {h['n']} rows "
        f"({h['n'] / h['fs_hz']:.6g} s at {h['fs_hz']} Hz), levels {h['levels']}\n\n" + table(doc["rows"])
    )


def row_dict(
    channel: str, level: int, pairs: int, acc: Optional[int], avar: float, fs_hz: float, flags: Iterable[str] = ()
) -> dict[str, Any]:
    m = 1 << level
    ok = pairs > 0 and math.isfinite(avar)
    return {
        "channel": channel,
        "level": level,
        "m": m,
        "tau_s": m / fs_hz,
        "pairs": pairs,
        "covers": (pairs + 1) * m,
        "acc": acc,
        "avar": avar if ok else None,
        "adev": math.sqrt(avar) if ok else None,
        "flags": list(flags),
    }


def _g(v: Optional[float]) -> str:
    return "-" if v is None else f"{v:.6g}"


def table(rows: list[dict[str, Any]]) -> str:
    # the device's sums are in ADC codes: avar in code^2, adev in code
    lines = [
        f"{'ch':<4} {'level':>5} {'m':>7} {'tau_s':>10} {'pairs':>10} {'avar code^2':>12} {'adev code':>12}  flags"
    ]
    for r in rows:
        lines.append(
            f"{r['channel']:<4} {r['level']:>5} {r['m']:>7} {r['tau_s']:>10.6g} "
            f"{r['pairs']:>10} {_g(r['avar']):>12} {_g(r['adev']):>12}  "
            f"{' '.join(r['flags'])}".rstrip()
        )
    return "\n".join(lines) + "\n"


def _v(x: Any) -> str:
    return "?" if x is None else str(x)


def device_header_text(h: dict[str, Any]) -> str:
    """The header of a device report (its ``as_dict()``) for people."""
    fs = h["fs_hz"]
    running = {True: "yes", False: "no", None: "?"}[h["running"]]
    reset = "?" if h["reset_cause"] is None else "+".join(h["reset_cause"]) or "none"
    lines = [
        f"  proto {h['version']}, fw {_v(h['fw'])}, mcu {_v(h['mcu'])}, "
        f"fcpu {_v(h['fcpu_hz'])} Hz, baud {_v(h['baud'])}",
        f"  fs {fs} Hz, levels {h['levels']}, n {h['n']} samples ({h['n'] / fs:.6g} s), "
        f"drops {_v(h['drops'])}, running {running}, reset {reset}",
    ]
    if any(h.get(k) is not None for k in ("mode", "range_g", "cfg")):
        lines.append(f"  mode {_v(h.get('mode'))}, range {_v(h.get('range_g'))} g, settings {_v(h.get('cfg'))}")
    if h["clips"] is not None:
        lines.append("  clips (codes at 0 or 1023): " + "  ".join(f"{k} {v}" for k, v in h["clips"].items()))
    t = h["temp"]
    lines.append(
        "  temp code this interval: " + ("-" if t is None else f"mean {t['mean']:g}, min {t['min']}, max {t['max']}")
    )
    extra = dict(h.get("extra") or {})
    rx = _rx_counters(extra.get("rx"))
    if rx is not None:
        del extra["rx"]
        lines.append(
            f"  link since power-up: {rx[0]} UART overruns, {rx[1]} bytes lost to the full "
            f"receive ring, {rx[2]} command lines refused (error:5), {rx[3]} timed out (error:7)"
        )
    if extra:
        lines.append("  other keys: " + ", ".join(f"{k}={v}" for k, v in extra.items()))
    return "\n".join(lines) + "\n"


def _rx_counters(text: Optional[str]) -> Optional[list[int]]:
    """The header's ``rx=<overruns>:<ringlost>:<lostlines>:<timeouts>`` (firmware with
    the console's line discipline; docs/protocol.md), or None (absent, or another shape:
    then shown as an other key)."""
    parts = (text or "").split(":")
    if len(parts) != 4 or not all(p.isdigit() and p.isascii() for p in parts):
        return None
    return [int(p) for p in parts]


def errors_text(errors: dict[str, int]) -> str:
    bad = {k: v for k, v in errors.items() if v}
    return "not used: " + (", ".join(f"{k} {v}" for k, v in bad.items()) if bad else "nothing") + "\n"


def device_adev_table(rows: list[dict[str, Any]], channels: Iterable[str]) -> str:
    """Allan deviation in counts, one line per tau (levels with pairs), one
    column per channel; a flagged value ends in ``!``, a missing one is ``-``."""
    chans = list(channels)
    by_level: dict[int, dict[str, dict[str, Any]]] = {}
    for r in rows:
        by_level.setdefault(r["level"], {})[r["channel"]] = r
    lines = [f"{'tau_s':>10}" + "".join(f"{c:>9}" for c in chans)]
    for level in sorted(by_level):
        cells = by_level[level]
        if not any(r["pairs"] > 0 for r in cells.values()):
            continue
        tau = next(iter(cells.values()))["tau_s"]
        out = []
        for c in chans:
            r = cells.get(c)
            if r is None or r["adev"] is None:
                out.append("-")
            else:
                out.append(sig3(r["adev"]) + ("!" if r["flags"] else ""))
        lines.append(f"{sig3(tau):>10}" + "".join(f"{x:>9}" for x in out))
    return "\n".join(lines) + "\n"


# ---- the analysis document ---------------------------------------------------------------


def g(v: Optional[float], digits: int = 3) -> str:
    return "-" if v is None else f"{v:.{digits}g}"


def literature_value(c: dict[str, Any], term: str) -> tuple[str, float]:
    return LITERATURE[c["kind"]][term]


def _duration(s: float) -> str:
    if s >= 3600:
        return f"{s / 3600:.3g} h"
    if s >= 60:
        return f"{s / 60:.3g} min"
    return f"{s:.3g} s"


def text(doc: dict[str, Any]) -> str:
    """``imu-allan analyze`` for people: the answer table first (answer.py), then
    how each figure was found, channel by channel, then the curve."""
    src = doc["source"]
    kind = KIND_NAMES[src["kind"]]
    lines = [
        f"{src['file']}: {kind}, {src['n']} samples at {src['fs_hz']:g} Hz "
        f"({_duration(src['duration_s'])}), profile {doc['profile']['name']}",
        "",
    ]
    lines += answer_table(doc).rstrip("\n").split("\n")
    lines += ["", "Details"]
    lines += [f"  {n}" for n in doc["notes"]]
    stat = (
        "the device's non-overlapping Allan deviation"
        if src["kind"] == "device-log"
        else "the overlapping Allan deviation"
    )
    lines += textwrap.wrap(
        f"Each term is fitted to {stat} at octave taus (whatever --taus shows), with its 95 % "
        "interval, first in the rate unit of the channel, then in the unit datasheets quote; "
        "'dominates': the tau range where the term makes at least half the Allan variance.",
        80,
    )
    explained = False
    for ch, c in doc["channels"].items():
        lines += ["", f"{ch} [{c['unit']}]"]
        lines += outlier_lines(c)
        lines += _term_lines(c)
        lines += _process_lines(c)
        lines += _check_lines(c, explain_fit=not explained)
        explained = explained or "model" in c
    lines.append("")
    lines += adev_table(doc).split("\n")
    return "\n".join(wrap80(lines)) + "\n"


def wrap80(lines: list[str]) -> list[str]:
    """Lines longer than 80 columns broken at spaces, the rest indented under their start."""
    out = []
    for line in lines:
        if len(line) <= 80:
            out.append(line)
            continue
        lead = len(line) - len(line.lstrip(" "))
        out += textwrap.wrap(line.strip(), 80, initial_indent=" " * lead, subsequent_indent=" " * (lead + 4))
    return out


def _term_lines(c: dict[str, Any]) -> list[str]:
    """The five IEEE 952 terms of a channel: value, interval, where it dominates."""
    lines = []
    for k in ("N", "B", "K", "Q", "R"):
        t = c["terms"][k]
        lu, lf = literature_value(c, k)
        head = f"  {k} {NAMES[k]:<17}"
        if t is None:
            note = c["term_notes"].get(k, "not identifiable")
            ub = c["upper_bounds"].get(k)
            bound = (
                f" (95 % upper bound {g(ub)} {c['term_units'][k]} = {g(ub * lf if ub else None)} {lu})"
                if ub is not None and not note.startswith("not in")
                else ""
            )
            lines.append(f"{head}{note.split(' (')[0]}{bound}")
            continue
        rng = t["tau_range_s"]
        lines.append(
            f"{head}{g(t['value'])} [{g(t['low'])}, {g(t['high'])}] {c['term_units'][k]}"
            f"  = {g(t['value'] * lf)} [{g(t['low'] * lf)}, {g(t['high'] * lf)}] {lu}"
            + (f"  dominates {g(rng[0])} .. {g(rng[1])} s" if rng else "")
        )
        if c["term_notes"].get(k):  # how it was bounded or where it was read
            lines.append(f"{'':21}{c['term_notes'][k]}")
    return lines


FIT_PERCENT_WORD = (
    "FIT% (the thesis') = 100 (1 - |data - model| / |data|) on log10 of the curves; "
    "unit-free: divided by |data - mean(data)| instead, so 100 % is a perfect match, 0 % no "
    "better than a constant, below 0 % worse. The time series FIT% compares one random draw "
    "of the model with the recording sample by sample: two independent noises of equal "
    "power score about -41 % even for a perfect model, so only the ADEV and PSD figures "
    "grade the model (docs/analysis.md)"
)


def _check_lines(c: dict[str, Any], explain_fit: bool = True) -> list[str]:
    """How far to trust the channel's terms: the thesis' read-off of B, the fit's
    chi2, the thesis model's FIT%, the device's points against the host's."""
    lines = []
    bc = c.get("b_classic")
    if bc:
        lu, lf = literature_value(c, "B")
        lines.append(
            f"  B by the thesis' read-off min(ADEV)/0.664: {g(bc['value'])} {c['unit']} "
            f"= {g(bc['value'] * lf)} {lu} (minimum at {g(bc['tau_s'])} s)"
        )
    fit = c["fit"]
    lines.append(
        f"  fit chi2/dof {g(fit['chi2_dof'])} on {fit['points']} points (about 1: the terms explain "
        "the curve within its intervals)"
    )
    m = c.get("model")
    fp = (m or {}).get("fit_percent") or {}
    parts = []
    if fp.get("adev_log10") is not None:
        parts.append(f"ADEV {fp['adev_log10']:.1f} % (unit-free {g(fp.get('adev_log10_nrmse'))} %)")
    if fp.get("psd_log10") is not None:
        parts.append(f"PSD {fp['psd_log10']:.1f} % (unit-free {g(fp.get('psd_log10_nrmse'))} %)")
    if fp.get("signal") is not None:
        parts.append(f"time series {fp['signal']:.1f} %")
    if parts:
        lines.append("  thesis model FIT%: " + ", ".join(parts))
        if explain_fit:
            lines += textwrap.wrap(FIT_PERCENT_WORD, 80, initial_indent="    ", subsequent_indent="    ")
    for note in fit["notes"]:
        lines.append(f"  note: {note}")
    note = device_n_note(c)
    if note:
        lines += textwrap.wrap(note, 80, initial_indent="  device's ", subsequent_indent="    ")
    dev = c.get("device")
    if dev and dev.get("agreement"):
        a = dev["agreement"]
        lines.append(
            f"  device vs host: {a['within']} of {a['checked']} device points hold the host's "
            f"value within their {a['level'] * 100:.0f} % interval"
            + (f" (outside at {', '.join(g(t) for t in a['outside_tau_s'])} s)" if a["outside_tau_s"] else "")
        )
    return lines


def outlier_lines(c: dict[str, Any]) -> list[str]:
    """The channel's spikes and bursts, next to the terms they would move."""
    o = c.get("outliers")
    if not o or not o.get("checked") or not (o["count"] or o.get("steps_s")):
        return []
    out = []
    if o["count"]:
        times = o["times_s"]
        at = ", ".join(g(t, 6) for t in times[:5]) + (f" ... ({len(times)} in all)" if len(times) > 5 else "")
        how = (
            "replaced by the line between their neighbours"
            if o["mode"] == "replace"
            else "kept in the statistics (--outliers keep)"
        )
        out.append(
            f"  outliers: {o['count']} samples in {len(times)} event{'s' * (len(times) != 1)} "
            f"(spikes, bursts) at {at} s: {how}"
        )
        eff = o.get("effect") or {}
        parts = [
            f"{k} {v['change_pct']:+.3g} % ({g(v['without_outliers'])} -> {g(v['with_outliers'])})"
            for k, v in eff.items()
            if v.get("change_pct") is not None
        ]
        if parts:
            out.append("            with them in, " + ", ".join(parts))
    if o.get("steps_s"):
        out.append(
            f"  level shifts (kept): {len(o['steps_s'])} at " + ", ".join(g(t, 6) for t in o["steps_s"][:5]) + " s"
        )
    return out


def _lp_form(t: dict[str, Any]) -> str:
    if t.get("shape") == "average":
        return "moving average" if t["order"] == 1 else "two averages (Bartlett)"
    poles = f"{'one' if t['order'] == 1 else 'two'}-pole"
    return poles + " averaged over each sample" if t.get("shape") == "pole_mean" else poles


def _process_lines(c: dict[str, Any]) -> list[str]:
    """The fitted processes beyond the IEEE 952 five: band limit, Gauss-Markov, sinusoid;
    and the IEEE 952 slope reading beside the whole-curve fit."""
    out = []
    for k, t in c["terms"].items():
        if t is None or k in NAMES:
            continue
        if k == "LP":
            out.append(
                f"  LP band limit         fc {g(t['fc'])} [{g(t['fc_low'])}, {g(t['fc_high'])}] Hz, "
                f"{_lp_form(t)}: the white noise N reaches the samples "
                f"through it (the curve bends under N's line up to {g(t['tau_range_s'][1])} s)"
            )
        elif k.startswith("GM"):
            out.append(
                f"  {k:<3} Gauss-Markov      sigma {g(t['value'])} [{g(t['low'])}, {g(t['high'])}] {c['unit']}"
                f", tau_c {g(t['tau_c'])} [{g(t['tau_c_low'])}, {g(t['tau_c_high'])}] s"
            )
        elif k == "SIN":
            out.append(
                f"  SIN oscillation       amplitude {g(t['value'])} [{g(t['low'])}, {g(t['high'])}] "
                f"{c['unit']} at {g(t['f0_hz'])} Hz"
            )
        elif k == "RES":
            out.append(
                f"  RES resonance         sd {g(t['value'])} [{g(t['low'])}, {g(t['high'])}] {c['unit']} at "
                f"{g(t['f0_hz'])} [{g(t['f0_low'])}, {g(t['f0_high'])}] Hz, quality {g(t['quality'])}"
            )
        else:
            continue
        if c["term_notes"].get(k) and k != "LP":
            out.append(f"{'':21}{c['term_notes'][k]}")
    fit = c.get("fit", {})
    if fit.get("model"):
        out.append(f"  model: {fit['model']}")
    sr = fit.get("slope_reading") or {}
    if sr:
        out.append(
            "  IEEE 952 slope reading (cross-check): "
            + ", ".join(f"{k} {g(v['value'])} ({g(v['tau_s'][0])} .. {g(v['tau_s'][1])} s)" for k, v in sr.items())
        )
    return out


def adev_table(doc: dict[str, Any]) -> str:
    """The fitted curve of every channel: tau rows, channel columns (rate units)."""
    chans = list(doc["channels"])
    by_tau: dict[float, dict[str, Any]] = {}
    for ch in chans:
        for p in doc["channels"][ch]["curve"]:
            by_tau.setdefault(round(p["tau_s"], 12), {})[ch] = p
    name = "device's non-overlapping" if doc["source"]["kind"] == "device-log" else "overlapping"
    head = f"Allan deviation ({name}), rate units:"
    cols = f"{'tau_s':>8}" + "".join(f"{ch + ' ' + doc['channels'][ch]['unit']:>12}" for ch in chans)
    rows = [head, cols]
    taus = sorted(by_tau)
    if len(taus) > 40:  # dense grids: every k-th row
        step = math.ceil(len(taus) / 40)
        taus = taus[::step] + ([taus[-1]] if (len(taus) - 1) % step else [])
    for t in taus:
        cells = []
        for ch in chans:
            p = by_tau[t].get(ch)
            if p is None or p["dev"] is None:
                cells.append("-")
            else:
                cells.append(g(p["dev"]) + ("!" if p.get("flags") else ""))
        rows.append(f"{g(t):>8}" + "".join(f"{x:>12}" for x in cells))
    if any(p.get("flags") for ch in chans for p in doc["channels"][ch]["curve"]):
        rows.append("! flagged by the device (sat or range): shown, not fitted")
    return "\n".join(rows)
