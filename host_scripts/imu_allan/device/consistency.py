"""Cross-checks a whole device report must pass before it is accepted: the
second line of defence behind the CRC-16 of each line.

A CRC-16 lets about one corrupted line in 65,536 through, and a report whose
lines were lost may splice two runs into one.  The numbers of one report are
bound to each other by how the device makes them (docs/protocol.md), so the
host can check, for free:

* each row against the header's ``n``: a row is sent after ``n`` was read,
  so it covers at least the first ``floor(n/m) * m`` samples:
  ``pairs >= floor(n/m) - 1``; and it is sent within the few tenths of a
  second a report takes, so it covers at most ``n + fs * REPORT_SECONDS_MAX``
  samples; in a stopped run nothing moves and ``pairs == max(floor(n/m) - 1, 0)``
  exactly;
* the rows against each other: a row with ``pairs`` p at cluster size m is a
  snapshot taken when the run had N samples, ``(p+1) m <= N < (p+2) m``
  (``N < 2m`` for p = 0), and rows are sent in order (ax levels 0..L-1,
  then ay ...), so N never goes down: every row's lower bound must stay below
  every later row's upper bound (this binds each row to the other channels'
  rows at the same level, and to its own channel's other levels);
* each value against its range: ``acc <= pairs * (1023 m)^2`` unless flagged
  (no two cluster sums of 10-bit codes differ by more than 1023 m), and
  ``acc == 0`` without pairs;
* the ``S`` summary against the rows: each cell is the row's deviation with 3
  significant digits (``!`` when flagged), in the header's ``units`` (phys:
  mg and deg/s at the header's ``range``; summary.py); in a stopped run within one unit
  of the last digit (the device computes it in single precision), and
  within 25 % where the row has at least 1000 pairs while the run goes on
  (the summary is computed a little later, over a few more samples).

``problem(report, ...)`` returns the first failure as one line, or None.
"""

from __future__ import annotations

import math
from typing import Any, Optional

from ..channels import CHANNELS, CODE_MAX
from .summary import is_text_line, scales

DeviceReport = LRow = Any  # records.py's classes (it imports this module, not the reverse)

REPORT_SECONDS_MAX = 10
"""Longest time a report may take to send (0.4 s at 115200 baud in mode allan;
under a second with raw rows sharing the link): rows newer than the header's
n by more than this many seconds of samples belong to another run."""
SUMMARY_TOLERANCE = 0.25
"""Largest relative difference between a summary cell and its row while running."""
SUMMARY_MIN_PAIRS = 1000
"""Rows with fewer pairs are not compared with the summary while running."""


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


def last_digit(shown: float) -> float:
    """One unit of the last of 3 significant digits of a summary value."""
    if shown <= 0 or not math.isfinite(shown):
        return 0.0
    return 10.0 ** (math.floor(math.log10(shown)) - 2)


def problem(rep: "DeviceReport", summary: list[str], moving: bool) -> Optional[str]:
    """The first cross-check ``rep`` fails (rows in the order they arrived),
    or None.  ``summary``: the text of its ``S`` lines; ``moving``: samples
    may have been added while it was sent (the header says run=1, or a reply
    came in the middle)."""
    return _rows_vs_n(rep, moving) or _rows_vs_rows(rep) or _values(rep) or _summary(rep, summary, moving)


def _where(r: "LRow") -> str:
    return f"{r.channel} level {r.level}"


def _rows_vs_n(rep: "DeviceReport", moving: bool) -> Optional[str]:
    n = rep.header.n
    most = n + math.ceil(rep.header.fs_hz * REPORT_SECONDS_MAX)
    for r in rep.rows:
        least = max(n // r.m - 1, 0)
        if r.pairs < least:
            return f"{_where(r)}: pairs {r.pairs} < floor(n/m) - 1 = {least} (n={n})"
        if (r.pairs + 1) * r.m > most and r.pairs:
            return (
                f"{_where(r)}: pairs {r.pairs} cover {(r.pairs + 1) * r.m} samples, more than "
                f"n={n} plus {REPORT_SECONDS_MAX} s of samples ({most})"
            )
        if not moving and r.pairs != least:
            return f"{_where(r)}: pairs {r.pairs} in a stopped run of n={n} (expected {least})"
    return None


def _rows_vs_rows(rep: "DeviceReport") -> Optional[str]:
    low, low_at = 0, None
    for r in rep.rows:
        high = (r.pairs + 2) * r.m if r.pairs else 2 * r.m
        if low >= high:
            return (
                f"{_where(r)}: pairs {r.pairs} means fewer than {high} samples, but "
                f"{_where(low_at)} was sent earlier with at least {low}"
            )
        if r.pairs and (r.pairs + 1) * r.m > low:
            low, low_at = (r.pairs + 1) * r.m, r
    return None


def _values(rep: "DeviceReport") -> Optional[str]:
    for r in rep.rows:
        if r.flags:
            continue  # a saturated or range-flagged value is a bound, checked by `check`
        most = r.pairs * (CODE_MAX * r.m) ** 2
        if r.acc > most:
            return f"{_where(r)}: acc {r.acc} above pairs * (1023 m)^2 = {most}"
    return None


def _summary(rep: "DeviceReport", summary: list[str], moving: bool) -> Optional[str]:
    fs = rep.header.fs_hz
    by_tau = {}
    for k in range(rep.header.levels):
        by_tau.setdefault(sig3((1 << k) / fs), k)
    rows = {(r.channel, r.level): r for r in rep.rows}
    scale = scales(rep.header)
    for text in summary:
        cells = text.split()
        if is_text_line(text):
            continue  # title, column heading, the terms' caption and rows (check.py)
        level = by_tau.get(cells[0])
        if level is None or len(cells) != 1 + len(CHANNELS):
            return f"summary line {text.strip()!r}: not a level of this report"
        for ch, cell in zip(CHANNELS, cells[1:]):
            r = rows.get((ch, level))
            if r is None:
                continue  # the row count check reports a missing row
            bad = _cell_problem(r, cell, moving, scale[ch].adev)
            if bad:
                return f"{_where(r)}: summary shows {cell}, {bad}"
    return None


def _cell_problem(r: "LRow", cell: str, moving: bool, factor: float = 1.0) -> Optional[str]:
    """A level's cell against its row; ``factor``: counts to the summary's units."""
    if r.pairs == 0:
        return None if cell == "-" or moving else "the row has no pairs"
    adev = math.sqrt(r.avar) * factor
    try:
        shown = float(cell.rstrip("!"))
    except ValueError:
        return "not a number"
    if not moving:
        if cell.endswith("!") != bool(r.flags):
            return "flagged" if r.flags else "not flagged"
        # the device rounds in single precision: its last digit may be one off
        if shown != adev and abs(shown - adev) > last_digit(shown):
            return f"the row gives {sig3(adev)}"
        return None
    if r.flags or r.pairs < SUMMARY_MIN_PAIRS:
        return None
    if adev > 0 and abs(shown - adev) / adev > SUMMARY_TOLERANCE:
        return f"the row gives {adev:.6g} (more than {SUMMARY_TOLERANCE:.0%} apart)"
    return None
