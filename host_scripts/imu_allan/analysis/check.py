"""Compare a device report with the host reference over the same rows.

A device row (channel, level k, pairs p, acc) covers exactly the first
(p + 1) * 2^k rows of the input (docs/protocol.md). One streaming cascade
over the file, stopped per (level, channel) after p pairs, gives for every
row both the exact integer sum of squared cluster-sum differences (must
equal ``acc`` bit for bit) and the float64 Allan variance (must agree with
acc / (2 m^2 p) within ``REL_TOL``). Flagged rows are listed, not compared:
a SAT row must carry a saturation value (2^48 - 1, or 2^40 - 1 for narrower
accumulators) no larger than the exact sum, and an unflagged row's exact sum
must stay below it.  When the header says from which level the accumulators
have 48 bits (``acc48``; 40 bits below), each row is held to its own width.

The noise terms the device read off its own deviations (T records) are
recomputed from the report's integers (``expected_terms``) and must agree
within the printed precision (half a unit in the third significant digit,
plus the device's fixed-point error, ``TERM_REL``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..channels import CHANNELS
from ..device.files import PathLike
from ..device.records import ACC_MAX, FLAG_RANGE, FLAG_SAT, DeviceHeader, DeviceReport, flag_names
from ..device.summary import summary_units
from ..device.termcheck import B_MIN_PAIRS, TERM_REL, expected_terms, printed_tol, summary_terms_problems, term_problems  # noqa: F401
from ..sources.rows import iter_blocks
from ..stats.reference import OctaveCascade

REL_TOL = 1e-12
SAT_VALUES = ((1 << 40) - 1, ACC_MAX)


@dataclass
class CheckResult:
    file_rows: int = 0
    rows: int = 0  # L rows in the report
    compared: int = 0  # rows without flags, compared exactly
    terms: int = 0  # device noise terms (T records) recomputed
    summary_terms: int = 0  # values of the summary's terms rows (N, B, +-%) recomputed
    exact: int = 0  # ... whose acc equals the host's exact sum
    flagged: list[str] = field(default_factory=list)
    max_rel: float = 0.0
    mismatches: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.mismatches


def check_report(report: DeviceReport, rows_path: PathLike, fs_hz: Optional[float] = None) -> CheckResult:
    h = report.header
    levels = h.levels
    res = CheckResult(rows=len(report.rows))
    bad = res.mismatches.append

    limit = np.zeros((levels, len(CHANNELS)), dtype=np.int64)
    for r in report.rows:
        limit[r.level, CHANNELS.index(r.channel)] = r.pairs
    need = max([r.covers for r in report.rows if r.pairs] + [0])

    cascade = OctaveCascade(levels, len(CHANNELS), limit)
    for block in iter_blocks(rows_path):
        take = min(block.shape[1], need - cascade.n)
        if take > 0:
            cascade.push(block[: len(CHANNELS), :take])
        res.file_rows += block.shape[1]
    exact = cascade.acc()
    ref = cascade.avar()
    got_pairs = cascade.pairs()

    _check_header(h, fs_hz, res)

    for r in report.rows:
        c, k, m = CHANNELS.index(r.channel), r.level, r.m
        where = f"{r.channel} level {k}"
        least = max(h.n // m - 1, 0)
        if r.pairs < least:
            bad(f"{where}: pairs {r.pairs} < floor(n/m) - 1 = {least}")
        elif h.running is False and r.pairs != least:
            bad(f"{where}: pairs {r.pairs}, but a stopped run of n={h.n} has {least}")
        if r.pairs and r.covers > res.file_rows:
            bad(f"{where}: covers {r.covers} rows, the file has only {res.file_rows}")
            continue
        if got_pairs[k, c] != r.pairs:  # cannot happen once covers fits; kept as a guard
            bad(f"{where}: pairs {r.pairs}, the file gives {got_pairs[k, c]}")
            continue
        true = exact[k][c]
        acc48 = h.acc48_from
        width_max = ACC_MAX if acc48 is None or k >= acc48 else (1 << 40) - 1
        if r.flags & ~(FLAG_SAT | FLAG_RANGE):
            bad(f"{where}: unknown flags 0x{r.flags:02x}")
            continue
        if r.flags & FLAG_RANGE:
            res.flagged.append(f"{where} {'+'.join(flag_names(r.flags))}")
            continue
        if r.flags & FLAG_SAT:
            # The device sends its accumulator's saturation value (all ones of
            # its width: 2^48 - 1 per docs/protocol.md; 2^40 - 1 for the
            # narrower accumulators of some builds); the true sum is at least that.
            if r.acc not in SAT_VALUES or true < r.acc or (acc48 is not None and r.acc != width_max):
                bad(
                    f"{where}: SAT flag set with acc {r.acc} (0x{r.acc:012X}) but the exact "
                    f"sum is {true} (0x{true:012X})"
                    + ("" if r.acc in SAT_VALUES else "; a saturated acc is 2^40-1 or 2^48-1")
                )
            else:
                res.flagged.append(f"{where} sat")
            continue
        if true >= width_max:
            bad(f"{where}: SAT flag clear but the exact sum {true} is at least {width_max} (the accumulator's maximum)")
            continue
        res.compared += 1
        rel = 0.0
        if r.pairs:
            want = float(ref[k, c])
            rel = abs(r.avar - want) / abs(want) if want else (0.0 if r.avar == 0 else float("inf"))
            res.max_rel = max(res.max_rel, rel)
        if r.acc != true:
            bad(
                f"{where}: acc {r.acc} (0x{r.acc:012X}) but the exact sum is {true} "
                f"(0x{true:012X}), off by {r.acc - true:+d}"
            )
            continue
        res.exact += 1
        if rel > REL_TOL:
            bad(f"{where}: avar {r.avar!r} vs float64 reference {want!r} (relative difference {rel:.3g} > {REL_TOL:g})")
    _check_terms(report, res)
    _check_summary_terms(report, res)
    return res


def _check_terms(report: DeviceReport, res: CheckResult) -> None:
    """Each T record against the terms recomputed from the report's integers
    (device/termcheck.py, which ``decode`` uses too: a line it refused is
    listed here).  A running device computes its T lines a few samples after
    its L rows: those are compared only when the header says the run had
    stopped."""
    res.mismatches.extend(f"refused by decode: the {why}" for why in report.refused)
    if report.header.running is not False:
        return
    for ch in sorted(report.terms, key=CHANNELS.index):
        bad, agreed = term_problems(report, report.terms[ch], moving=False)
        res.mismatches.extend(bad)
        res.terms += agreed + len(bad)


def _check_summary_terms(report: DeviceReport, res: CheckResult) -> None:
    """The summary's terms (caption and rows, docs/protocol.md) against the
    values recomputed from the report's integers in the header's units, within
    the printed precision (stopped runs, like the T lines)."""
    if report.header.running is not False:
        return
    bad, agreed = summary_terms_problems(report, report.summary, moving=False)
    res.mismatches.extend(bad)
    res.summary_terms += agreed


def _check_header(h: DeviceHeader, fs_hz: Optional[float], res: CheckResult) -> None:
    """The header's claims that the rows file must bear out."""
    bad = res.mismatches.append
    if fs_hz is not None and float(h.fs_hz) != float(fs_hz):
        bad(f"header: fs={h.fs_hz} Hz, expected {fs_hz:g} Hz")
    if h.drops is None:
        bad("header: no drops count (cannot tell whether rows line up with the file)")
    elif h.drops:
        bad(f"header: drops={h.drops}: the device lost sample sets, its rows no longer line up with the file")
    if h.n > res.file_rows:
        bad(f"header: n={h.n} samples but the file has only {res.file_rows} rows")


def summary(res: CheckResult, report: DeviceReport, log_name: str, rows_name: str, max_listed: int = 10) -> str:
    h = report.header
    lines = [
        f"check: report seq {report.seq} of {log_name} (n {h.n}, levels {h.levels}, "
        f"fs {h.fs_hz} Hz) against {rows_name} ({res.file_rows} rows)",
        f"rows: {res.rows}; compared exactly {res.compared}, exact {res.exact}; "
        f"flagged (not compared) {len(res.flagged)}",
        f"max relative difference of avar vs float64 reference: {res.max_rel:.3g} (limit {REL_TOL:g})",
    ]
    if res.terms:
        lines.append(f"noise terms (T): {res.terms} recomputed from the report's integers")
    if res.summary_terms:
        lines.append(
            f"summary terms (N, B, +-% in {summary_units(report.header)} units): "
            f"{res.summary_terms} recomputed from the report's integers"
        )
    if res.flagged:
        lines.append("flagged: " + ", ".join(res.flagged))
    if res.ok:
        lines.append("OK: the device report agrees with the reference")
    else:
        n = len(res.mismatches)
        lines.append(f"MISMATCH: {n} problem{'s' if n != 1 else ''}")
        lines += [f"  {m}" for m in res.mismatches[:max_listed]]
        if n > max_listed:
            lines.append(f"  ... and {n - max_listed} more")
    return "\n".join(lines) + "\n"
