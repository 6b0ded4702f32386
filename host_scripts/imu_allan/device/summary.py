"""The device's human summary (``S`` lines, docs/protocol.md) in the units it
prints them: the scale of each channel's values from the report header's
``units`` and ``range`` keys, the thesis board's facts coming from
``profiles.py`` (the firmware's copy is firmware/units.h; a test checks that
the two agree).

The summary's values, per channel, are counts times a factor:

==========  ===============================  =====================
quantity    phys (accel / gyro)              counts
==========  ===============================  =====================
deviation   mg / deg/s                       count
N           m/s/sqrt(h) / deg/sqrt(h)        count*sqrt(s)
B           mg / deg/h                       count
==========  ===============================  =====================

B = min sigma / 0.664 (IEEE 952's flicker floor); sqrt(s) to sqrt(h) is 60.
A header without ``units`` (firmware before the setting) printed counts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

from ..channels import CHANNELS
from ..profiles import G0, KIND, thesis_profile

B_FACTOR = 0.664
TERM_ROWS = ("N", "B", "+-%", "tau_s")
"""The rows of the noise terms under the channel columns, after the caption."""


@dataclass(frozen=True)
class Scale:
    adev: float
    N: float
    B: float


def summary_units(header: Any) -> Optional[str]:
    """``phys`` or ``counts`` (the header's ``units``; counts before the setting)."""
    return header.extra.get("units", "counts")


def scales(header: Any) -> dict[str, Scale]:
    """Per channel: the factor from counts to the summary's units."""
    if summary_units(header) != "phys":
        return {ch: Scale(1.0, 1.0, 1.0 / B_FACTOR) for ch in CHANNELS}
    prof = thesis_profile(header.range_g or "1.5")
    out = {}
    for ch in CHANNELS:
        per = prof.scale(ch).per_count  # m/s^2 or deg/s per count
        if KIND[ch] == "acc":
            mg = per / G0 * 1000.0
            out[ch] = Scale(mg, per * 60.0, mg / B_FACTOR)
        else:
            out[ch] = Scale(per, per * 60.0, per * 3600.0 / B_FACTOR)
    return out


@dataclass
class SummaryTerms:
    """The terms part of a summary: N's tau and +-% (caption) and, per channel,
    the N, B, B's +-% and B's tau cells as printed."""

    n_tau: float
    n_pct: float
    rows: dict[str, dict[str, float]]


def parse_terms(summary: list[str]) -> Optional[SummaryTerms]:
    """The caption ``N at <tau> s +-<pct>%: ...`` and the 4 rows after it, or
    None when the summary has none (too few pairs, or older firmware)."""
    for i, text in enumerate(summary):
        if text.startswith("N at "):
            head = text[5:].split(":")[0]  # "1.28 s +-3.27%"
            tau, _, pct = head.partition(" s +-")
            rows: dict[str, dict[str, float]] = {ch: {} for ch in CHANNELS}
            for name, line in zip(TERM_ROWS, summary[i + 1 : i + 1 + len(TERM_ROWS)]):
                cells = line.split()
                if len(cells) != 1 + len(CHANNELS) or cells[0] != name:
                    raise ValueError(f"summary terms row {line.strip()!r}: expected {name} and 6 values")
                for ch, c in zip(CHANNELS, cells[1:]):
                    rows[ch][name] = float(c)
            return SummaryTerms(float(tau), float(pct.rstrip("%")), rows)
    return None


def is_text_line(text: str) -> bool:
    """The title, the column heading, the caption and the terms rows (not a level's row)."""
    cells = text.split()
    return not cells or text.startswith("Allan deviation ") or text.startswith("N at ") or cells[0] in TERM_ROWS
