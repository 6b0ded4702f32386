"""The answer first: the table ``imu-allan analyze`` opens with (and all that
``--brief`` prints): a row per channel with N, B and K and their 95 % intervals
in the units datasheets quote (deg/sqrt(h), deg/h, m/s/sqrt(h), ug ...), the
other fitted processes (band limit, Gauss-Markov, oscillation, Q, R) on a line
under their channel, and, for a device log, how the device's own N differs from
the fitted one and why.  At most 80 columns."""

from __future__ import annotations

import math
import textwrap
from typing import Any, Optional

from ..profiles import LITERATURE

WIDTH = 80
MAIN = ("N", "B", "K")
HEAD = {"N": "N white noise", "B": "B bias instab.", "K": "K rate rand. walk"}
GROUPS = (("gyros", "gyro"), ("accelerometers", "acc"), ("channels in counts", "counts"))


def num(v: Optional[float]) -> str:
    """Three significant digits, without an exponent from 0.001 to 999999."""
    if v is None or not math.isfinite(v):
        return "-"
    s = f"{v:.3g}"
    if "e" in s and 1.0 <= abs(v) < 1e6:
        return str(int(float(s)))
    return s


def cell(t: Optional[dict[str, Any]], factor: float, bound: Optional[float]) -> str:
    """A term's value and 95 % interval, or '< bound' when the data do not show it."""
    if t is None:
        return "-" if bound is None else f"< {num(bound * factor)}"
    return f"{num(t['value'] * factor)} [{num(t['low'] * factor)}, {num(t['high'] * factor)}]"


def _extra_terms(c: dict[str, Any]) -> list[str]:
    lit = LITERATURE[c["kind"]]
    out = []
    for k, t in c["terms"].items():
        if t is None or k in MAIN:
            continue
        if k == "LP":
            out.append(f"LP fc {num(t['fc'])} Hz")
        elif k.startswith("GM"):
            out.append(
                f"{k} sigma {num(t['value'])} [{num(t['low'])}, {num(t['high'])}] {c['unit']}, "
                f"tau_c {num(t['tau_c'])} s"
            )
        elif k == "SIN":
            out.append(f"SIN {num(t['value'])} {c['unit']} at {num(t['f0_hz'])} Hz")
        elif k == "RES":
            out.append(f"RES {num(t['value'])} {c['unit']} at {num(t['f0_hz'])} Hz, quality {num(t['quality'])}")
        elif k in lit:
            unit, f = lit[k]
            out.append(f"{k} {'quantization' if k == 'Q' else 'rate ramp'} {cell(t, f, None)} {unit}")
    return out


def device_n_note(c: dict[str, Any]) -> Optional[str]:
    """One sentence when the device's N (read at one tau) differs from the fitted N."""
    d = (c.get("device_terms") or {}).get("N")
    if not d or not d.get("differs"):
        return None
    unit, f = LITERATURE[c["kind"]]["N"]
    s = f"N {num(d['value'] * f)} {unit} is adev*sqrt(tau) read at one tau, {num(d['tau_s'])} s"
    if d.get("other_share_pct") is not None and d.get("model_at_tau") is not None:
        s += (
            f", where the other terms add {d['other_share_pct']:.0f} % to the deviation (the fitted "
            f"terms give {num(d['model_at_tau'] * f)} there)"
        )
    return s + f"; the fit over the whole curve separates them: N {num(d['fit'] * f)} {unit}"


def device_n_footnote(doc: dict[str, Any]) -> list[str]:
    """The device's N where it differs from the fit, for all channels in a few lines."""
    diff = {ch: c["device_terms"]["N"] for ch, c in doc["channels"].items() if device_n_note(c)}
    if not diff:
        return []
    taus = sorted({num(d["tau_s"]) for d in diff.values()}, key=float)
    by_unit: dict[str, list[str]] = {}
    for ch, d in diff.items():
        unit, f = LITERATURE[doc["channels"][ch]["kind"]]["N"]
        by_unit.setdefault(unit, []).append(f"{ch} {num(d['value'] * f)}")
    vals = "; ".join(", ".join(v) + f" {u}" for u, v in by_unit.items())
    shares = [d["other_share_pct"] for d in diff.values() if d.get("other_share_pct") is not None]
    text = (
        f"! The device's summary reads N as adev*sqrt(tau) at one tau ({', '.join(taus)} s): {vals}. "
        "The fit separates N from the other terms over the whole curve"
        + (f"; at that tau they add {min(shares):.0f} .. {max(shares):.0f} % to the deviation" if shares else "")
        + " (each channel in the details)."
    )
    return textwrap.wrap(text, WIDTH, break_on_hyphens=False)


def _rows(chans: dict[str, Any], kind: str) -> list[list[str]]:
    lit = LITERATURE[kind]
    return [
        [ch] + [cell(c["terms"].get(k), lit[k][1], c["upper_bounds"].get(k)) for k in MAIN] for ch, c in chans.items()
    ]


def _group(title: str, kind: str, chans: dict[str, Any]) -> list[str]:
    lit = LITERATURE[kind]
    rows = _rows(chans, kind)
    heads = [[title] + [HEAD[k] for k in MAIN], [""] + [lit[k][0] for k in MAIN]]
    widths = [max(len(r[i]) for r in rows + heads) for i in range(4)]
    if sum(widths) + 2 * 3 > WIDTH:  # intervals too wide: each on a line under its value
        return _group_split(heads, rows, chans)
    out = ["  ".join(h[i].ljust(widths[i]) for i in range(4)).rstrip() for h in heads]
    for r, c in zip(rows, chans.values()):
        out.append("  ".join(r[i].ljust(widths[i]) for i in range(4)).rstrip())
        out += _under(c)
    return out


def _group_split(heads: list[list[str]], rows: list[list[str]], chans: dict[str, Any]) -> list[str]:
    w = [max(len(heads[0][0]), 4)] + [24] * 3
    out = ["  ".join(h[i][: w[i]].ljust(w[i]) for i in range(4)).rstrip() for h in heads]
    for r, c in zip(rows, chans.values()):
        vals = [x.split(" [", 1) for x in r[1:]]
        out.append("  ".join([r[0].ljust(w[0])] + [v[0].ljust(24) for v in vals]).rstrip())
        out.append("  ".join([" " * w[0]] + [("[" + v[1] if len(v) > 1 else "").ljust(24) for v in vals]).rstrip())
        out += _under(c)
    return out


def _under(c: dict[str, Any]) -> list[str]:
    """The line(s) under a channel's row: its other processes, and what could
    mislead in the row (a constant channel, spikes taken out)."""
    out = []
    if not any(p.get("dev") for p in c.get("curve") or []):
        out.append("    ! constant (the same value in every sample): no noise to fit")
    o = c.get("outliers") or {}
    if o.get("count"):
        how = "replaced" if o.get("mode") == "replace" else "kept"
        out.append(f"    ! {o['count']} samples of spikes or bursts {how} (see the details)")
    extra = _extra_terms(c)
    if extra:
        out += textwrap.wrap("; ".join(extra), WIDTH, initial_indent="    + ", subsequent_indent="      ")
    return out


def answer_table(doc: dict[str, Any], brief: bool = False) -> str:
    """The first table of ``analyze``: every channel's noise terms, one row each
    (``brief``: the whole output, so it points to the details instead)."""
    device = doc["source"]["kind"] == "device-log"
    curve = "the device's Allan curve" if device else "the whole Allan curve"
    lines = [f"Noise terms (IEEE 952) fitted to {curve}; 95 % intervals in [ ]"]
    for title, kind in GROUPS:
        chans = {ch: c for ch, c in doc["channels"].items() if c["kind"] == kind}
        if chans:
            lines += [""] if len(lines) > 1 else []
            lines += _group(title, kind, chans)
    lines.append("")
    lines += device_n_footnote(doc)
    lines += textwrap.wrap(
        "'< x': not seen, at most x; '-': not identifiable; '+' other processes: LP low-pass "
        "the white noise goes through, GM Gauss-Markov (tau_c its correlation time), SIN "
        "oscillation. " + ("Details without --brief." if brief else "Details below."),
        WIDTH,
        break_on_hyphens=False,
    )
    return "\n".join(lines) + "\n"
