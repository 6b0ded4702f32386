"""The protocol's records, typed, and the parsers of their bodies (B, H, L, T,
C ...): one CRC-checked body in, a typed record out (or BodyError). The
report's assembly from them is records.py, which re-exports these names."""

from __future__ import annotations

import re
from dataclasses import dataclass, field, fields
from typing import Any, Optional

from ..channels import CHANNELS, FS_LIMITS_HZ
from .framing import LINE_ERRORS
from .termcheck import sig3_problem

PROTO = 1
"""The sample rates the device accepts (`rate <hz>`, docs/protocol.md)."""
FLAG_SAT = 0x01
FLAG_RANGE = 0x02
ACC_MAX = (1 << 48) - 1
"""Saturation value of an accumulator (the SAT flag)."""

ERROR_KEYS = LINE_ERRORS + (
    "unparsable",
    "unknown_records",
    "orphan_lines",
    "incomplete_reports",
    "inconsistent_reports",
    "missing_reports",
    "report_check_failed",
    "inconsistent_lines",
    "seq_backwards",
)
"""Keys of ``DecodeResult.errors`` (all always present).  ``report_check_failed``: a
whole report refused by its ``V`` check line (a missing, repeated or malformed ``V``
from a firmware that sends them, an ``id`` other than the header's, or a CRC that
does not match the H and L bodies received).  ``inconsistent_lines``: a ``T`` line
(or the summary's terms rows) of a report that its ``L`` rows contradict, refused
alone (the ``V`` check does not cover them: a line CRC collision, 1 in 65,536, must
not reach the reader).  ``seq_backwards``: a header whose ``seq`` is behind the
previous report line's without a boot line between (a replayed older report, or a
reset whose boot line was lost): file order is then not the device's order."""

CLIP_KEYS = CHANNELS + ("temp",)
_UINT = re.compile(r"\d+")
_SEQ_MAX = 65535
_COUNT_MAX = (1 << 32) - 1
"""The engine's sample count is 32 bits (docs/protocol.md, ``drops``)."""


class BodyError(ValueError):
    """A CRC-valid body that does not parse."""


@dataclass(frozen=True)
class LRow:
    channel: str
    level: int
    pairs: int
    acc: int
    flags: int

    @property
    def m(self) -> int:
        return 1 << self.level

    @property
    def covers(self) -> int:
        """Samples of the run this row depends on: (pairs + 1) * m."""
        return (self.pairs + 1) * self.m

    @property
    def avar(self) -> float:
        """acc / (2 m^2 pairs), correctly rounded; nan without pairs."""
        if self.pairs == 0:
            return float("nan")
        return self.acc / (2 * self.m * self.m * self.pairs)


@dataclass(frozen=True)
class Boot:
    """A B record: the device (re)started."""

    version: Optional[int]
    fw: Optional[str]
    mcu: Optional[str]
    reset_cause: Optional[list[str]]


@dataclass(frozen=True)
class DeviceHeader:
    """An H record. Field names and order are the keys of ``decode --json``'s
    ``header`` (docs/protocol.md); None where the device did not send the key."""

    version: int
    fw: Optional[str]
    mcu: Optional[str]
    fcpu_hz: Optional[int]
    baud: Optional[int]
    fs_hz: int | float
    levels: int
    acc48_from: Optional[int]
    n: int
    drops: Optional[int]
    clips: Optional[dict[str, int]]
    temp: Optional[dict[str, Any]]
    running: Optional[bool]
    mode: Optional[str]
    range_g: Optional[str]
    cfg: Optional[str]
    reset_cause: Optional[list[str]]
    seq: int
    extra: dict[str, str]

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class DeviceTerm:
    """One noise term the device read off its own deviations (a T record):
    the octave level it used and the value as printed (3 significant digits),
    N in count*sqrt(s), B in counts; level and value None when the device had
    no level to take it from (``-``)."""

    level: Optional[int]
    value: Optional[float]


@dataclass(frozen=True)
class DeviceTerms:
    """A T record: ``T,<seq>,<ch>,<level N>,<N>,<level B>,<B>``."""

    channel: str
    N: DeviceTerm
    B: DeviceTerm


@dataclass
class DeviceReport:
    """One whole report of the device: its header and every L row, in channel
    then level order; the noise terms of its T records by channel (firmware
    that sends them)."""

    seq: int
    header: DeviceHeader
    rows: list[LRow] = field(default_factory=list)
    terms: dict[str, DeviceTerms] = field(default_factory=dict)
    summary: list[str] = field(default_factory=list)
    """The text of its ``S`` lines after ``S,<seq>,``, in order (summary.py)."""
    refused: list[str] = field(default_factory=list)
    """Why lines of it were refused and left out (a ``T`` line, the summary's
    terms rows) while its rows passed every check (termcheck.py)."""


@dataclass
class DecodeResult:
    reports: list[DeviceReport]
    errors: dict[str, int]
    boots: list[Boot] = field(default_factory=list)
    replies: list[str] = field(default_factory=list)
    """Bodies of the intact replies (``ok ...``, ``error:<code> ...``), in order."""
    refused: list[str] = field(default_factory=list)
    """Why each whole report that failed the cross-checks was refused."""
    warnings: list[str] = field(default_factory=list)
    """What a reader must be told next to the reports: a line of a report
    refused by its cross-checks, ``seq`` going backwards without a boot line."""


def flag_names(flags: int) -> list[str]:
    """``0x03`` -> ``["sat", "range"]``; unknown bits as ``"0x04"``."""
    names = []
    if flags & FLAG_SAT:
        names.append("sat")
    if flags & FLAG_RANGE:
        names.append("range")
    for bit in range(2, 8):
        if flags & (1 << bit):
            names.append(f"0x{1 << bit:02x}")
    return names


# ---- body parsers -------------------------------------------------------------


def _uint(text: str, what: str, hi: Optional[int] = None) -> int:
    if not _UINT.fullmatch(text):
        raise BodyError(f"{what}: not a decimal number: {text!r}")
    value = int(text)
    if hi is not None and value > hi:
        raise BodyError(f"{what}: {value} above {hi}")
    return value


def _number(text: str, what: str) -> int | float:
    if _UINT.fullmatch(text):
        return int(text)
    if re.fullmatch(r"\d+\.\d+", text):
        return float(text)
    raise BodyError(f"{what}: not a number: {text!r}")


def _pairs(fields: list[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for f in fields:
        key, eq, value = f.partition("=")
        if not eq or not key or key in out:
            raise BodyError(f"bad key=value field {f!r}")
        out[key] = value
    return out


def _reset(text: str) -> list[str]:
    if text == "none":
        return []
    parts = text.split("+")
    if not all(re.fullmatch(r"[a-z]+", p) for p in parts):
        raise BodyError(f"reset: {text!r}")
    return parts


def parse_boot(items: list[str]) -> Boot:
    kv = _pairs(items)
    return Boot(
        version=_uint(kv["proto"], "proto") if "proto" in kv else None,
        fw=kv.get("fw"),
        mcu=kv.get("mcu"),
        reset_cause=_reset(kv["reset"]) if "reset" in kv else None,
    )


_HEADER_KEYS = {
    "proto",
    "fw",
    "mcu",
    "fcpu",
    "baud",
    "fs",
    "levels",
    "acc48",
    "n",
    "drops",
    "clips",
    "temp",
    "run",
    "mode",
    "range",
    "cfg",
    "reset",
}


def parse_header(seq: int, items: list[str]) -> DeviceHeader:
    """The ``key=value`` fields of an H record."""
    kv = _pairs(items)
    for need in ("proto", "fs", "levels", "n"):
        if need not in kv:
            raise BodyError(f"header without {need}")
    version = _uint(kv["proto"], "proto")
    if version != PROTO:
        raise BodyError(f"protocol version {version} (this reader knows {PROTO})")
    levels = _uint(kv["levels"], "levels", 32)
    fs = _number(kv["fs"], "fs")
    if levels < 1 or not FS_LIMITS_HZ[0] <= fs <= FS_LIMITS_HZ[1]:
        raise BodyError(f"levels must be positive and fs within {FS_LIMITS_HZ[0]:g} .. {FS_LIMITS_HZ[1]:g} Hz")

    def opt_uint(key: str) -> Optional[int]:
        return _uint(kv[key], key) if key in kv else None

    clips = None
    if "clips" in kv:
        parts = kv["clips"].split(":")
        if len(parts) != len(CLIP_KEYS):
            raise BodyError(f"clips: {len(parts)} counts, expected {len(CLIP_KEYS)}")
        clips = {k: _uint(p, "clips") for k, p in zip(CLIP_KEYS, parts)}
    temp = None
    if kv.get("temp", "-") != "-":
        parts = kv["temp"].split(":")
        if len(parts) != 3:
            raise BodyError(f"temp: {kv['temp']!r}")
        temp = {
            "mean": float(_number(parts[0], "temp")),
            "min": _uint(parts[1], "temp"),
            "max": _uint(parts[2], "temp"),
        }
    running = None
    if "run" in kv:
        if kv["run"] not in ("0", "1"):
            raise BodyError(f"run: {kv['run']!r}")
        running = kv["run"] == "1"
    return DeviceHeader(
        version=version,
        fw=kv.get("fw"),
        mcu=kv.get("mcu"),
        fcpu_hz=opt_uint("fcpu"),
        baud=opt_uint("baud"),
        fs_hz=fs,
        levels=levels,
        acc48_from=opt_uint("acc48"),
        n=_uint(kv["n"], "n", _COUNT_MAX),
        drops=opt_uint("drops"),
        clips=clips,
        temp=temp,
        running=running,
        mode=kv.get("mode"),
        range_g=kv.get("range"),
        cfg=kv.get("cfg"),
        reset_cause=_reset(kv["reset"]) if "reset" in kv else None,
        seq=seq,
        extra={k: v for k, v in kv.items() if k not in _HEADER_KEYS},
    )


def parse_row(fields: list[str]) -> LRow:
    """``<ch>,<level>,<pairs>,<acc>,<flags>`` (after ``L,<seq>,``)."""
    if len(fields) != 5:
        raise BodyError(f"L row with {len(fields) + 2} fields, expected 7")
    ch, level, pairs, acc, flags = fields
    if ch not in CHANNELS:
        raise BodyError(f"unknown channel {ch!r}")
    if not re.fullmatch(r"[0-9A-F]{12}", acc):  # upper case only, as the device sends
        raise BodyError(f"acc must be 12 upper-case hex digits: {acc!r}")
    if not re.fullmatch(r"[0-9A-F]{2}", flags):
        raise BodyError(f"flags must be 2 upper-case hex digits: {flags!r}")
    return LRow(ch, _uint(level, "level", 31), _uint(pairs, "pairs"), int(acc, 16), int(flags, 16))


def _term(level: str, value: str) -> DeviceTerm:
    if level == "-" and value == "-":
        return DeviceTerm(None, None)
    why = sig3_problem(value)
    if why:
        raise BodyError(f"bad term value: {why}")
    return DeviceTerm(_uint(level, "level", 63), float(value))


def parse_terms(fields: list[str]) -> DeviceTerms:
    """The fields of a T record after its seq: ch, level N, N, level B, B."""
    if len(fields) != 5 or fields[0] not in CHANNELS:
        raise BodyError("T record needs <ch>,<level N>,<N>,<level B>,<B>")
    return DeviceTerms(fields[0], _term(fields[1], fields[2]), _term(fields[3], fields[4]))


def parse_count(fields: list[str]) -> tuple[int, Optional[int]]:
    """``C,<rows>[,<drops>[,...]]`` (fields after ``C``) -> (rows, drops or None).
    Further fields are ignored."""
    if not fields:
        raise BodyError("C record without a count")
    drops = _uint(fields[1], "drops") if len(fields) > 1 and fields[1] else None
    return _uint(fields[0], "rows"), drops


def parse_count_block(fields: list[str]) -> Optional[int]:
    """The ``block`` CRC of a count line ``C,<rows>,<drops>,<block>`` (fields
    after ``C``): 4 upper-case hex digits; None for a count line of the first
    protocol-1 firmware, which sends no ``block``."""
    if len(fields) < 3:
        return None
    if not re.fullmatch(r"[0-9A-F]{4}", fields[2]):
        raise BodyError(f"count line block must be 4 upper-case hex digits: {fields[2]!r}")
    return int(fields[2], 16)


def resets_run(body: str) -> bool:
    """A boot or a reply whose word ``reset`` says a new run began (drops count from 0)."""
    return body.startswith("B,") or body == "B" or (body.startswith("ok ") and "reset" in body[3:].split())


_ERROR_REPLY = re.compile(r"error:\d+( |$)")


def is_reply(body: str) -> bool:
    """``ok``, ``ok <text>`` or ``error:<code>[ <reason>]``."""
    return body == "ok" or body.startswith("ok ") or _ERROR_REPLY.match(body) is not None


_RESTART_WORDS = {"reset", "loaded", "defaults"}


def cuts_report(body: str) -> bool:
    """Does this reply mean the device cut the report it was sending off
    (docs/protocol.md): a reset of the accumulators (the word ``reset``) or a
    switch to mode raw or binary?"""
    if not body.startswith("ok "):
        return False
    words = body[3:].split()
    return "reset" in words or "mode=raw" in words or "mode=binary" in words


def restarts_output(body: str) -> bool:
    """Does this record mark a restart of the raw row count and frame sequence?

    A boot (``B``), and replies to commands that start a new run or enter a
    mode: words ``reset``, ``loaded``, ``defaults`` or ``mode=...``.
    """
    if body.startswith("B,") or body == "B":
        return True
    if not body.startswith("ok "):
        return False
    words = body[3:].split()
    return any(w in _RESTART_WORDS or w.startswith("mode=") for w in words)
