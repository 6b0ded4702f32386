"""The analysis' use of outliers.py: spikes and bursts found in the samples
before the statistics, replaced (or kept, ``--outliers keep``), and reported:
``channels.<ch>.outliers`` and the document's ``outliers`` (docs/analysis.md).

Both series' octave curves are computed when anything is found (host_pass.py),
so the report says how much N and B move with the outliers in and out."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

from ..noise import terms
from ..noise.fit import fit_curve
from ..stats import allan
from . import outliers


@dataclass
class OutlierPass:
    """The spikes and bursts of the samples in memory, and the octave curves of
    the series the statistics did not use (the raw one when they were replaced,
    the replaced one when kept), to tell how much N and B move."""

    scan: outliers.OutlierScan
    mode: str
    other: Optional[allan.OctaveResult]


def note_outliers(found: outliers.OutlierScan, mode: str, notes: list[str]) -> None:
    """The document's note on what was found and done with it."""
    ev = [e for e in found.events if not e.step]
    if mode == "replace":
        notes.append(
            f"outliers: {found.count} samples in {_events(len(ev))} replaced by the line "
            "between their neighbours before the statistics (--outliers keep keeps them)"
        )
    else:
        notes.append(f"outliers: {found.count} samples in {_events(len(ev))} kept in the statistics (--outliers keep)")


def _events(k: int) -> str:
    return f"{k} event{'s' * (k != 1)} (spikes, bursts)"


def outliers_json(
    op: Optional[OutlierPass], c_i: int, fs: float, k2: float, efn: Any, fit: terms.FitResult
) -> dict[str, Any]:
    """``channels.<ch>.outliers``: samples flagged, one time per event, the
    events, the lone level shifts kept, and how N and B move with them."""
    if op is None:
        return {"checked": False, "count": None, "times_s": []}
    ch = op.scan.channels[c_i]
    ev = op.scan.channel_events(c_i)
    out: dict[str, Any] = {
        "checked": True,
        "mode": op.mode,
        "count": ch.count,
        "times_s": [e.start / fs for e, _ in ev],
        "events": [
            {"start_s": e.start / fs, "duration_s": (e.stop - e.start) / fs, "samples": k, "peak_sigma": e.peak}
            for e, k in ev
        ],
        "steps_s": [e.start / fs for e in op.scan.channel_steps(c_i)],
        "scale": ch.scale * math.sqrt(k2),
        "threshold_sigma": outliers.SPIKE_SIGMA,
    }
    if op.other is not None and ch.count:
        res = op.other
        # the same whole-curve fit as the channel's own terms, so the change is the outliers' alone
        other = fit_curve(res.ms / fs, res.oavar[:, c_i] * k2, efn, fs=fs, overlapping=True)
        clean, raw = (fit, other) if op.mode == "replace" else (other, fit)
        out["effect"] = {k: _change(clean.terms[k].value, raw.terms[k].value) for k in ("N", "B")}
    return out


def _change(without: Optional[float], with_: Optional[float]) -> dict[str, Optional[float]]:
    pct = (100.0 * (with_ / without - 1.0)) if without and with_ is not None else None
    return {"without_outliers": without, "with_outliers": with_, "change_pct": pct}


def outliers_doc(op: Optional[OutlierPass], chans: list[str], mode: str) -> dict[str, Any]:
    """The document's ``outliers``: the method and every event across channels."""
    head: dict[str, Any] = {
        "checked": op is not None,
        "mode": mode,
        "threshold_sigma": outliers.SPIKE_SIGMA,
        "false_alarm_per_difference": math.erfc(outliers.SPIKE_SIGMA / math.sqrt(2)),
        "method": "first differences against 1.4826 MAD (docs/analysis.md)",
    }
    if op is not None:
        fs = op.scan.fs
        head["events"] = [
            {
                "start_s": e.start / fs,
                "duration_s": (e.stop - e.start) / fs,
                "kind": "step" if e.step else ("spike" if e.stop - e.start <= 2 else "burst"),
                "channels": [chans[c] for c in e.channels],
                "peak_sigma": e.peak,
            }
            for e in op.scan.events
        ]
    return head
