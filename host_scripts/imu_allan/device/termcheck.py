"""The noise terms a report carries beside its rows, against those rows: the
``T`` lines and the summary's terms rows (caption, ``N``, ``B``, ``+-%``,
``tau_s``; docs/protocol.md).  The one home of these checks: ``decode`` (the
``Assembler``) refuses a line that fails them, ``check`` lists the failure.

The ``V`` check binds a report's ``H`` and ``L`` lines only; a ``T`` or ``S``
line is guarded by its own line CRC alone, which lets one corrupted line in
65,536 through.  Everything in them is bound to the ``L`` rows, so:

* every report: a term's level is one of the report's levels, the level the
  device's rule picks among those whose rows have (or, while the run goes
  on, may have reached) the pairs it needs (N: at least 1, the level whose
  tau is nearest 1 s; B: at least 8), each value a number of at most 3
  significant digits (the device's ``fmt_sig3``), and, where the level's row
  has ``SUMMARY_MIN_PAIRS`` pairs, within ``SUMMARY_TOLERANCE`` of the value
  the row gives;
* a stopped run (nothing moved while the report was sent): every value and
  level as the rows give them, within the printed precision (half a unit of
  the third digit, plus the device's fixed-point error ``TERM_REL``).
"""

from __future__ import annotations

import math
import re
from typing import Any, Optional

from ..channels import CHANNELS
from .consistency import REPORT_SECONDS_MAX, SUMMARY_MIN_PAIRS, SUMMARY_TOLERANCE
from .summary import B_FACTOR, TERM_ROWS, scales
from .summary import parse_terms as parse_summary_terms

DeviceReport = DeviceTerms = Any  # records.py's classes (it imports this module)

TERM_REL = 2e-4
"""Relative error the device's fixed-point deviation may add (fmt_adev: below 1e-4)."""
B_MIN_PAIRS = 8
"""Pairs a level needs to be B's (and for T lines to be sent at all, at level 0)."""

_SIG3 = re.compile(r"(\d+)(?:\.(\d+))?(?:e-\d{1,2})?")


def sig3_problem(text: str) -> Optional[str]:
    """Why ``text`` is not a value as the device prints it (a decimal number,
    at most 3 significant digits, ``e-<n>`` below 0.001), or None."""
    m = _SIG3.fullmatch(text)
    if m is None:
        return f"{text!r} is not a decimal number"
    digits = (m.group(1) + (m.group(2) or "")).strip("0")
    if len(digits) > 3:
        return f"{text!r} has more than 3 significant digits"
    return None


def printed_tol(value: float) -> float:
    """Half a unit in the third significant digit of value, plus TERM_REL."""
    if value <= 0:
        return 1e-300
    return 0.5 * 10.0 ** (math.floor(math.log10(value)) - 2) * 1.0001 + TERM_REL * value


def _n_level(fs: float, levels: list[int]) -> Optional[int]:
    """The level whose tau is nearest 1 s (ties: the lower) among ``levels``."""
    return min(levels, key=lambda k: (abs((1 << k) - fs), k)) if levels else None


def expected_terms(report: DeviceReport, channel: str) -> dict[str, Optional[tuple[int, float]]]:
    """The noise terms as the device defines them (docs/protocol.md, T), from
    the report's own L rows: N = adev(tau) * sqrt(tau) at the level whose tau
    is nearest 1 s (ties: the lower) among levels with pairs, in count*sqrt(s);
    B = min adev / 0.664 over levels with at least 8 pairs, in counts.
    {"N": (level, value) or None, "B": ...}."""
    fs = float(report.header.fs_hz)
    rows = {r.level: r for r in report.rows if r.channel == channel and r.pairs}
    out: dict[str, Optional[tuple[int, float]]] = {"N": None, "B": None}
    k = _n_level(fs, list(rows))
    if k is not None:
        out["N"] = (k, math.sqrt(rows[k].avar * rows[k].m / fs))
    cand = [r for r in rows.values() if r.pairs >= B_MIN_PAIRS]
    if cand:
        b = min(cand, key=lambda r: (r.avar, r.level))
        out["B"] = (b.level, math.sqrt(b.avar) / B_FACTOR)
    return out


def _reach(report: DeviceReport, moving: bool) -> int:
    """Samples the run may have had when a term was computed: n, plus the
    samples of the longest report while the run goes on."""
    h = report.header
    return h.n + (math.ceil(float(h.fs_hz) * REPORT_SECONDS_MAX) if moving else 0)


def _levels_with(report: DeviceReport, channel: str, pairs: int, moving: bool) -> tuple[list[int], list[int]]:
    """Levels whose rows have ``pairs`` pairs, and those that may have reached
    them when the term was computed (the same in a stopped run)."""
    most = _reach(report, moving)
    have, may = [], []
    for r in report.rows:
        if r.channel == channel:
            if r.pairs >= pairs:
                have.append(r.level)
            if r.pairs >= pairs or (moving and (pairs + 1) * r.m <= most):
                may.append(r.level)
    return sorted(have), sorted(may)


def _allowed_n_levels(report: DeviceReport, channel: str, moving: bool) -> set[int]:
    fs = float(report.header.fs_hz)
    have, may = _levels_with(report, channel, 1, moving)
    return {_n_level(fs, may[:i]) for i in range(len(have), len(may) + 1) if i}


def _close_enough(shown: float, value: float, row: Any, moving: bool) -> bool:
    if not moving:
        return abs(shown - value) <= printed_tol(value)
    if row.flags or row.pairs < SUMMARY_MIN_PAIRS or value <= 0:
        return True
    return abs(shown - value) / value <= SUMMARY_TOLERANCE


def term_problems(report: DeviceReport, term: DeviceTerms, moving: bool) -> tuple[list[str], int]:
    """What the ``T`` line of ``term.channel`` says that the report's rows
    contradict (one line each), and how many of its values were recomputed
    and agree (stopped runs)."""
    ch, h = term.channel, report.header
    fs = float(h.fs_hz)
    rows = {r.level: r for r in report.rows if r.channel == ch}
    want = expected_terms(report, ch)
    bad: list[str] = []
    agreed = 0
    for name, got in (("N", term.N), ("B", term.B)):
        where = f"{ch} {name}"
        need = 1 if name == "N" else B_MIN_PAIRS
        have, may = _levels_with(report, ch, need, moving)
        if got.level is None:
            if have:  # pairs only grow: what the rows give, the line had
                bad.append(f"{where}: device -, but level {have[0]} has {need} pairs or more")
            continue
        if got.level >= h.levels:
            bad.append(f"{where}: level {got.level}, beyond the report's {h.levels} levels")
            continue
        if got.level not in may:
            bad.append(
                f"{where}: level {got.level}, whose row has {rows[got.level].pairs} pairs (the term needs {need})"
            )
            continue
        if name == "N" and got.level not in _allowed_n_levels(report, ch, moving):
            bad.append(f"{where}: device used level {got.level}, expected {want['N'][0] if want['N'] else '-'}")
            continue
        row = rows[got.level]
        if not row.pairs:
            continue  # reached while the report was sent: nothing to compare yet
        value = math.sqrt(row.avar * row.m / fs) if name == "N" else math.sqrt(row.avar) / B_FACTOR
        if name == "B" and not moving and want["B"] is not None and got.level != want["B"][0]:
            # a near tie of the minimum may fall either way in fixed point
            if abs(value - want["B"][1]) > TERM_REL * want["B"][1]:
                bad.append(f"{where}: device used level {got.level}, expected {want['B'][0]}")
                continue
        if not _close_enough(got.value, value, row, moving):
            bad.append(
                f"{where}: device {got.value:g}, recomputed {value:.6g} "
                f"({'beyond the printed precision' if not moving else 'too far apart'})"
            )
        elif not moving:
            agreed += 1
    return bad, agreed


def summary_terms_problems(report: DeviceReport, summary: list[str], moving: bool) -> tuple[list[str], int]:
    """What the summary's terms part (caption and rows) says that the report's
    rows contradict (one line each), and how many values agree (stopped runs)."""
    head = next((i for i, text in enumerate(summary) if text.startswith("N at ")), None)
    if head is None:
        return [], 0
    form = _summary_form(summary[head : head + 1 + len(TERM_ROWS)])
    if form:
        return [f"summary: {form}"], 0
    try:
        got = parse_summary_terms(summary)
    except ValueError as e:
        return [f"summary: {e}"], 0
    assert got is not None
    h = report.header
    fs = float(h.fs_hz)
    units = scales(h)
    bad: list[str] = []
    agreed = 0

    def level_of(tau: float) -> Optional[int]:
        return next((k for k in range(h.levels) if abs(tau - (1 << k) / fs) <= printed_tol((1 << k) / fs)), None)

    n_level = level_of(got.n_tau)
    if n_level is None:
        return [f"summary: N at {got.n_tau:g} s is not a tau of this report"], 0
    first = True
    for ch in CHANNELS:
        rows = {r.level: r for r in report.rows if r.channel == ch}
        if first:
            first = False
            if n_level not in _allowed_n_levels(report, ch, moving):
                bad.append(f"summary: N at {got.n_tau:g} s, not the level the rows give")
                break
            row = rows[n_level]
            if row.pairs and not _close_enough(got.n_pct, 100 / math.sqrt(2 * row.pairs), row, moving):
                bad.append(f"summary: N +-{got.n_pct:g}%, the rows give {100 / math.sqrt(2 * row.pairs):.3g}%")
        cells = got.rows[ch]
        b_level = level_of(cells["tau_s"])
        if b_level is None or b_level not in _levels_with(report, ch, B_MIN_PAIRS, moving)[1]:
            bad.append(f"{ch} B: summary at tau {cells['tau_s']:g} s, not a level with {B_MIN_PAIRS} pairs")
            continue
        nrow, brow = rows[n_level], rows[b_level]
        want = expected_terms(report, ch)
        if (
            not moving
            and want["B"] is not None
            and b_level != want["B"][0]
            and abs(math.sqrt(brow.avar) / B_FACTOR - want["B"][1]) > TERM_REL * want["B"][1]
        ):
            bad.append(f"{ch} B: summary at tau {cells['tau_s']:g} s, the rows give {(1 << want['B'][0]) / fs:.4g} s")
            continue
        checks = []
        if nrow.pairs:
            checks.append(("N", cells["N"], math.sqrt(nrow.avar * nrow.m / fs) * units[ch].N, nrow))
        if brow.pairs:
            checks += [
                ("B", cells["B"], math.sqrt(brow.avar) * units[ch].B, brow),
                ("B +-%", cells["+-%"], 100 / math.sqrt(2 * brow.pairs), brow),
            ]
        for name, shown, value, row in checks:
            if not _close_enough(shown, value, row, moving):
                bad.append(f"{ch} {name}: summary shows {shown:g}, recomputed {value:.6g}")
            elif not moving:
                agreed += 1
    return bad, agreed


def _summary_form(lines: list[str]) -> Optional[str]:
    """Why the caption and the 4 rows are not shaped as the device prints them."""
    m = re.fullmatch(r"N at (\S+) s \+-(\S+)%: .*", lines[0])
    if m is None:
        return f"caption {lines[0]!r}"
    values = [m.group(1), m.group(2)]
    if len(lines) != 1 + len(TERM_ROWS):
        return f"{len(lines) - 1} terms rows, expected {len(TERM_ROWS)}"
    for name, text in zip(TERM_ROWS, lines[1:]):
        cells = text.split()
        if len(cells) != 1 + len(CHANNELS) or cells[0] != name:
            return f"terms row {text.strip()!r}: expected {name} and {len(CHANNELS)} values"
        values += cells[1:]
    for v in values:
        why = sig3_problem(v)
        if why:
            return why
    return None
