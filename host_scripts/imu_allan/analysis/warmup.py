"""Warm-up and stationarity in ``imu-allan analyze``: the windows of the same
file (dynamic.py) tested, the warm-up reported, the terms recomputed without
it, and ``--skip SECONDS`` to drop a leading stretch by hand."""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Iterator, Optional

import numpy as np

from ..device.records import DeviceReport, LRow
from ..errors import InputError


def _skip_blocks(blocks: Iterator[np.ndarray], k: int) -> Iterator[np.ndarray]:
    for b in blocks:
        if k >= b.shape[-1]:
            k -= b.shape[-1]
            continue
        yield b[..., k:] if k else b
        k = 0


def report_since(reports: list[DeviceReport], n_from: int) -> DeviceReport:
    """The last report minus the first one of its run sent at or after sample
    ``n_from``: the device's exact sums over the pairs completed in between, as
    a report (header ``n`` the samples in between; no T or S lines)."""
    from .dynamic import runs

    run = runs(reports)[-1]
    first = next((r for r in run if r.header.n >= n_from), None)
    last = run[-1]
    if first is None or first is last:
        raise InputError(
            f"--skip: no report of the last run after sample {n_from} and before its last "
            "(the device's sums can only be cut at a report)"
        )
    before = {(r.channel, r.level): r for r in first.rows}
    rows = []
    for r in last.rows:
        b = before.get((r.channel, r.level))
        bp, ba, bf = (b.pairs, b.acc, b.flags) if b else (0, 0, 0)
        rows.append(LRow(r.channel, r.level, r.pairs - bp, r.acc - ba, r.flags | bf))
    head = dataclasses.replace(last.header, n=last.header.n - first.header.n)
    return DeviceReport(last.seq, head, rows)


def skipped(src: Any, path: str, skip_s: float, fs: Optional[float] = None) -> tuple[Any, str, float]:
    """``src`` without its first ``skip_s`` seconds, a note saying so, and the seconds
    left out: ``skip_s`` for rows, cut at the sample asked; for a device log the time
    of its first report at or after it (its sums can only be cut at a report)."""
    if skip_s <= 0:
        return src, "", 0.0
    if src.samples is not None:
        fs = src.samples.fs or (float(src.report.header.fs_hz) if src.report else None) or fs
        if fs is None:
            raise InputError("--skip needs the sample rate: give --fs HZ")
        k = int(round(skip_s * fs))
        old, old_t = src.samples.open_blocks, src.samples.open_temperature
        samples = dataclasses.replace(
            src.samples,
            open_blocks=lambda: _skip_blocks(old(), k),
            open_temperature=(lambda: _skip_blocks(old_t(), k)) if old_t else None,
            n_hint=max(src.samples.n_hint - k, 0) if src.samples.n_hint else None,
        )
        note = f"the first {skip_s:g} s ({k} samples) left out (--skip)"
        return dataclasses.replace(src, samples=samples), note, skip_s
    from ..device.records import decode_bytes

    with open(path, "rb") as f:
        reports = decode_bytes(f.read()).reports
    fs = float(src.report.header.fs_hz)
    rep = report_since(reports, int(round(skip_s * fs)))
    cut = (src.report.header.n - rep.header.n) / fs
    return (
        dataclasses.replace(src, report=rep),
        f"the first {cut:g} s left out (--skip {skip_s:g}: the device's sums cut at the first "
        "report after it; its report minus that one)",
        cut,
    )


def warmup_section(
    doc: dict[str, Any],
    src: Any,
    path: str,
    fs: Optional[float],
    rerun: Callable[[Any], dict[str, Any]],
    store: Any = None,
) -> None:
    """Adds ``doc["warmup"]``: the windows' test (dynamic.py) on the same data,
    the warm-up per channel, stationarity, and the terms without the warm-up."""
    from . import dynamic
    from .windows import windows_of

    chans = list(doc.get("channels", {}))
    try:
        ws, notes = windows_of(src, path, "auto", fs or doc["source"].get("fs_hz"), chans, store=store)
    except InputError as exc:
        doc["warmup"] = {"tested": False, "why": str(exc)}
        return
    if len(ws.t0) < 4:
        doc["warmup"] = {"tested": False, "why": f"{len(ws.t0)} windows: too few to compare"}
        return
    v = dynamic.assess(ws)
    out: dict[str, Any] = {
        "tested": True,
        "windows": len(ws.t0),
        "from": ws.source,
        "level": v.level,
        "warmup_s": dict(v.warmup_s),
        "stationary": {ch: v.stationary[ch] for ch in ws.channels},
        "tau_range_s": {ch: (list(v.tau_range_s[ch]) if v.tau_range_s[ch] else None) for ch in ws.channels},
        "notes": notes,
    }
    from .windows import adev_list as _devs

    out["temp_move_codes"] = dynamic.TEMP_MOVE
    out["temp_bins"] = [
        {
            "temp": b["temp"],
            "windows": b["windows"],
            "adev": {ch: _devs(b["var"][c]) for c, ch in enumerate(ws.channels)},
        }
        for b in dynamic.temperature_bins(ws)
    ]
    warm = [w for w in v.warmup_s.values() if w is not None]
    if warm:
        cut = max(warm)
        try:
            other, note, left_out = skipped(src, path, cut, fs or doc["source"].get("fs_hz"))
            without = rerun(other)
            out["without_warmup"] = {
                "skip_s": cut,
                "left_out_s": left_out,
                "note": note,
                "terms": {ch: c.get("terms") for ch, c in without["channels"].items()},
            }
        except InputError as exc:
            out["without_warmup"] = {"skip_s": cut, "why": str(exc)}
    doc["warmup"] = out


def warmup_text(doc: dict[str, Any]) -> str:
    w = doc.get("warmup")
    if not w:
        return ""
    if not w.get("tested"):
        return f"Warm-up and stationarity: not tested ({w.get('why')})\n"
    lines = [
        f"Warm-up and stationarity ({w['windows']} windows from {w['from']}; "
        f"{w['level']:.0%} confidence per channel; details: imu-allan dynamic):"
    ]
    for ch, warm in w["warmup_s"].items():
        text = f"  {ch}: " + (f"warm-up {warm:.0f} s" if warm is not None else "no warm-up")
        if not w["stationary"][ch]:
            tr = w["tau_range_s"][ch]
            text += "; NOT stationary" + (f" (windows depart at tau {tr[0]:.3g}-{tr[1]:.3g} s)" if tr else "")
        lines.append(text)
    if w.get("temp_bins"):
        b = w["temp_bins"]
        lines.append(
            f"  temperature moved > {w['temp_move_codes']:g} codes: {len(b)} bins "
            f"({b[0]['temp'][0]:g}-{b[-1]['temp'][1]:g}), a curve each in --json (warmup.temp_bins)"
        )
    wo = w.get("without_warmup")
    if wo and "terms" in wo:
        gone = wo.get("left_out_s", wo["skip_s"])
        at = f" (the device's sums cut at its first report after {wo['skip_s']:.0f} s)" if gone != wo["skip_s"] else ""
        lines.append(f"  terms without the first {gone:.0f} s{at}:")
        for ch, ts in wo["terms"].items():
            vals = [f"{k} {t['value']:.4g}" for k, t in (ts or {}).items() if t]
            with_ = [f"{k} {t['value']:.4g}" for k, t in (doc["channels"][ch].get("terms") or {}).items() if t]
            lines.append(f"    {ch}: {', '.join(vals) or 'none'}   (with it: {', '.join(with_) or 'none'})")
    elif wo:
        lines.append(f"  terms without the warm-up: not computed ({wo.get('why')})")
    return "\n".join(lines) + "\n"
