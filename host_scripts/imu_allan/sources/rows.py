"""Thesis rows: the raw ADC stream as text, one sample set per line.

Each data line holds 7 integer codes (0..1023) separated by tabs or spaces:
``ax ay az gx gy gz temp``. ``#`` starts a comment (to the end of the line);
a line starting with ``$`` is a protocol line (count lines ``$C,...`` and
replies inside a raw capture of the device) and is skipped whole, as
imu-sim does; blank lines are ignored. ``-`` as a path means stdin/stdout.
A capture with binary frames or damaged rows: ``imu-allan rows`` (stream.py).

Reading goes a few MB at a time through the compiled reader beside the Allan
kernels (stats/ck_text.c; pandas' C reader where it is not built; bench/parsers.py
measures them beside pyarrow's and this module's numpy reader), and through the
numpy reader for a block with a fault, which it names by line; writing is
vectorized the same way.
"""

from __future__ import annotations

import io
import re
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Iterator, Optional

import numpy as np

from ..channels import CODE_MAX, COLUMNS
from ..device.files import BLOCK_BYTES, PathLike, input_name, read_blocks
from ..errors import InputError

_COMMENT = re.compile(rb"#[^\n]*")
_PROTOCOL_LINE = re.compile(rb"^\$[^\n]*", re.MULTILINE)
_POW10 = 10 ** np.arange(10, dtype=np.int64)


PARSERS = 2
"""Blocks parsed at once (the compiled reader releases the GIL): the split into
whole lines stays in order, the numbers of the next block are read meanwhile."""


def iter_blocks(
    path: PathLike, block_bytes: int = BLOCK_BYTES, ncol: int = len(COLUMNS), name: Optional[str] = None
) -> Iterator[np.ndarray]:
    """Yield the rows of ``path`` as uint16 arrays of shape (ncol, rows).

    Channel-major blocks (each channel contiguous). Raises InputError naming
    the file (``name``: how to call it, e.g. ``<stdin>`` for its spooled copy)
    and line on the first malformed line.
    """
    name = input_name(path) if name is None else name
    line = 1  # file line number of the first line of the next block
    with ThreadPoolExecutor(PARSERS) as pool:
        pending: deque[tuple[bytes, Future[Optional[tuple[np.ndarray, int]]]]] = deque()
        for text, whole in _line_blocks(path, block_bytes):
            if not whole:  # a line longer than MAX_ROW_LINE after the blocks pending
                while pending:
                    block, line = _parsed(*pending.popleft(), name, line, ncol)
                    yield block
                at = line + text.count(b"\n")
                raise InputError(
                    f"{name}: line {at}: longer than {MAX_ROW_LINE} bytes without a line end: not a rows file"
                )
            pending.append((text, pool.submit(_compiled, text, ncol)))
            if len(pending) > PARSERS:
                block, line = _parsed(*pending.popleft(), name, line, ncol)
                yield block
        while pending:
            block, line = _parsed(*pending.popleft(), name, line, ncol)
            yield block


def _line_blocks(path: PathLike, block_bytes: int) -> Iterator[tuple[bytes, bool]]:
    """The text of ``path`` in blocks of whole lines (line ends as LF), in order:
    (text, True); (the text before it, False) at a line too long to be a row."""
    tail = b""
    for chunk in read_blocks(path, block_bytes):
        chunk = tail + chunk
        held = b"\r" if chunk.endswith(b"\r") else b""  # maybe the CR of a CR LF cut in two
        chunk = line_ends(chunk[: len(chunk) - len(held)])
        cut = chunk.rfind(b"\n") + 1
        tail = chunk[cut:] + held
        if len(tail) > MAX_ROW_LINE:
            yield chunk[:cut], False
            return
        if cut:
            yield chunk[:cut], True
    if tail:
        yield line_ends(tail), True


def _parsed(
    text: bytes, fut: Future[Optional[tuple[np.ndarray, int]]], name: str, line: int, ncol: int
) -> tuple[np.ndarray, int]:
    """A block from its compiled parse (or, on a fault, the exact reader, which
    names the line), and the line number after it."""
    got = fut.result()
    if got is None:
        return parse_exact(text, name, line, ncol), line + text.count(b"\n")
    return got[0], line + got[1]


MAX_ROW_LINE = 1 << 20
"""Longest line a rows file may have (a row is at most 7 codes and 6 blanks;
comments may be long, not a megabyte): the memory a line may take."""


def line_ends(text: bytes) -> bytes:
    """CR LF and a lone CR as LF: a rows file saved with any line ends reads alike."""
    return text.replace(b"\r\n", b"\n").replace(b"\r", b"\n") if b"\r" in text else text


def read_rows(path: PathLike, ncol: int = len(COLUMNS)) -> np.ndarray:
    """All rows of ``path``: uint16 array of shape (ncol, rows)."""
    blocks = list(iter_blocks(path, ncol=ncol))
    if not blocks:
        return np.zeros((ncol, 0), dtype=np.uint16)
    return np.concatenate(blocks, axis=1)


_CLASS = np.zeros(256, dtype=np.uint8)  # 0: not allowed, 1: blank, 2: digit
_CLASS[[0x20, 0x09, 0x0A, 0x0B, 0x0C, 0x0D]] = 1
_CLASS[0x30:0x3A] = 2


_ROW_BYTES = b"0123456789 \t\n"


def _compiled(block: bytes, ncol: int) -> Optional[tuple[np.ndarray, int]]:
    """The block through the compiled reader (stats/ck_text.c: every rule of
    the format in one pass), or pandas' C reader where the extension is not
    built (plain rows only: digits, blanks, line ends), and its line ends; None
    on any fault or doubt (a blank line for pandas, a short row, a code out of
    range): the exact reader below then names the line."""
    if not block:
        return None
    from ..stats.kernels import _C

    if _C is not None:
        cap = (len(block) + 1) // (2 * ncol - 1) + 1  # a row holds ncol digits and ncol - 1 blanks at least
        out = np.empty((ncol, cap), dtype=np.uint16)
        lines = np.zeros(1, dtype=np.int64)
        rows = _C.parse_rows(block, ncol, CODE_MAX, out, cap, lines)
        if rows < 0:
            return None
        return (out if rows == cap else np.ascontiguousarray(out[:, :rows])), int(lines[0])
    if b"#" in block or b"$" in block or block.translate(None, _ROW_BYTES):
        return None
    try:
        import pandas as pd

        sep = "\t" if b" " not in block else r"\s+"
        v = pd.read_csv(io.BytesIO(block), sep=sep, header=None, dtype=np.int64, engine="c").to_numpy()
    except Exception:
        return None
    if v.ndim != 2 or v.shape[1] != ncol or v.shape[0] != block.count(b"\n") + (not block.endswith(b"\n")):
        return None
    if v.size and (v.min() < 0 or v.max() > CODE_MAX):
        return None
    return np.ascontiguousarray(v.T.astype(np.uint16)), block.count(b"\n")


def parse_block(block: bytes, name: str, first_line: int, ncol: int) -> np.ndarray:
    """Parse whole lines of text into a (ncol, rows) uint16 array."""
    fast = _compiled(block, ncol)
    return fast[0] if fast is not None else parse_exact(block, name, first_line, ncol)


def parse_exact(block: bytes, name: str, first_line: int, ncol: int) -> np.ndarray:
    """``parse_block`` in numpy alone: every rule of the format, every fault named."""
    if b"$" in block:  # blocks start at a line start, so ^ is one
        block = _PROTOCOL_LINE.sub(b"", block)  # keeps the newlines: line numbers hold
    if b"#" in block:
        block = _COMMENT.sub(b"", block)
    b = np.frombuffer(block, dtype=np.uint8)
    if b.size == 0:
        return np.zeros((ncol, 0), dtype=np.uint16)
    cls = _CLASS[b]
    if not cls.all():
        i = int(np.argmin(cls))
        ch = chr(b[i])
        what = repr(ch) if ch.isprintable() else f"byte 0x{b[i]:02x}"
        raise InputError(
            f"{name}: line {_line_of(b, i, first_line)}: unexpected {what} "
            f"(a row is {ncol} integer codes separated by tabs or spaces)"
        )
    digit = cls.view(np.int8) - 1  # 1 digit, 0 blank
    edge = np.flatnonzero(digit[1:] != digit[:-1]) + 1
    if digit[0]:
        edge = np.concatenate(([0], edge))
    if digit[-1]:
        edge = np.append(edge, b.size)
    starts, ends = edge[0::2], edge[1::2]  # digit runs: [start, end)
    newlines = np.flatnonzero(b == 0x0A)
    before = np.searchsorted(starts, newlines)  # codes before each line end
    counts = np.diff(before, prepend=0, append=starts.size)  # codes per line
    wrong = (counts != 0) & (counts != ncol)
    if wrong.any():
        k = int(np.argmax(wrong))
        raise InputError(
            f"{name}: line {first_line + k}: {counts[k]} columns, expected {ncol} "
            f"({' '.join(COLUMNS) if ncol == len(COLUMNS) else 'integer codes'})"
        )
    if starts.size == 0:
        return np.zeros((ncol, 0), dtype=np.uint16)
    lengths = ends - starts
    width = int(lengths.max())
    if width > 9:
        i = int(starts[np.argmax(lengths > 9)])
        raise InputError(f"{name}: line {_line_of(b, i, first_line)}: code out of range 0..{CODE_MAX}")
    values = b[starts].astype(np.int64) - 0x30
    for p in range(1, width):  # over digit positions (at most 9), each vectorized
        more = np.flatnonzero(lengths > p)
        values[more] = values[more] * 10 + (b[starts[more] + p].astype(np.int64) - 0x30)
    over = values > CODE_MAX
    if over.any():
        t = int(np.argmax(over))
        raise InputError(
            f"{name}: line {_line_of(b, int(starts[t]), first_line)}: code {values[t]} out of range 0..{CODE_MAX}"
        )
    return np.ascontiguousarray(values.astype(np.uint16).reshape(-1, ncol).T)


def _line_of(b: np.ndarray, index: int, first_line: int) -> int:
    return first_line + int(np.count_nonzero(b[:index] == 0x0A))


def format_rows(codes: np.ndarray) -> bytes:
    """Rows (ncol, rows) of codes 0..9999 -> tab-separated text lines."""
    v = np.asarray(codes, dtype=np.int64).T  # (rows, ncol)
    if v.size == 0:
        return b""
    if v.min() < 0 or v.max() > 9999:
        raise ValueError("codes must be 0..9999")
    ndig = 1 + (v >= 10) + (v >= 100) + (v >= 1000)
    width = (ndig + 1).ravel()  # digits and a tab (or the newline)
    start = np.cumsum(width) - width
    out = np.full(int(width.sum()), ord("\t"), dtype=np.uint8)
    out[(start + width - 1).reshape(v.shape)[:, -1]] = ord("\n")
    flat, nd = v.ravel(), ndig.ravel()
    for p in range(4):
        sel = nd > p
        out[start[sel] + p] = 0x30 + (flat[sel] // _POW10[nd[sel] - 1 - p]) % 10
    return out.tobytes()


def write_rows(path: str, head: bytes, blocks: Iterator[np.ndarray]) -> None:
    """A rows file: ``head`` (comment lines) then each block of codes (shape
    (7, rows)); ``-`` writes to stdout.  An unwritable path is one InputError."""
    import sys

    try:
        with open(path, "wb") if path != "-" else open(sys.stdout.fileno(), "wb", closefd=False) as f:
            f.write(head)
            for block in blocks:
                f.write(format_rows(block))
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
