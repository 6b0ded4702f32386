"""A ROS 2 sqlite3 bag's ``messages`` rows read from the file's pages, in
rowid order, without sqlite's per-row work (its virtual machine and record
decoding were two thirds of a bag's reading time).

The table's b-tree is walked from its root page (sqlite_master says which)
to its leaves, whose pages are read in large sequential pieces, and its
cells decoded by a compiled reader (_db3pages.c) that checks each of them
against what rosbags' and rosbag2's writers make. The file format is
SQLite's documented, stable one (https://www.sqlite.org/fileformat2.html);
what this does not read (no compiled reader, a WAL beside the file, another
schema, a row that spills to overflow pages, anything unexpected) is read
through sqlite from where this stopped (``along`` returns the first rowid
not read).
"""

from __future__ import annotations

import os
import sqlite3
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from itertools import islice
from typing import Generator, NamedTuple, Optional

import numpy as np

try:
    from . import _db3pages as _C
except ImportError:  # built by `make ext`; without it sqlite reads every row
    _C = None

PIECE = 256
"""Leaf pages read and decoded at a time (1 MB of 4 KB pages, ~3000 sensor_msgs/Imu: in a core's
cache when the reader comes to them, where 2 MB pieces took about 1.4 times the CPU)."""
COLUMNS = [("id", 1), ("topic_id", 0), ("timestamp", 0), ("data", 0)]
"""The messages table's columns (name, part of the primary key) as rosbag2 makes them."""


class Decoded(NamedTuple):
    """The rows' messages decoded as sensor_msgs/Imu (imumsg.decode's results) by the compiled reader."""

    vals: np.ndarray  # (6, k) ax ay az gx gy gz
    stamps: np.ndarray  # (k,) header stamps, ns
    odd: np.ndarray  # (k,) bool: not the standard layout (values meaningless)
    keys: np.ndarray  # (k,) layout: 2 x length + 1 if big-endian
    ids: np.ndarray  # (k,) rowids: sqlite gives a message's bytes when they are needed


class Rows(NamedTuple):
    raw: np.ndarray  # the rows' data end to end (uint8); empty when ``imu``
    lens: np.ndarray  # (k,)
    times: np.ndarray  # (k,) the times the bag recorded them, ns
    after: int  # the first rowid past these rows
    imu: Optional[Decoded] = None  # the messages decoded instead of copied


def _leaves(fd: int, con: sqlite3.Connection) -> Optional[tuple[np.ndarray, int, int]]:
    """The messages table's leaf pages (numbers, in rowid order), page size and
    usable bytes of a page; None when the file is not one this reads."""
    head = os.pread(fd, 100, 0)
    if len(head) < 100 or not head.startswith(b"SQLite format 3\0"):
        return None
    size = int.from_bytes(head[16:18], "big")
    size = 65536 if size == 1 else size
    usable = size - head[20]
    cols = [(r[1], r[5]) for r in con.execute("PRAGMA table_info(messages)")]
    root = con.execute("SELECT rootpage FROM sqlite_master WHERE type = 'table' AND name = 'messages'").fetchone()
    if cols != COLUMNS or root is None or not root[0]:
        return None
    level = np.array([root[0]], dtype=np.int64)
    for _ in range(16):  # a b-tree's leaves all lie at one depth
        kids = []
        for n in level:
            pg = np.frombuffer(os.pread(fd, size, (int(n) - 1) * size), dtype=np.uint8)
            if n <= 1 or len(pg) < size:  # page 1 is sqlite_master's
                return None
            if pg[0] == 13:  # a table leaf: this level holds the leaves
                return level, size, usable
            if pg[0] != 5:  # not a table's interior page
                return None
            k = int(pg[3]) << 8 | int(pg[4])
            at = pg[12 : 12 + 2 * k].view(">u2").astype(np.int64)
            if len(at) != k or np.any(at > usable - 4):
                return None
            kids.append(np.r_[pg[at[:, None] + np.arange(4)].reshape(-1).view(">u4"), pg[8:12].view(">u4")])
        level = np.concatenate(kids).astype(np.int64)
    return None


def along(
    path: str, con: sqlite3.Connection, ids: list[int], first: int, imu: bool = False, join: int = 1
) -> Generator[Rows, None, Optional[int]]:
    """The rows of topics ``ids`` in rowid order (the least rowid: ``first``),
    in batches of pieces of ``PIECE`` pages joined until they hold ``join``
    rows (the work per batch downstream, in Python, is then small), the next pieces read and decoded by other threads
    meanwhile (the reads and the compiled reader let go of the GIL); ``imu``:
    the messages decoded as CDR sensor_msgs/Imu (``Rows.imu``), not copied.
    Returns None when every row was read, else the first rowid not read (the
    rest for sqlite to read)."""
    held: list[Rows] = []
    pieces = _pieces(path, con, ids, first, imu)
    while True:
        try:
            piece = next(pieces)
        except StopIteration as stop:
            if held:
                yield _joined(held)
            return stop.value
        held.append(piece)
        if sum(len(h.lens) for h in held) >= join:
            yield _joined(held)
            held = []


def _pieces(
    path: str, con: sqlite3.Connection, ids: list[int], first: int, imu: bool
) -> Generator[Rows, None, Optional[int]]:
    """``along``'s rows piece by piece (each at least one row)."""
    if _C is None or os.path.exists(path + "-wal") and os.path.getsize(path + "-wal"):
        return first
    want = np.zeros(max(ids) + 1, dtype=np.uint8)
    want[ids] = 1
    rows = _imu_rows if imu and hasattr(_C, "leaf_imu") else _rows  # a reader built before leaf_imu: the bytes
    with open(path, "rb") as f, ThreadPoolExecutor(AHEAD) as pool:
        got = _leaves(f.fileno(), con)
        if got is None:
            return first
        leaves, size, usable = got
        last = first - 1  # the last rowid read
        todo = iter(range(0, len(leaves), PIECE))
        ahead = deque(
            pool.submit(rows, f.fileno(), leaves[a : a + PIECE], size, usable, want) for a in islice(todo, AHEAD)
        )
        try:
            while ahead:
                piece = ahead.popleft().result()
                ahead.extend(
                    pool.submit(rows, f.fileno(), leaves[a : a + PIECE], size, usable, want) for a in islice(todo, 1)
                )
                if piece is None or piece[0] <= last:  # not read, or its rowids not after the last piece's
                    return last + 1
                if len(piece[1].lens):
                    yield piece[1]
                last = piece[1].after - 1
        finally:
            for job in ahead:
                job.cancel()
    return None


def _joined(pieces: list[Rows]) -> Rows:
    """The pieces as one batch, its arrays made by this thread: kept arrays
    made by the reading threads would pin their heaps after the rest is freed
    (a pass in memory took a third more)."""
    if len(pieces) == 1:
        return pieces[0]._replace(
            imu=None if pieces[0].imu is None else pieces[0].imu._replace(vals=pieces[0].imu.vals.copy())
        )
    imu = None
    if pieces[0].imu is not None:
        imu = Decoded(*(np.concatenate([getattr(p.imu, f) for p in pieces], axis=-1) for f in Decoded._fields))
    cat = [np.concatenate([getattr(p, f) for p in pieces]) for f in ("raw", "lens", "times")]
    return Rows(cat[0], cat[1], cat[2], pieces[-1].after, imu)


AHEAD = 2
"""Pieces read and decoded ahead, each by a thread of its own."""
LEAST = -(2**63)


def _rows(fd: int, pages: np.ndarray, size: int, usable: int, want: np.ndarray) -> Optional[tuple[int, Rows]]:
    """The first rowid of the leaf pages ``pages`` and the rows of the topics
    ``want`` on them (``after``: the first rowid past the pages); None when
    they are not read so."""
    buf, at = _piece(fd, pages, size)
    if buf is None:
        return None
    cells = int((buf[at + 3].astype(np.int64) << 8 | buf[at + 4]).sum())
    raw = np.empty(len(buf), dtype=np.uint8)
    lens, times, rowids = (np.empty(cells, dtype=np.int64) for _ in range(3))
    status, k, nbytes, lo, hi = _C.leaf_rows(buf, at, size, usable, want, LEAST, raw, lens, times, rowids)
    if status < 0 or hi == LEAST:
        return None
    return lo, Rows(raw[:nbytes], lens[:k], times[:k], hi + 1)


def _imu_rows(fd: int, pages: np.ndarray, size: int, usable: int, want: np.ndarray) -> Optional[tuple[int, Rows]]:
    """``_rows``, each message decoded as sensor_msgs/Imu instead of copied (``Rows.imu``)."""
    buf, at = _piece(fd, pages, size)
    if buf is None:
        return None
    cells = int((buf[at + 3].astype(np.int64) << 8 | buf[at + 4]).sum())
    lens, times, rowids, stamps, keys = (np.empty(cells, dtype=np.int64) for _ in range(5))
    vals, odd = np.empty((6, cells)), np.empty(cells, dtype=np.uint8)
    args = (lens, times, rowids, vals, stamps, keys, odd)
    status, k, lo, hi = _C.leaf_imu(buf, at, size, usable, want, LEAST, *args)
    if status < 0 or hi == LEAST:
        return None
    dec = Decoded(vals[:, :k], stamps[:k], odd[:k].view(bool), keys[:k], rowids[:k])
    return lo, Rows(np.empty(0, dtype=np.uint8), lens[:k], times[:k], hi + 1, dec)


def _piece(fd: int, pages: np.ndarray, size: int) -> tuple[Optional[np.ndarray], np.ndarray]:
    """The pages (numbers) read into one buffer, and each one's offset in it:
    one read of the whole span when they lie close together (they do when a
    bag was written in one go), else one read a page. (Mapping the file
    instead costs more CPU than the copy: its page tables, unmapping.)"""
    lo, hi = int(pages.min()), int(pages.max())
    if hi - lo + 1 <= 2 * len(pages):
        want = (hi - lo + 1) * size
        raw = os.pread(fd, want, (lo - 1) * size)
        at = (pages - lo) * size
    else:
        raw = b"".join(os.pread(fd, size, (int(p) - 1) * size) for p in pages)
        want, at = len(pages) * size, np.arange(len(pages), dtype=np.int64) * size
    if len(raw) != want:
        return None, at
    return np.frombuffer(raw, dtype=np.uint8), at
