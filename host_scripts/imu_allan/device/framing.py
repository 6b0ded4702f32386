"""Framing of the serial protocol (docs/protocol.md): the one home of the
CRC-16 and of both frame formats.

* text lines ``$<body>*<CRC>\\r\\n`` (reports, replies, boots, count lines);
* 13-byte binary sample frames: ``0xA5``, seq, 7 low bytes, 16-bit LE word of
  the high bits, CRC-16 of bytes 1-10 (high byte first).

This module only knows bytes and lines, not records: it cuts a byte stream
into the bodies of intact lines and counts everything it had to throw away
(records.py parses the bodies, stream.py mixes lines, raw rows and frames).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

from ..channels import CODE_MAX, COLUMNS

MAX_BODY = 320
"""Longest body a frame may carry (characters): docs/protocol.md's limit, which
holds a header with every count at its maximum and the ``rx=`` counters (303)."""


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
    return int(crc16_many([bytes(data)])[0])


def crc16_many(bodies: Sequence[bytes]) -> np.ndarray:
    """``crc16`` of many byte strings at once (vectorized across strings)."""
    n = len(bodies)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    lens = np.fromiter((len(b) for b in bodies), dtype=np.int64, count=n)
    width = int(lens.max())
    if width == 0:
        return np.full(n, 0xFFFF, dtype=np.int64)
    flat = np.frombuffer(b"".join(bodies), dtype=np.uint8)
    starts = np.cumsum(lens) - lens
    grid = np.zeros((n, width), dtype=np.int64)
    grid[np.repeat(np.arange(n), lens), np.arange(flat.size) - np.repeat(starts, lens)] = flat
    return crc16_columns(grid, lens)


def crc16_columns(grid: np.ndarray, lens: Optional[np.ndarray] = None) -> np.ndarray:
    """The CRC-16 of each row of ``grid`` (k, width) of byte values: the one
    implementation of the table-driven CRC loop, run over byte positions
    (<= MAX_BODY), vectorized across rows.  ``lens``: bytes used per row
    (all when None)."""
    g = np.asarray(grid, dtype=np.int64)
    crc = np.full(g.shape[0], 0xFFFF, dtype=np.int64)
    for j in range(g.shape[1]):
        nxt = ((crc << 8) & 0xFFFF) ^ _CRC_TABLE_NP[((crc >> 8) ^ g[:, j]) & 0xFF]
        crc = nxt if lens is None else np.where(lens > j, nxt, crc)
    return crc


def _modbus_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


MODBUS_TABLE = _modbus_table()
MODBUS_INIT = 0xFFFF


def crc16_modbus(data: bytes, crc: int = MODBUS_INIT) -> int:
    """CRC-16/MODBUS: poly 0x8005 reflected (0xA001 shifting right), init
    0xFFFF, no xor-out: the second line of defence (docs/protocol.md): the
    ``V`` check of a report's H and L bodies, and the ``block`` field of count
    lines over raw rows and binary frames.  A polynomial other than the lines'
    CRC-16, so that an error one misses the other catches (2^-31 for both).
    ``crc``: the value so far, to continue over more bytes.

    ``crc16_modbus(b"123456789") == 0x4B37``.
    """
    table = MODBUS_TABLE
    for byte in data:
        crc = (crc >> 8) ^ table[(crc ^ byte) & 0xFF]
    return crc


def frame(body: str) -> bytes:
    """Encode one line the way the device does: ``$body*CRC\\r\\n``."""
    raw = body.encode("ascii")
    if len(raw) > MAX_BODY or not _BODY.fullmatch(raw):
        raise ValueError(f"not a valid frame body: {body!r}")
    return b"$%s*%04X\r\n" % (raw, crc16(raw))


_BODY = re.compile(rb"[\x20-\x23\x25-\x29\x2B-\x7E]*")
LINE = re.compile(rb"([\x20-\x23\x25-\x29\x2B-\x7E]{0,%d})\*([0-9A-F]{4})\r?" % MAX_BODY)
"""What follows the ``$`` of an intact-looking line, up to its LF: the body and the CRC
(upper-case hex only, as the device sends it: a lower-case digit is a corruption)."""

LINE_ERRORS = ("bad_crc", "malformed", "restarted", "truncated", "garbage_bytes")
"""Counters of :func:`split_frames`, in the order reports list them."""


@dataclass
class Frames:
    """Bodies of the intact frames of a stream, in order, and what was lost."""

    bodies: list[str] = field(default_factory=list)
    errors: dict[str, int] = field(default_factory=lambda: dict.fromkeys(LINE_ERRORS, 0))


MAX_LINE = 4096
"""Bytes of text without a line end kept waiting for it.  The longest line the
device sends is 327 bytes (``$``, a ``MAX_BODY`` body, ``*CRC``, CR LF); a line
still open after this many bytes is dropped and counted (``malformed``, or
``garbage_bytes`` outside a line), so that no input, however long its lines,
costs memory beyond it."""
SPLIT_BYTES = 1 << 18
"""Bytes split into lines at a time (bounds the per-line index arrays)."""
_CHECK_BATCH = 4096
"""Candidate lines matched and CRC-checked at a time (bounds crc16_many's grid)."""


def split_frames(data: bytes) -> Frames:
    """Cut a raw byte stream into frame bodies whose CRC checks.

    Everything else is counted, never returned:
      bad_crc        a well-formed line whose CRC does not match its body;
      malformed      a line (ended by LF) with a missing or malformed ``*CRC``,
                     a byte that is not printable ASCII, or a body too long;
                     a line still open after ``MAX_LINE`` bytes;
      restarted      a line cut short by a ``$`` before its end (the receiver
                     restarts there);
      truncated      a line cut short by the end of the input;
      garbage_bytes  bytes outside any line (CR and LF not counted; the
                     device's echo lines, ``> ...``, are not garbage).
    A line ends at LF, CR LF or CR (a log saved with any of the three reads alike).
    """
    splitter = LineSplitter()
    bodies = splitter.feed(data) + splitter.finish()
    return Frames(bodies, splitter.errors)


class LineSplitter:
    """``split_frames`` over a stream given in pieces of any size, in memory
    bounded by ``SPLIT_BYTES`` and ``MAX_LINE`` whatever the input (a file of
    ten million ``$`` costs what a file of ten does)."""

    def __init__(self) -> None:
        self.errors: dict[str, int] = dict.fromkeys(LINE_ERRORS, 0)
        self._carry = b""  # text after the last line end, waiting for its end

    def feed(self, data: bytes) -> list[str]:
        """The bodies of the intact lines that ended in ``data``."""
        bodies: list[str] = []
        for at in range(0, len(data), SPLIT_BYTES):
            bodies += self._step(data[at : at + SPLIT_BYTES])
        return bodies

    def finish(self) -> list[str]:
        """The end of the input: a line still open is cut short."""
        self._tail(self._carry, "truncated")
        self._carry = b""
        return []

    def _step(self, data: bytes) -> list[str]:
        # CR LF and a lone CR end a line as LF does (a CR LF cut between two
        # pieces gives an empty line, which is nothing); bodies never hold CR
        buf = (self._carry + data).replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        b = np.frombuffer(buf, dtype=np.uint8)
        nl = np.flatnonzero(b == 0x0A)
        end = int(nl[-1]) + 1 if nl.size else 0
        bodies = self._lines(buf, b, nl) if nl.size else []
        rest = buf[end:]
        if len(rest) > MAX_LINE:
            last = rest.rfind(b"$")
            keep = last if last >= 0 and len(rest) - last <= MAX_LINE else len(rest)
            self._tail(rest[:keep], "restarted" if keep < len(rest) else "malformed")
            rest = rest[keep:]
        self._carry = rest
        return bodies

    def _lines(self, buf: bytes, b: np.ndarray, nl: np.ndarray) -> list[str]:
        """The whole lines of ``buf`` (each ends at an index of ``nl``)."""
        err = self.errors
        ls = np.concatenate(([0], nl[:-1] + 1))
        d = np.flatnonzero(b[: int(nl[-1])] == 0x24)
        k_first = np.searchsorted(d, ls)
        k_end = np.searchsorted(d, nl)  # one past the line's last '$'
        has = k_end > k_first
        first = nl.copy()
        first[has] = d[k_first[has]]
        echo = (ls + 1 < nl) & (b[ls] == 0x3E) & (b[np.minimum(ls + 1, b.size - 1)] == 0x20)
        err["garbage_bytes"] += int((first - ls)[~echo].sum())
        if not d.size:
            return []
        bodies: list[str] = []
        found = dollar_lines(buf, b, ls[has], nl[has], d, err)
        for at in range(0, len(found), _CHECK_BATCH):
            batch = found[at : at + _CHECK_BATCH]
            crcs = crc16_many([body for _, body, _ in batch]).tolist()
            for (_, body, sent), got in zip(batch, crcs):
                if sent == got:
                    bodies.append(body.decode("ascii"))
                else:
                    err["bad_crc"] += 1
        return bodies

    def _tail(self, text: bytes, last: str) -> None:
        """Text without a line end given up: cut by the end of the input, by a
        later ``$`` or open for more than ``MAX_LINE`` bytes; ``last``: what
        its last line (from its last ``$``) counts as."""
        if not text:
            return
        err = self.errors
        first = text.find(b"$")
        if not text.startswith(b"> "):
            err["garbage_bytes"] += first if first >= 0 else len(text)
        if first < 0:
            return
        err["restarted"] += text.count(b"$", first + 1)
        err[last] += 1


def dollar_lines(
    buf: bytes, b: np.ndarray, starts: np.ndarray, stops: np.ndarray, dollars: np.ndarray, errors: dict[str, int]
) -> list[tuple[int, bytes, int]]:
    """The one cutter of ``$`` lines (``LineSplitter`` and the stream decoder use
    it): of the lines [starts, stops) of ``buf`` (``b`` its bytes; stops: the
    line's end, before CR LF), each holding a ``$`` (``dollars``: every ``$`` of
    ``buf``, sorted), the candidates (index of the body, body, sent CRC) from
    the line's last ``$`` on, shaped ``body*XXXX`` (checked vectorized first,
    so that a flood of ``$`` lines stays cheap).  Counts ``restarted`` (a
    ``$`` after the first) and ``malformed`` in ``errors``; the CRC is the
    caller's to check."""
    if starts.size == 0:
        return []
    k_first = np.searchsorted(dollars, starts)
    k_end = np.searchsorted(dollars, stops)  # one past the line's last '$'
    errors["restarted"] += int((k_end - k_first - 1).sum())
    start = dollars[k_end - 1] + 1  # after the line's last '$'
    length = stops - start
    shaped = (length >= 5) & (length - 5 <= MAX_BODY)
    shaped[shaped] = b[stops[shaped] - 5] == 0x2A  # '*' before the 4 CRC digits
    errors["malformed"] += int(np.count_nonzero(~shaped))
    found: list[tuple[int, bytes, int]] = []
    for s, e in zip(start[shaped].tolist(), stops[shaped].tolist()):
        m = LINE.fullmatch(buf, s, e)
        if m is None:
            errors["malformed"] += 1
        else:
            found.append((s, m.group(1), int(m.group(2), 16)))
    return found


def cr_line_ends(res: bytes, final: bool) -> tuple[bytes, np.ndarray]:
    """A CR not followed by LF ends a line as LF does (a capture saved with
    CR-only line ends reads as one with CR LF): the text with those CRs made
    LF (same length: frame positions hold), and where they were.  A CR at the
    end of unfinished text waits for the next byte."""
    if b"\r" not in res:
        return res, np.zeros(0, dtype=np.int64)
    r = np.frombuffer(res, dtype=np.uint8)
    cr = np.flatnonzero(r == 0x0D)
    after = np.append(r, 0x0A if not final else 0)[cr + 1]
    lone = cr[after != 0x0A] if final else cr[(after != 0x0A) & (cr + 1 < r.size)]
    if lone.size == 0:
        return res, lone
    out = bytearray(res)
    np.frombuffer(out, dtype=np.uint8)[lone] = 0x0A
    return bytes(out), lone


# ---- binary sample frames -------------------------------------------------------------

SYNC = 0xA5
FRAME_BYTES = 13
FRAME_CODES = len(COLUMNS)
"""Codes per frame: ax ay az gx gy gz temp."""


def encode_frame(seq: int, codes: Any) -> bytes:
    """The 13-byte binary frame of one sample set (7 codes 0..1023)."""
    c = [int(v) for v in codes]
    if len(c) != FRAME_CODES or not all(0 <= v <= CODE_MAX for v in c) or not 0 <= seq <= 255:
        raise ValueError("a frame holds seq 0..255 and 7 codes 0..1023")
    hi = sum((v >> 8) << (2 * i) for i, v in enumerate(c))
    body = bytes([seq] + [v & 0xFF for v in c] + [hi & 0xFF, hi >> 8])
    crc = crc16(body)
    return bytes([SYNC]) + body + bytes([crc >> 8, crc & 0xFF])


def frame_crc_ok(b: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """For each candidate start (index of a 0xA5 at least 13 bytes from the
    end of ``b``): does the CRC of bytes 1-10 equal bytes 11-12?"""
    g = b[starts[:, None] + np.arange(1, FRAME_BYTES)].astype(np.int64)  # (k, 12)
    return crc16_columns(g[:, :10]) == (g[:, 10] << 8) | g[:, 11]


def frame_bytes(b: np.ndarray, starts: np.ndarray) -> list[bytes]:
    """The 13 bytes of each frame at ``starts``, as received (for count lines' block CRC)."""
    g = b[starts[:, None] + np.arange(FRAME_BYTES)]
    return [row.tobytes() for row in g]


def frame_codes(b: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sequence numbers (k,) and codes (7, k) of the intact frames at ``starts``."""
    g = b[starts[:, None] + np.arange(1, 11)].astype(np.uint16)  # seq, 7 low, hi word
    hi = g[:, 8] | (g[:, 9] << 8)
    shifts = (2 * np.arange(FRAME_CODES)).astype(np.uint16)
    codes = g[:, 1:8] | (((hi[:, None] >> shifts) & 3) << 8)
    return g[:, 0].astype(np.int64), np.ascontiguousarray(codes.T)
