"""Framing of the serial protocol (docs/protocol.md): ``$<body>*<CRC>\\r\\n``.

This module only knows lines, not records: it cuts a byte stream into the
bodies of intact frames and counts everything it had to throw away.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

MAX_BODY = 256
"""Longest body a frame may carry (characters)."""


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC_TABLE = _crc_table()
_CRC_TABLE_NP = np.array(CRC_TABLE, dtype=np.int64)


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xor-out.

    ``crc16(b"123456789") == 0x29B1``.
    """
    crc = 0xFFFF
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ CRC_TABLE[(crc >> 8) ^ byte]
    return crc


def crc16_many(bodies: Sequence[bytes]) -> np.ndarray:
    """``crc16`` of many byte strings at once (vectorized across strings)."""
    n = len(bodies)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    lens = np.fromiter((len(b) for b in bodies), dtype=np.int64, count=n)
    width = int(lens.max())
    crc = np.full(n, 0xFFFF, dtype=np.int64)
    if width == 0:
        return crc
    flat = np.frombuffer(b"".join(bodies), dtype=np.uint8)
    starts = np.cumsum(lens) - lens
    grid = np.zeros((n, width), dtype=np.int64)
    grid[np.repeat(np.arange(n), lens), np.arange(flat.size) - np.repeat(starts, lens)] = flat
    for j in range(width):  # over byte positions (<= MAX_BODY), not over lines
        nxt = ((crc << 8) & 0xFFFF) ^ _CRC_TABLE_NP[((crc >> 8) ^ grid[:, j]) & 0xFF]
        crc = np.where(lens > j, nxt, crc)
    return crc


def frame(body: str) -> bytes:
    """Encode one line the way the device does: ``$body*CRC\\r\\n``."""
    raw = body.encode("ascii")
    if len(raw) > MAX_BODY or not _BODY.fullmatch(raw):
        raise ValueError(f"not a valid frame body: {body!r}")
    return b"$%s*%04X\r\n" % (raw, crc16(raw))


_BODY = re.compile(rb"[\x20-\x23\x25-\x29\x2B-\x7E]*")
_LINE = re.compile(rb"([\x20-\x23\x25-\x29\x2B-\x7E]{0,%d})\*([0-9A-Fa-f]{4})\r?" % MAX_BODY)

LINE_ERRORS = ("bad_crc", "malformed", "restarted", "truncated", "garbage_bytes")
"""Counters of :func:`split_frames`, in the order reports list them."""


@dataclass
class Frames:
    """Bodies of the intact frames of a stream, in order, and what was lost."""

    bodies: list[str] = field(default_factory=list)
    errors: dict[str, int] = field(default_factory=lambda: dict.fromkeys(LINE_ERRORS, 0))


def split_frames(data: bytes) -> Frames:
    """Cut a raw byte stream into frame bodies whose CRC checks.

    Everything else is counted, never returned:
      bad_crc        a well-formed line whose CRC does not match its body;
      malformed      a line (ended by LF) with a missing or malformed ``*CRC``,
                     a byte that is not printable ASCII, or a body too long;
      restarted      a line cut short by a ``$`` before its end (the receiver
                     restarts there);
      truncated      a line cut short by the end of the input;
      garbage_bytes  bytes outside any line (CR and LF not counted).
    A line ends at LF; the CR before it is optional.
    """
    out = Frames()
    err = out.errors
    segments = data.split(b"$")
    err["garbage_bytes"] += _garbage(segments[0])
    candidates: list[tuple[bytes, int]] = []
    last = len(segments) - 1
    for i, seg in enumerate(segments[1:], start=1):
        nl = seg.find(b"\n")
        if nl < 0:
            err["truncated" if i == last else "restarted"] += 1
            continue
        err["garbage_bytes"] += _garbage(seg[nl + 1:])
        m = _LINE.fullmatch(seg, 0, nl)
        if m is None:
            err["malformed"] += 1
            continue
        candidates.append((m.group(1), int(m.group(2), 16)))
    if candidates:
        crcs = crc16_many([body for body, _ in candidates])
        for (body, sent), got in zip(candidates, crcs.tolist()):
            if sent == got:
                out.bodies.append(body.decode("ascii"))
            else:
                err["bad_crc"] += 1
    return out


def _garbage(chunk: bytes) -> int:
    return len(chunk) - chunk.count(b"\r") - chunk.count(b"\n")
