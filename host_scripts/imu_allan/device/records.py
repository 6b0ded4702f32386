"""Records of the protocol (B, H, L, T, V, S, E, C, ok, error) and complete device reports.

A report's lines come as H, L..., T..., V, S..., E (the summary a person reads
last); firmware before it sent S before T and V: both orders are read alike.

``decode_bytes(data)`` turns a raw device log into the list of its complete
reports (header + every L row + its V check + E, all intact and agreeing) and the counts of everything
that could not be used.  Nothing partial or unchecked is ever returned.
``Assembler`` is the same record logic fed one CRC-checked body at a time
(used by ``stream.py`` for live and mixed captures).

Records are typed: ``DeviceHeader`` (an H record), ``Boot`` (a B record),
``LRow`` (an L row) and ``DeviceReport`` (one whole report: header and rows).
``DeviceHeader.as_dict()`` is the ``header`` object of ``decode --json``.
"""

from __future__ import annotations

import re
from typing import Iterable, Optional

from ..channels import CHANNELS
from .bodies import (  # noqa: F401  (the records' names, one import for every user)
    _SEQ_MAX,
    ACC_MAX,
    CLIP_KEYS,
    ERROR_KEYS,
    FLAG_RANGE,
    FLAG_SAT,
    PROTO,
    BodyError,
    Boot,
    DecodeResult,
    DeviceHeader,
    DeviceReport,
    DeviceTerm,
    DeviceTerms,
    LRow,
    _uint,
    cuts_report,
    flag_names,
    is_reply,
    parse_boot,
    parse_count,
    parse_count_block,
    parse_header,
    parse_row,
    parse_terms,
    resets_run,
    restarts_output,
)
from .consistency import problem
from .framing import MODBUS_INIT, LineSplitter, crc16_modbus
from .summary import TERM_ROWS
from .termcheck import summary_terms_problems, term_problems

# ---- report assembly ----------------------------------------------------------


class Assembler:
    """Record logic, one CRC-checked body at a time.

    Complete reports, boots and replies are appended to the lists of the same
    names; record-level errors are counted into ``errors`` (the keys of
    ``ERROR_KEYS`` after the framing ones).  Call ``finish()`` at the end of
    the input: an open report then counts as incomplete.
    """

    def __init__(self, errors: Optional[dict[str, int]] = None) -> None:
        self.errors = errors if errors is not None else dict.fromkeys(ERROR_KEYS, 0)
        for key in ERROR_KEYS:
            self.errors.setdefault(key, 0)
        self.reports: list[DeviceReport] = []
        self.boots: list[Boot] = []
        self.replies: list[str] = []
        self.refused: list[str] = []
        """Why each report that arrived whole was refused (consistency.py), in order."""
        self._open: Optional[DeviceReport] = None
        self._summary: list[str] = []  # the open report's S lines
        self._moving = False  # a reply came inside the open report
        self._bound = MODBUS_INIT  # CRC-16/MODBUS of the open report's H and L bodies
        self._check: list[str] = []  # the open report's V line(s), after V,<seq>,
        self._last_seq: Optional[int] = None  # of the last H/L/S/E seen since boot
        self._doubled: set[str] = set()  # channels of the open report with two T lines
        self.warnings: list[str] = []
        """What must be said next to the reports (``DecodeResult.warnings``), in order."""

    def _abandon(self) -> None:
        if self._open is not None:
            self.errors["incomplete_reports"] += 1
        self._open = None

    def finish(self) -> None:
        self._abandon()

    def add(self, body: str) -> None:
        fields = body.split(",")
        kind = fields[0]
        try:
            if kind == "B":
                boot = parse_boot(fields[1:])
                self._abandon()  # the device reset: an open report never ends
                self._last_seq = None  # seq counts from 0 again
                self.boots.append(boot)
            elif kind in ("H", "L", "S", "T", "V", "E"):
                self._report_line(kind, fields, body)
            elif kind == "C":
                parse_count(fields[1:])  # raw row counts: checked by stream.py
            elif kind == "ok" or kind.startswith("ok ") or kind.startswith("error:"):
                if not is_reply(body):
                    raise BodyError("bad error reply")
                self._reply(body)
            else:
                self.errors["unknown_records"] += 1  # readers ignore record types they do not know
        except (BodyError, KeyError, ValueError):
            self.errors["unparsable"] += 1  # a lost L row then fails the report's E count

    def _reply(self, body: str) -> None:
        self.replies.append(body)
        if self._open is not None:
            if cuts_report(body):
                self._abandon()  # the device cut the report off: it gets no E
            else:
                self._moving = True  # a command ran between two lines: `start` may have too

    def _report_line(self, kind: str, fields: list[str], body: str) -> None:
        errors = self.errors
        if len(fields) < 2:
            raise BodyError(f"{kind} without seq")
        seq = _uint(fields[1], "seq", _SEQ_MAX)
        if kind == "H":
            header = parse_header(seq, fields[2:])
            self._count_gap(seq, header=True)
            self._abandon()
            self._open, self._summary, self._moving = DeviceReport(seq, header), [], False
            self._doubled = set()
            self._bound = crc16_modbus(body.encode("ascii"))
            self._check = []
            return
        row = parse_row(fields[2:]) if kind == "L" else None
        term = parse_terms(fields[2:]) if kind == "T" else None
        if kind == "E":
            if len(fields) != 3:
                raise BodyError("E record needs exactly <seq>,<rows>")
            count = _uint(fields[2], "rows")
        self._count_gap(seq)
        open_ = self._open
        if open_ is None or seq != open_.seq:
            errors["orphan_lines"] += 1
            if kind == "E":
                errors["incomplete_reports"] += 1  # a report whose H was lost
            return
        if row is not None:
            open_.rows.append(row)
            self._bound = crc16_modbus(body.encode("ascii"), self._bound)
        elif kind == "V":
            self._check.append(",".join(fields[2:]))
        elif term is not None:
            if term.channel in open_.terms:
                self._doubled.add(term.channel)
            open_.terms[term.channel] = term
        elif kind == "S":
            self._summary.append(",".join(fields[2:]))
        elif not _complete(open_, count):
            self._abandon()
        else:
            self._open = None
            bad = check_problem(open_.header, self._check, self._bound)
            if bad is not None:
                errors["report_check_failed"] += 1
                self.refused.append(f"report seq {seq}: {bad}")
                return
            why = problem(open_, self._summary, self._moving or open_.header.running is not False)
            if why is not None:
                errors["inconsistent_reports"] += 1
                self.refused.append(f"report seq {seq}: {why}")
                return
            self._check_terms(open_, self._moving or open_.header.running is not False)
            open_.rows.sort(key=lambda r: (CHANNELS.index(r.channel), r.level))
            self.reports.append(open_)

    def _check_terms(self, rep: DeviceReport, moving: bool) -> None:
        """Leave out, count and say each T line, and the summary's terms part,
        that the report's rows contradict (termcheck.py): the V check does not
        cover them."""
        refused = []
        for ch in sorted(rep.terms, key=CHANNELS.index):
            bad = ["two T lines"] if ch in self._doubled else term_problems(rep, rep.terms[ch], moving)[0]
            if bad:
                del rep.terms[ch]
                refused.append(f"T line of {ch} ({'; '.join(bad)})")
        summary = self._summary
        bad = summary_terms_problems(rep, summary, moving)[0]
        if bad:  # the caption and the rows under it
            at = next(i for i, t in enumerate(summary) if t.startswith("N at "))
            summary = summary[:at] + summary[at + 1 + len(TERM_ROWS) :]
            refused.append(f"summary's terms rows ({'; '.join(bad)})")
        rep.summary = summary
        for why in refused:
            self.errors["inconsistent_lines"] += 1
            rep.refused.append(why)
            self.warnings.append(f"report seq {rep.seq}: refused the {why}")

    def _count_gap(self, seq: int, header: bool = False) -> None:
        """Reports that vanished whole: a jump in seq (a report cut off by a
        reset keeps its seq; a jump of half the range or more is a restart).
        A header whose seq is behind the last one's without a boot line between
        is counted and said (``seq_backwards``): a replayed older report, or a
        reset whose boot line was lost; in file order it would pass for the
        latest."""
        last = self._last_seq
        if last is not None:
            gap = (seq - last - 1) % (_SEQ_MAX + 1)
            if 0 < gap < (_SEQ_MAX + 1) // 2 and seq != last:
                self.errors["missing_reports"] += gap
            elif header and seq != last and (last - seq) % (_SEQ_MAX + 1) < (_SEQ_MAX + 1) // 2:
                self.errors["seq_backwards"] += 1
                self.warnings.append(
                    f"report seq {seq} comes after seq {last} without a boot line: "
                    "an older report replayed, or a reset whose boot line was "
                    "lost (the reports are in file order)"
                )
        self._last_seq = seq


def decode_bytes(data: bytes) -> DecodeResult:
    """Every complete report of a raw log, in order, and the error counts."""
    return decode_blocks((data,))


def decode_blocks(blocks: Iterable[bytes]) -> DecodeResult:
    """``decode_bytes`` over a log read in blocks (``files.read_blocks``): the
    memory it takes is bounded by a block and the reports it keeps, whatever
    the bytes (lines are cut at ``framing.MAX_LINE``)."""
    splitter = LineSplitter()
    errors = dict.fromkeys(ERROR_KEYS, 0)
    asm = Assembler(errors)
    for block in blocks:
        for body in splitter.feed(block):
            asm.add(body)
    for body in splitter.finish():
        asm.add(body)
    asm.finish()
    errors.update(splitter.errors)
    return DecodeResult(asm.reports, errors, asm.boots, asm.replies, asm.refused, asm.warnings)


_CHECK = re.compile(r"id=(\d{1,3}),crc=([0-9A-F]{4})")


def check_problem(header: DeviceHeader, checks: list[str], bound: int) -> Optional[str]:
    """Why a whole report fails its ``V`` check (docs/protocol.md), or None.

    ``checks``: the text after ``V,<seq>,`` of each V line the report got;
    ``bound``: the CRC-16/MODBUS of its H body and then its L bodies, as
    received.  A firmware that sends V lines says so with ``id=`` in its
    header: its report needs exactly one V with that id and that CRC.  A
    report of an older firmware (no ``id=``, no V) is accepted as before; a V
    that comes anyway is checked.
    """
    run = header.extra.get("id")
    if not checks:
        return None if run is None else f"no V check line (the header says id={run})"
    if len(checks) > 1:
        return f"{len(checks)} V check lines"
    m = _CHECK.fullmatch(checks[0])
    if m is None:
        return f"malformed V check line {checks[0]!r}"
    if run != m.group(1):
        return f"V says id={m.group(1)}, the header id={run}: rows of two runs"
    if int(m.group(2), 16) != bound:
        return f"V crc={m.group(2)}, the H and L bodies received give {bound:04X}: a row changed or from another report"
    return None


def _complete(rep: DeviceReport, count: int) -> bool:
    levels = rep.header.levels
    keys = {(r.channel, r.level) for r in rep.rows}
    return count == len(rep.rows) == len(keys) == len(CHANNELS) * levels and all(r.level < levels for r in rep.rows)
