"""The byte-level scans behind stream.py's ``StreamDecoder``, vectorized over
a piece of the capture: binary frames found and CRC-checked, text split into
lines, raw rows recognised and parsed (the rules are stream.py's docstring)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .framing import CODE_MAX, FRAME_BYTES, FRAME_CODES, SYNC, frame_crc_ok
from .records import Boot, DeviceReport

NCOL = FRAME_CODES  # ax ay az gx gy gz temp


def _joined(parts: list["Chunk"]) -> "Chunk":
    """The chunks of consecutive steps as one."""
    out = Chunk(
        samples=np.concatenate([p.samples for p in parts], axis=1),
        from_frame=np.concatenate([p.from_frame for p in parts]),
    )
    for p in parts:
        out.reports += p.reports
        out.replies += p.replies
        out.boots += p.boots
        out.counts += p.counts
    return out


_CLASS = np.zeros(256, dtype=np.uint8)  # 0 other, 1 digit, 2 tab, 3 LF, 4 CR
_CLASS[0x30:0x3A] = 1
_CLASS[0x09] = 2
_CLASS[0x0A] = 3
_CLASS[0x0D] = 4


@dataclass
class Chunk:
    """What one ``feed`` (or ``finish``) decoded, in stream order."""

    samples: np.ndarray = field(default_factory=lambda: np.zeros((NCOL, 0), dtype=np.uint16))
    """(7, n) uint16 codes of intact raw rows and binary frames, in stream order."""
    from_frame: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    """(n,) True where the sample came from a binary frame, False for a raw row."""
    reports: list[DeviceReport] = field(default_factory=list)
    replies: list[str] = field(default_factory=list)
    boots: list[Boot] = field(default_factory=list)
    counts: list[int] = field(default_factory=list)
    """Values of the intact count lines."""


def _frames(b: np.ndarray, final: bool) -> tuple[np.ndarray, int, int]:
    """Intact frame starts (greedy, left to right), count of failed 0xA5s
    before the cut, and the cut: the first 0xA5 too near the end to decide
    (the whole length when ``final`` or when there is none)."""
    n = b.size
    syncs = np.flatnonzero(b == SYNC)
    ready = syncs[syncs <= n - FRAME_BYTES]
    if ready.size:
        good = ready[frame_crc_ok(b, ready)]
    else:
        good = ready
    if good.size > 1 and np.any(np.diff(good) < FRAME_BYTES):  # rare: a false match inside
        keep, end = [], -1
        for p in good.tolist():
            if p >= end:
                keep.append(p)
                end = p + FRAME_BYTES
        good = np.array(keep, dtype=np.int64)
    inside = np.zeros(syncs.size, dtype=bool)
    if good.size:
        k = np.searchsorted(good, syncs, side="right") - 1
        inside = (k >= 0) & (syncs < good[np.maximum(k, 0)] + FRAME_BYTES)
    loose = syncs[~inside]
    late = loose[loose > n - FRAME_BYTES]
    cut = int(late[0]) if late.size else n
    bad = int(np.count_nonzero(loose < cut))
    return good, bad, cut


def _text(chunk: bytes) -> int:
    return len(chunk) - chunk.count(b"\r") - chunk.count(b"\n")


def _row_bytes(res: bytes, ls: np.ndarray, lf: np.ndarray, rows_at: np.ndarray, lone: np.ndarray) -> list[bytes]:
    """Each raw row's bytes for its block CRC, as received from its first digit
    through its LF; a row ended by a CR alone is taken with the CR LF the
    device sent."""
    if lone.size == 0:
        return [res[int(ls[i]) : int(lf[i]) + 1] for i in rows_at.tolist()]
    ends = set(lone.tolist())
    return [
        res[int(ls[i]) : int(lf[i])] + b"\r\n" if int(lf[i]) in ends else res[int(ls[i]) : int(lf[i]) + 1]
        for i in rows_at.tolist()
    ]


ECHO = 0x3E
"""'>': the device's echo of a typed command line starts with "> " (docs/protocol.md)."""


def _rows(b: np.ndarray, ls: np.ndarray, le: np.ndarray, cand: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Raw rows among whole lines [ls, le) (le: index of the LF) of ``b``.

    ``cand``: the lines that may be rows (whole, without '$').  Returns the
    indices of the valid lines, their codes (7, n) and the count of non-empty
    candidates that are not valid rows.
    """
    nl = ls.size
    if nl == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((NCOL, 0), dtype=np.uint16), 0
    lo, hi = int(ls[0]), int(le[-1]) + 1
    cls = _CLASS[b[lo:hi]]
    ls0, le0 = ls - lo, le - lo
    has_cr = (le0 > ls0) & (cls[np.maximum(le0 - 1, 0)] == 4)
    ce = le0 - has_cr  # content end
    blank = ce == ls0
    other = np.flatnonzero((cls == 0) | (cls == 4))
    line_of = np.searchsorted(le0, other)
    final_cr = (cls[other] == 4) & (other == le0[line_of] - 1)
    bad = np.zeros(nl, dtype=bool)
    bad[line_of[~final_cr]] = True
    tabs = np.bincount(np.searchsorted(le0, np.flatnonzero(cls == 2)), minlength=nl)
    d = cls == 1
    rs = np.flatnonzero(d[1:] & ~d[:-1]) + 1
    if d[0]:
        rs = np.concatenate(([0], rs))
    re_ = np.flatnonzero(d[:-1] & ~d[1:]) + 1  # the region ends with LF: runs end inside
    runs = np.bincount(np.searchsorted(le0, rs), minlength=nl)
    first = np.cumsum(runs) - runs
    shaped = cand & ~blank & ~bad & (tabs == NCOL - 1) & (runs == NCOL)
    idx = np.flatnonzero(shaped)
    r = first[idx][:, None] + np.arange(NCOL)  # the 7 digit runs of each shaped line
    start, length = rs[r], re_[r] - rs[r]
    value = np.zeros(r.shape, dtype=np.int64)
    for p in range(4):
        more = length > p
        value[more] = value[more] * 10 + (b[lo + start[more] + p].astype(np.int64) - 0x30)
    ok = (length <= 4).all(axis=1) & (value <= CODE_MAX).all(axis=1)
    nonempty = int(np.count_nonzero(cand & ~blank))
    good = idx[ok]
    return good, np.ascontiguousarray(value[ok].T.astype(np.uint16)), nonempty - good.size
