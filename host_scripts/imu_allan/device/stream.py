"""One pass over a captured byte stream that mixes every output mode.

A capture of the device (docs/protocol.md) may interleave framed text lines
(``$<body>*<CRC>\\r\\n``: reports, replies, boots, count lines ``$C,<rows>``),
raw thesis rows (7 tab-separated codes and CR LF, no checksum) and 13-byte
binary frames (``0xA5``, seq, 7 low bytes, 16-bit LE high-bits word,
CRC-16/CCITT-FALSE of bytes 1-10, high byte first).  ``StreamDecoder`` takes
the stream in pieces of any size (a file read in blocks, or a serial port)
and returns, in stream order, the samples of intact rows and frames, the
complete reports, replies and boots, and counts everything it had to throw
away.  Nothing unchecked is returned: a damaged row or frame is counted and
skipped.

Resync rules, in the order they apply:

1. Binary frames first.  A frame starts at a ``0xA5`` byte; it is intact when
   the CRC of its bytes 1-10 equals bytes 11-12.  Frames are taken greedily
   from the left: an intact frame's 13 bytes are cut out of the stream (any
   byte may occur inside, ``$``, CR and LF included), a ``0xA5`` whose CRC
   fails is counted (``bad_frames``) and the search moves on by one byte.
   Text never contains ``0xA5``, so the bytes left form the text stream; a
   frame that came in the middle of a text line (the firmware lets frames
   cut into text) does not break that line.  A ``0xA5`` less than 13 bytes
   from the end of the capture is a frame cut short (``truncated``).
2. A ``$`` starts a framed text line, wherever it is; the line ends at LF.
   A ``$`` before that LF restarts the line (``restarted``).  The line is
   used only if ``<body>*<CRC>`` is well formed and the CRC matches
   (``malformed``, ``bad_crc`` otherwise).  Bytes before the ``$`` on the
   same line are ``garbage_bytes``.  A line still without its LF after
   4096 bytes of text, or after 64 frames came into it, is given up
   (``malformed``).
3. A raw row is a whole line without ``$``: it must follow an LF (so the
   first line of a capture, which usually starts mid-row, is never taken:
   its bytes count as ``garbage_bytes``) and end with LF, CR before it
   optional.  It must be exactly 7 codes of 1-4 decimal digits, 0..1023,
   separated by one tab each, nothing else; any other non-empty line is a
   ``bad_rows``.  Empty lines are ignored.  A row cut by a ``$`` is garbage
   before that ``$``; a row cut by the end of the capture is ``truncated``.
   Raw rows carry no checksum of their own: a digit changed into another
   digit is seen only by the count line's block CRC (rule 4).
4. Count lines ``$C,<rows>`` check the samples received between two count
   lines (raw rows and binary frames, both counted: the firmware also sends
   count lines in binary mode) against the difference of their counts; the
   shortfall is ``rows_lost``.  An interval cannot be checked
   (``count_unchecked``) when the count restarted in it: a boot or a reply
   saying ``reset``, ``loaded``, ``defaults`` or ``mode=...`` came between,
   or the count went down, or more samples arrived than it went up.  A
   count line's second field is the device's own ``drops`` (sample sets it
   lost, since its last reset): ``device_drops`` adds them up over the runs
   of the capture.  Its fourth field, ``block``, is the CRC-16/MODBUS of the
   bytes of the rows (as received: digits, tabs, CR, LF) or frames (13
   bytes) since the previous count line, or since the count restarted.  A
   block is verified (``blocks_verified``) when both its count and its CRC
   match the samples received, taken from the previous count line or, after
   a restart marker, from the marker (whichever matches); otherwise it is bad
   (``blocks_bad``, its samples in ``rows_in_bad_blocks``: a row changed,
   lost or added).  Samples no block CRC vouched for (after the last count
   line, before a restart that no count line covers, before the first count
   line of a capture that started mid-block, or under count lines without
   ``block`` from older firmware, ``count_lines_nocrc``) are
   ``rows_unverified``.  With ``verified_only`` the decoder holds samples
   until their count line arrived and drops the samples of bad blocks
   (``rows_dropped``); unverified samples are returned and counted, since no
   check exists that could tell them wrong (the partial block at a mode
   switch or at the capture's end).
5. Frame sequence numbers: a gap between consecutive intact frames counts
   ``(seq - previous - 1) mod 256`` lost frames (``frames_lost``; 256 or
   more frames lost in a row are undercounted), except across a restart
   marker as in 4 (the sequence restarts at 0 with the mode and a new run).

Records (reports, replies, boots) go through ``decode.Assembler``, with the
same error counts as ``decode_bytes``.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from .framing import (
    FRAME_BYTES,
    cr_line_ends,
    crc16_many,
    crc16_modbus,
    dollar_lines,
    frame_bytes,
    frame_codes,
)
from .records import (
    ERROR_KEYS,
    Assembler,
    BodyError,
    parse_count,
    parse_count_block,
    resets_run,
    restarts_output,
)
from .scan import ECHO, NCOL, Chunk, _frames, _joined, _row_bytes, _rows, _text

MAX_CARRY = 4096
"""Text without an LF kept waiting for its end; beyond it, it is garbage."""
MAX_WAITING_FRAMES = 64
"""Frames that may wait for the end of a text line they cut into (the
firmware cuts a line into steps of at most 20 bytes); beyond, the line is
given up as malformed."""

STREAM_KEYS = (
    "rows",
    "bad_rows",
    "count_lines",
    "rows_lost",
    "count_unchecked",
    "frames",
    "bad_frames",
    "frames_lost",
    "device_drops",
    "blocks_verified",
    "blocks_bad",
    "rows_in_bad_blocks",
    "rows_unverified",
    "count_lines_nocrc",
    "rows_dropped",
)
"""Counters of raw rows and binary frames; ``counts`` also holds ``ERROR_KEYS``."""

LOSS_KEYS = ("bad_rows", "rows_lost", "bad_frames", "frames_lost", "device_drops", "blocks_bad")
"""Counters that mean samples were lost or damaged on the way."""
HOLD_MAX = 1000
"""Samples kept waiting for a count line (100 rows or frames apart); beyond,
the oldest are given up as unverified (or, before any block CRC was seen,
returned unverified as older firmware's were)."""

_CRC_BATCH = 4096
"""Lines whose CRC is computed at a time (bounds crc16_many's grid)."""
FEED_BYTES = 1 << 18
"""Bytes decoded in one step (a larger ``feed`` is cut into such steps): bounds
the per-line index arrays whatever the input (a block of nothing but line ends
held some 60 bytes of them per byte)."""


class StreamDecoder:
    """Incremental decoder of a mixed capture (see the module docstring).

    ``feed(data)`` as bytes arrive, ``finish()`` at the end; each returns a
    ``Chunk``.  ``counts`` holds the running totals of ``STREAM_KEYS`` and
    ``ERROR_KEYS``.  ``line_start``: whether the capture starts at the start
    of a line (a capture from a port opened mid-stream does not).
    """

    def __init__(self, line_start: bool = False, verified_only: bool = False) -> None:
        self.counts: dict[str, int] = dict.fromkeys(STREAM_KEYS + ERROR_KEYS, 0)
        self._asm = Assembler(self.counts)
        self._pending = b""  # raw bytes from the first undecided 0xA5
        self._carry = b""  # text after the last LF, waiting for its end
        self._carry_line_start = line_start
        self._dpos = np.zeros(0, dtype=np.int64)  # frames waiting behind the carry
        self._dseq = np.zeros(0, dtype=np.int64)
        self._dcodes = np.zeros((NCOL, 0), dtype=np.uint16)
        self._dbytes: list[bytes] = []
        self._verified_only = verified_only
        self._crc_seen = False  # a count line with a block CRC came
        self._held_from = 0  # global index of the first held sample
        self._held_bytes: list[bytes] = []  # each held sample's bytes, as received
        self._held = np.zeros((NCOL, 0), dtype=np.uint16)
        self._held_frame = np.zeros(0, dtype=bool)
        self._marker: Optional[int] = None  # sample index of the last restart marker
        self._samples = 0  # samples returned so far
        self._count_base: Optional[tuple[int, int]] = None  # (count, samples then)
        self._count_restart = False
        self._drops_before = 0  # device drops of the runs before this one (count lines)
        self._run_drops = 0  # this run's, from its last count line
        self._last_seq: Optional[int] = None
        self._frame_restart = False
        self._done = False
        self.text_lines = 0
        """Intact framed text lines (``$...*CRC``) so far, count lines included."""

    @property
    def samples(self) -> int:
        return self._samples

    @property
    def warnings(self) -> list[str]:
        """What must be said next to the reports (``records.Assembler.warnings``):
        a refused T line, seq going backwards without a boot line."""
        return self._asm.warnings

    def feed(self, data: bytes) -> Chunk:
        if self._done:
            raise ValueError("feed() after finish()")
        data = bytes(data)
        if len(data) <= FEED_BYTES:
            return self._process(self._pending + data, final=False)
        parts = [
            self._process(self._pending + data[at : at + FEED_BYTES], final=False)
            for at in range(0, len(data), FEED_BYTES)
        ]
        return _joined(parts)

    def finish(self) -> Chunk:
        if self._done:
            return Chunk()
        chunk = self._process(self._pending, final=True)
        self._asm.finish()
        self._done = True
        return chunk

    # ---- one step ---------------------------------------------------------------

    def _process(self, buf: bytes, final: bool) -> Chunk:
        c = self.counts
        res, fpos, fseq, fcodes, fbytes = self._cut_frames(buf, final)
        res, lone = cr_line_ends(res, final)

        r = np.frombuffer(res, dtype=np.uint8)
        lf = np.flatnonzero(r == 0x0A)
        end = int(lf[-1]) + 1 if lf.size else 0  # whole lines end here
        ls = np.concatenate(([0], lf[:-1] + 1)) if lf.size else np.zeros(0, dtype=np.int64)
        dollars = np.flatnonzero(r[:end] == 0x24)
        dline = np.unique(np.searchsorted(lf, dollars)) if dollars.size else dollars
        cand = np.ones(lf.size, dtype=bool)
        cand[dline] = False
        cand[r[ls] == ECHO] = False  # the device's echo of a typed line: not data
        if lf.size and not self._carry_line_start:
            cand[0] = False
            if 0 not in dline:
                c["garbage_bytes"] += _text(res[: int(lf[0])])
        rows_at, rows, bad_rows = _rows(r, ls, lf, cand)
        c["bad_rows"] += bad_rows
        c["rows"] += rows_at.size
        rkey = 2 * lf[rows_at] + 1

        # framed text lines: a loop over the lines holding a '$' (few)
        found = self._dollar_lines(res, r, ls[dline], lf[dline], dollars)
        carry = res[end:]
        if final:
            self._give_up(carry, ended=True)
            carry, release = b"", len(res)
        else:
            if end:
                self._carry_line_start = True
            j = carry.find(b"$")
            # frames wait only behind an unfinished '$' line (a count line or a
            # restart marker decides how they count); a row cannot reorder them
            release = len(res) if j < 0 else end + j
            if len(carry) > MAX_CARRY or np.count_nonzero(fpos > release) > MAX_WAITING_FRAMES:
                self._give_up(carry, ended=False)
                carry, release = b"", len(res)
                self._carry_line_start = False
        self._carry = carry

        now = fpos <= release
        self._dpos, self._dseq = fpos[~now] - end, fseq[~now]
        self._dcodes = fcodes[:, ~now]
        self._dbytes = [fb for fb, w in zip(fbytes, now.tolist()) if not w]
        fbytes = [fb for fb, w in zip(fbytes, now.tolist()) if w]
        fpos, fseq, fcodes = fpos[now], fseq[now], fcodes[:, now]

        bodies: list[tuple[int, str]] = []
        if found:
            crcs = [
                v
                for at in range(0, len(found), _CRC_BATCH)
                for v in crc16_many([body for _, body, _ in found[at : at + _CRC_BATCH]]).tolist()
            ]
            bodies = [(key, body.decode("ascii")) for (key, body, sent), got in zip(found, crcs) if sent == got]
            c["bad_crc"] += len(found) - len(bodies)
            self.text_lines += len(bodies)

        # samples in stream order
        fkey = 2 * fpos
        keys = np.concatenate((rkey, fkey))
        order = np.argsort(keys, kind="stable")
        out = Chunk(
            samples=np.concatenate((rows, fcodes), axis=1)[:, order],
            from_frame=np.concatenate((np.zeros(rows_at.size, dtype=bool), np.ones(fpos.size, dtype=bool)))[order],
        )
        skeys = keys[order]
        self._hold(_row_bytes(res, ls, lf, rows_at, lone) + fbytes, order, out)
        self._frame_gaps(fkey, fseq, [k for k, body in bodies if restarts_output(body)])
        released: list[tuple[np.ndarray, np.ndarray]] = []
        self._records(bodies, skeys, out, released)
        self._samples += skeys.size
        self._release(final, released, out)
        return out

    def _hold(self, sbytes: list[bytes], order: np.ndarray, out: Chunk) -> None:
        """Keep this step's samples (in stream order) and their bytes until a
        count line decides on them."""
        self._held_bytes.extend(sbytes[i] for i in order.tolist())
        self._held = np.concatenate((self._held, out.samples), axis=1)
        self._held_frame = np.concatenate((self._held_frame, out.from_frame))

    def _release(self, final: bool, released: list[tuple[np.ndarray, np.ndarray]], out: Chunk) -> None:
        """Give up what waits too long (or everything, at the end); with
        ``verified_only`` the chunk's samples become the released ones."""
        limit = self._samples - HOLD_MAX
        if final:
            self._settle(self._samples, self._samples, released)
        elif self._held_from < limit:
            self._settle(limit, limit, released)
        if self._verified_only:
            out.samples = (
                np.concatenate([s for s, _ in released], axis=1) if released else np.zeros((NCOL, 0), dtype=np.uint16)
            )
            out.from_frame = np.concatenate([f for _, f in released]) if released else np.zeros(0, dtype=bool)

    def _settle(
        self, start: int, end: int, released: list[tuple[np.ndarray, np.ndarray]], verdict: Optional[bool] = None
    ) -> None:
        """Let go of the held samples before ``end``: those before ``start``
        no block CRC vouched for, those in [start, end) verified (``verdict``
        True), bad (False) or unverified (None)."""
        c = self.counts
        base = self._held_from
        a, b = start - base, end - base
        # Samples no block CRC covers (the partial block before a mode switch or
        # the capture's end) cannot be verified, but nothing says they are wrong:
        # they are written, counted as unverified and said; only a block whose CRC
        # or count fails is dropped.
        if a > 0:
            c["rows_unverified"] += a
            released.append((self._held[:, :a], self._held_frame[:a]))
        if b > a:
            if verdict is None:
                c["rows_unverified"] += b - a
            if verdict is not False:
                released.append((self._held[:, a:b], self._held_frame[a:b]))
            else:
                c["rows_dropped"] += b - a
        self._held_from = end
        self._held_bytes = self._held_bytes[b:]
        self._held = self._held[:, b:]
        self._held_frame = self._held_frame[b:]

    def _count_block(
        self, here: int, value: int, block: Optional[int], released: list[tuple[np.ndarray, np.ndarray]]
    ) -> None:
        """A count line after ``here`` samples: verify the block it closes."""
        c = self.counts
        if block is None:
            c["count_lines_nocrc"] += 1
            self._settle(here, here, released)
            return
        self._crc_seen = True
        tries = []  # (first sample of the block, rows the device sent in it)
        if self._marker is not None:
            tries.append((self._marker, value))  # the count restarted at the marker
        if self._count_base is not None and value >= self._count_base[0]:
            tries.append((self._count_base[1], value - self._count_base[0]))
        if not tries:
            tries.append((max(here - value, self._held_from), value))  # the capture's first block
        for start, sent in tries:
            if (
                start >= self._held_from
                and here - start == sent
                and crc16_modbus(b"".join(self._held_bytes[start - self._held_from : here - self._held_from])) == block
            ):
                c["blocks_verified"] += 1
                self._settle(start, here, released, True)
                return
        if self._count_base is None and self._marker is None:
            self._settle(here, here, released)  # mid-block start: nothing to hold it to
            return
        start = tries[0][0]
        c["blocks_bad"] += 1
        c["rows_in_bad_blocks"] += here - max(start, self._held_from)
        self._settle(max(start, self._held_from), here, released, False)

    def _cut_frames(self, buf: bytes, final: bool) -> tuple[bytes, np.ndarray, np.ndarray, np.ndarray, list[bytes]]:
        """Take the intact binary frames out of ``buf`` (rule 1): the text left
        (behind the carried text), and the frames (those waiting from the last
        step first): their positions in that text, sequence numbers and codes."""
        c = self.counts
        b = np.frombuffer(buf, dtype=np.uint8)
        starts, bad, cut = _frames(b, final)
        c["bad_frames"] += bad
        if final and cut < b.size:
            c["truncated"] += 1  # a frame cut short by the end of the capture
            drop_from = cut
            cut = b.size
        else:
            drop_from = cut
        self._pending = b"" if final else buf[cut:]
        seq, codes = frame_codes(b, starts)
        c["frames"] += starts.size
        if starts.size:
            keep = np.ones(drop_from, dtype=bool)
            keep[(starts[:, None] + np.arange(FRAME_BYTES)).ravel()] = False
            text = b[:drop_from][keep].tobytes()
        else:
            text = buf[:drop_from]
        carry_len = len(self._carry)
        res = self._carry + text
        fpos = carry_len + starts - FRAME_BYTES * np.arange(starts.size)  # spliced before this byte
        fpos = np.concatenate((self._dpos, fpos))
        fseq = np.concatenate((self._dseq, seq))
        fcodes = np.concatenate((self._dcodes, codes), axis=1)
        return res, fpos, fseq, fcodes, self._dbytes + frame_bytes(b, starts)

    def _give_up(self, carry: bytes, ended: bool) -> None:
        """Text after the last LF that will not be completed: cut by the end of
        the capture (``ended``), or too long / holding frames back too long."""
        if not carry:
            return
        c = self.counts
        first = carry.find(b"$")  # counted, not split: a carry of a million '$' stays cheap
        dollars = carry.count(b"$")
        head = carry if first < 0 else carry[:first]
        c["garbage_bytes"] += _text(head) if dollars or not ended else 0
        c["restarted"] += max(dollars - 1, 0)
        if ended and (dollars or _text(head)):
            c["truncated"] += 1
        elif not ended and dollars:
            c["malformed"] += 1  # a line that never ended

    def _dollar_lines(
        self, res: bytes, r: np.ndarray, starts: np.ndarray, ends: np.ndarray, dollars: np.ndarray
    ) -> list[tuple[int, bytes, int]]:
        """The whole lines [starts, ends) (ends: their LF) that hold a '$':
        garbage before the first '$' counted here, the rest cut by framing's
        one line cutter (``dollar_lines``): candidates (key, body, sent CRC)."""
        if starts.size == 0:
            return []
        c = self.counts
        c["garbage_bytes"] += int((dollars[np.searchsorted(dollars, starts)] - starts).sum())
        stop = ends - (r[np.maximum(ends - 1, 0)] == 0x0D)  # a CR before the LF is the line's end
        return [(2 * s - 1, body, sent) for s, body, sent in dollar_lines(res, r, starts, stop, dollars, c)]

    def _frame_gaps(self, fkey: np.ndarray, fseq: np.ndarray, marks: list[int]) -> None:
        if fkey.size == 0:
            self._frame_restart = self._frame_restart or bool(marks)
            return
        m = np.searchsorted(np.array(marks, dtype=np.int64), fkey)  # markers before each frame
        prev = np.concatenate(([-1 if self._last_seq is None else self._last_seq], fseq[:-1]))
        crossed = np.diff(m, prepend=0) > 0
        crossed[0] |= self._frame_restart
        valid = ~crossed & (prev >= 0)
        self.counts["frames_lost"] += int(((fseq - prev - 1) % 256)[valid].sum())
        self._last_seq = int(fseq[-1])
        self._frame_restart = len(marks) > int(m[-1])

    def _records(
        self,
        bodies: list[tuple[int, str]],
        skeys: np.ndarray,
        out: Chunk,
        released: list[tuple[np.ndarray, np.ndarray]],
    ) -> None:
        asm, c = self._asm, self.counts
        n_rep, n_rpl, n_boot = len(asm.reports), len(asm.replies), len(asm.boots)
        for key, body in bodies:
            if body.startswith("C,") or body == "C":
                try:
                    value, drops = parse_count(body.split(",")[1:])
                    block = parse_count_block(body.split(",")[1:])
                except BodyError:
                    c["unparsable"] += 1
                    continue
                c["count_lines"] += 1
                out.counts.append(value)
                here = self._samples + int(np.searchsorted(skeys, key))
                if self._count_base is not None:
                    got = here - self._count_base[1]
                    sent = value - self._count_base[0]
                    if self._count_restart or sent < 0 or got > sent:
                        c["count_unchecked"] += 1
                    else:
                        c["rows_lost"] += sent - got
                self._count_block(here, value, block, released)
                self._count_base = (value, here)
                self._count_restart = False
                self._marker = None
                if drops is not None:
                    self._run_drops = drops
                    c["device_drops"] = self._drops_before + drops
                continue
            if restarts_output(body):
                self._count_restart = True
                self._marker = self._samples + int(np.searchsorted(skeys, key))
            if resets_run(body):
                self._drops_before += self._run_drops
                self._run_drops = 0
            asm.add(body)
        out.reports = asm.reports[n_rep:]
        out.replies = asm.replies[n_rpl:]
        out.boots = asm.boots[n_boot:]
