"""Output of Allan tables (decode, reference): text, JSON and CSV.

One document shape for every command that prints a table:
    {"header": {...}, "rows": [row, ...], "errors": {name: count}}
with rows
    {"channel", "level", "m", "tau_s", "pairs", "covers", "acc",
     "avar", "adev", "flags"}
avar/adev are in ADC counts (code^2, code); null when pairs is 0.
"""
from __future__ import annotations

import csv
import io
import json
import math
from typing import Any, Iterable, Optional

Doc = dict[str, Any]

CSV_COLUMNS = ("channel", "level", "m", "tau_s", "pairs", "covers", "acc", "avar", "adev", "flags")


def row_dict(channel: str, level: int, pairs: int, acc: Optional[int], avar: float,
             fs_hz: float, flags: Iterable[str] = ()) -> dict[str, Any]:
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


def to_json(doc: Doc) -> str:
    return json.dumps(doc, indent=1, allow_nan=False) + "\n"


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


def _g(v: Optional[float]) -> str:
    return "-" if v is None else f"{v:.6g}"


def table(rows: list[dict[str, Any]]) -> str:
    lines = [f"{'ch':<4} {'level':>5} {'m':>7} {'tau_s':>10} {'pairs':>10} "
             f"{'avar':>12} {'adev':>12}  flags"]
    for r in rows:
        lines.append(f"{r['channel']:<4} {r['level']:>5} {r['m']:>7} {r['tau_s']:>10.6g} "
                     f"{r['pairs']:>10} {_g(r['avar']):>12} {_g(r['adev']):>12}  "
                     f"{' '.join(r['flags'])}".rstrip())
    return "\n".join(lines) + "\n"


def _v(x: Any) -> str:
    return "?" if x is None else str(x)


def device_header_text(h: dict[str, Any]) -> str:
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
        lines.append(f"  mode {_v(h.get('mode'))}, range {_v(h.get('range_g'))} g, "
                     f"settings {_v(h.get('cfg'))}")
    if h["clips"] is not None:
        lines.append("  clips (codes at 0 or 1023): "
                     + "  ".join(f"{k} {v}" for k, v in h["clips"].items()))
    t = h["temp"]
    lines.append("  temp code this interval: " + (
        "-" if t is None else f"mean {t['mean']:g}, min {t['min']}, max {t['max']}"))
    if h.get("extra"):
        lines.append("  other keys: " + ", ".join(f"{k}={v}" for k, v in h["extra"].items()))
    return "\n".join(lines) + "\n"


def errors_text(errors: dict[str, int]) -> str:
    bad = {k: v for k, v in errors.items() if v}
    return "not used: " + (", ".join(f"{k} {v}" for k, v in bad.items()) if bad else "nothing") + "\n"


def sig3(v: float) -> str:
    """3 significant digits as the device's summary prints them:
    ``0.0100``, ``2.02``, ``164``, ``1.23e-4`` below 0.001."""
    if v == 0:
        return "0"
    if v < 1e-3:
        mant, exp = f"{v:.2e}".split("e")
        return f"{mant}e{int(exp)}"
    if v >= 999.5:
        return f"{v:.0f}"
    return f"{v:#.3g}".rstrip(".")


def adev_table(rows: list[dict[str, Any]], channels: Iterable[str]) -> str:
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
