"""ROS 2 bags stored in sqlite3 (``.db3``), read in bulk: a topic's messages
as one blob per batch, concatenated by sqlite itself, never a Python object
per message.

rosbags reads a ``.db3`` a row at a time (and counts every topic's messages
with a join when it opens it): at 1 kHz that, not the decoding, was the time
of a bag's analysis. Here the rows of the topic come in the order rosbags
gives them (the files in the order the metadata lists them, each by
``timestamp`` then insertion), batch by batch:

- along the table, by id, while that is the time order (a writer's usual
  table; each batch checked against the timestamp index before it is
  given): from the file's leaf pages (db3pages.py, compiled; with ``imu``
  each message decoded there as sensor_msgs/Imu, not copied), else through
  sqlite, each batch a single ``group_concat`` of the raw CDR bytes (exact:
  the database's text is UTF-8, so bytes pass unchanged, and the total
  length is checked) plus the messages' lengths when they differ;
- from where that stops, over ranges of the timestamp index, each batch a
  ``group_concat`` too (a look-up from the index per row: about three times
  the CPU of the table's order through sqlite, seven times its pages').

A bag this cannot read as rosbags would (compressed, another storage, a
message definition of its own for sensor_msgs/Imu) is left to rosbags
(``files`` returns None).
"""

from __future__ import annotations

import os
import sqlite3
from contextlib import closing
from typing import Any, Callable, Generator, Iterator, NamedTuple, Optional

import numpy as np

from . import db3pages

BATCH = 16384
"""Messages a batch aims at (5 MB of sensor_msgs/Imu); a range of timestamps
holding more than 4 batches is halved, one timestamp holding more is paged."""


class Batch(NamedTuple):
    raw: Any  # the messages end to end (bytes; empty when ``imu``)
    lens: np.ndarray  # (k,) their lengths
    times: Optional[np.ndarray]  # (k,) the times the bag recorded them (ns), when asked
    imu: Optional[db3pages.Decoded] = None  # the messages decoded from the pages instead
    fetch: Optional[Callable[[int], bytes]] = None  # with ``imu``: message i's bytes, from sqlite


def _first(b: Batch, left: int) -> Batch:
    """The first ``left`` messages of ``b``."""
    if b.imu is not None:
        return b._replace(lens=b.lens[:left], times=None if b.times is None else b.times[:left], imu=_cut(b.imu, left))
    return Batch(b.raw[: int(b.lens[:left].sum())], b.lens[:left], None if b.times is None else b.times[:left])


def _cut(d: db3pages.Decoded, left: int) -> db3pages.Decoded:
    return db3pages.Decoded(d.vals[:, :left], d.stamps[:left], d.odd[:left], d.keys[:left], d.ids[:left])


def files(path: str) -> Optional[list[str]]:
    """The .db3 files of the bag at ``path`` (a bag folder or a .db3), in
    rosbags' order, or None when it is not an uncompressed sqlite3 bag."""
    if not os.path.isdir(path):
        return [path] if path.endswith(".db3") else None
    try:
        from ruamel.yaml import YAML  # rosbags' own YAML reader

        with open(os.path.join(path, "metadata.yaml")) as f:
            meta = YAML(typ="safe").load(f)["rosbag2_bagfile_information"]
        if meta.get("storage_identifier") != "sqlite3" or (meta.get("compression_mode") or "none").lower() != "none":
            return None
        out = [os.path.join(path, os.path.basename(p)) for p in meta["relative_file_paths"]]
    except Exception:  # anything unexpected: rosbags reads it (and says what is wrong)
        return None
    return out if out and all(os.path.isfile(p) for p in out) else None


def _connect(path: str) -> sqlite3.Connection:
    return sqlite3.connect(f"file:{path}?immutable=1", uri=True)


def topics(paths: list[str]) -> list[tuple[str, str, str]]:
    """(name, type, type_description_hash or '') of every topic of the files."""
    seen: dict[tuple[str, str], str] = {}
    for p in paths:
        with closing(_connect(p)) as con:
            cols = {r[1] for r in con.execute("PRAGMA table_info(topics)")}
            digest = "type_description_hash" if "type_description_hash" in cols else "''"
            for name, typ, h in con.execute(f"SELECT name, type, {digest} FROM topics"):
                if h or (name, typ) not in seen:
                    seen[(name, typ)] = h
    return sorted((n, t, h) for (n, t), h in seen.items())


def _ids(con: sqlite3.Connection, topic: str, msgtype: str) -> list[int]:
    q = "SELECT id FROM topics WHERE name = ? AND type = ? AND serialization_format = 'cdr'"
    return [r[0] for r in con.execute(q, (topic, msgtype))]


def count(paths: list[str], topic: str, msgtype: str) -> int:
    """The topic's messages, for the progress line: when the topic is the file's
    only one, the span of the ids its writer gave (the count, unless rows were
    deleted; counting reads the whole index: a second at 8 h of 1 kHz)."""
    n = 0
    for p in paths:
        with closing(_connect(p)) as con:
            ids = _ids(con, topic, msgtype)
            if not ids:
                continue
            if con.execute("SELECT count(*) FROM topics").fetchone()[0] == len(ids):
                lo, hi = _span(con, "id")  # the ids a writer gave (counting the rows reads the whole index)
                n += 0 if lo is None else hi - lo + 1
            else:
                n += con.execute(f"SELECT count(*) FROM messages WHERE topic_id IN ({_marks(ids)})", ids).fetchone()[0]
    return n


def _marks(ids: list[int]) -> str:
    return ",".join("?" * len(ids))


def batches(
    paths: list[str], topic: str, msgtype: str, times: bool, limit: Optional[int] = None, imu: bool = False
) -> Iterator[Batch]:
    """The topic's messages, batch by batch, in rosbags' order; ``times``:
    with the bag's times; ``limit``: the first ``limit`` messages only;
    ``imu``: the batches read from the file's pages come decoded as CDR
    sensor_msgs/Imu (``Batch.imu``, ``Batch.fetch``) instead of as bytes."""
    left = limit
    for p in paths:
        with closing(_connect(p)) as con:
            ids = _ids(con, topic, msgtype)
            if not ids:
                continue
            exact = con.execute("PRAGMA encoding").fetchone()[0] == "UTF-8"
            pages = p if limit is None or limit > 4 * BATCH else ""  # a few: the walk to the leaves is not worth it
            for b in _file_batches(con, pages, ids, times, exact, imu):
                if left is not None:
                    b = _first(b, left)
                    left -= len(b.lens)
                if len(b.lens):
                    yield b
                if left is not None and left <= 0:
                    return


def _file_batches(
    con: sqlite3.Connection, path: str, ids: list[int], times: bool, exact: bool, imu: bool = False
) -> Iterator[Batch]:
    index = _index(con)
    if index is None:  # no timestamp index (an old bag): one ordered pass, a row at a time
        yield from _cursor(con, ids, times)
        return
    rest = ""
    stop = yield from _in_rowid_order(con, path, ids, times, exact, imu)
    if stop is None:
        return
    last, after = stop  # the rows not given: (timestamp, id) after (last, after - 1)
    if last is not None:
        yield from _ranges(con, ids, times, exact, index, f"timestamp = {last} AND id >= {after}")
        rest = f"timestamp > {last}"
    yield from _ranges(con, ids, times, exact, index, rest)


def _ranges(
    con: sqlite3.Connection, ids: list[int], times: bool, exact: bool, index: str, extra: str = ""
) -> Iterator[Batch]:
    """The topic's rows (``extra``: those it says) in (timestamp, id) order,
    over ranges of the timestamp index."""
    cond = f" AND {extra}" if extra else ""
    lo, hi = _span(con, "timestamp", cond)
    total = con.execute(f"SELECT count(*) FROM messages WHERE 1{cond}").fetchone()[0]
    if not total:
        return
    step = max(1, (hi - lo + 1) * BATCH // total)
    stack = [(a, min(a + step, hi + 1)) for a in range(lo, hi + 1, step)][::-1]
    span = f"timestamp >= ? AND timestamp < ?{cond}"
    where = f"{span} AND topic_id IN ({_marks(ids)})"
    direct = exact and not extra and _scans_in_order(con, index, where, len(ids))
    while stack:
        a, b = stack.pop()
        n = con.execute(f"SELECT count(*) FROM messages WHERE {span}", (a, b)).fetchone()[0]
        if n > 4 * BATCH and b - a > 1:  # a burst: halve the range
            m = (a + b) // 2
            stack += [(m, b), (a, m)]
            continue
        for off in range(0, n, 4 * BATCH) if n else ():
            paged = n > 4 * BATCH
            got = _fetch(con, where, (a, b, *ids), off if paged else None, times, exact, direct and not paged)
            if got is not None and len(got.lens):
                yield got


def _in_rowid_order(
    con: sqlite3.Connection, path: str, ids: list[int], times: bool, exact: bool, imu: bool = False
) -> Generator[Batch, None, Optional[tuple[Optional[int], int]]]:
    """The topic's rows straight along the table, by id (no look-up from the
    index per row: a third of the cost; from the file's pages, db3pages.py:
    a third again), batch by batch, while that is the order of (timestamp,
    id). Each batch is checked before it is given: its times non-decreasing
    from the last one given, and no row of the topic left behind (the index
    counts the topic's rows before the batch's last time: exactly those
    given). Returns None when every row was given, else (the last time
    given, or None, and the first id not given): the rest is read over the
    index."""
    alone = con.execute("SELECT count(*) FROM topics").fetchone()[0] == len(ids)
    topic, args = ("", []) if alone else (f" AND topic_id IN ({_marks(ids)})", ids)
    first, end = _span(con, "id")
    if first is None:
        return None
    before = f"SELECT count(*) FROM messages WHERE timestamp >= ? AND timestamp < ?{topic}"
    last: Optional[int] = None  # the last time given
    below = 0  # the topic's rows before ``last`` in the whole file, by the index
    given = same = 0  # rows given; of them, those at ``last``
    a = first  # the first id not given
    rows = _along(con, path, ids, first, end, exact, topic, args, imu)
    fetch = _fetcher(con)
    while True:
        try:
            raw, lens, t, after, dec = next(rows)
        except StopIteration as stop:
            return None if stop.value else (last, a)
        if (last is not None and t[0] < last) or np.any(np.diff(t) < 0):
            break
        top = int(t[-1])
        low = -(2**63) if last is None else last
        below += con.execute(before, (low, top, *args)).fetchone()[0]
        at_top = int(np.count_nonzero(t == top)) + (same if top == last else 0)
        if below != given + len(t) - at_top:  # a row of the topic before ``top`` lies further on
            break
        given, same, last, a = given + len(t), at_top, top, after
        yield Batch(raw, lens, t if times else None, dec, None if dec is None else fetch(dec.ids))
    rows.close()
    return last, a


def _fetcher(con: sqlite3.Connection) -> Callable[[np.ndarray], Callable[[int], bytes]]:
    """For a batch of rowids: message i's bytes, read by sqlite (those the decoding checks or cannot read)."""
    q = "SELECT data FROM messages WHERE id = ?"
    return lambda rowids: lambda i: bytes(con.execute(q, (int(rowids[i]),)).fetchone()[0])


def _along(
    con: sqlite3.Connection,
    path: str,
    ids: list[int],
    first: int,
    end: int,
    exact: bool,
    topic: str,
    args: list,
    imu: bool = False,
) -> Generator[db3pages.Rows, None, bool]:
    """(raw, lengths, times, the first id past them, decoded) of the topic's
    rows in id order: from the file's pages (db3pages.py; decoded when
    ``imu``), then, from where they stopped, from sqlite (``group_concat``
    when ``exact``). Returns whether every row was given (else it stopped
    before a batch it could not read whole)."""
    stop: Optional[int] = first
    if path:  # none: through sqlite only
        stop = yield from db3pages.along(path, con, ids, first, imu, BATCH)
    if stop is None:
        return True
    if not exact:
        return False
    src = f"messages WHERE id >= ? AND id < ?{topic}"
    cols = "CAST(group_concat(data, x'') AS BLOB), count(*), min(length(data)), max(length(data))"
    for a in range(stop, end + 1, BATCH):
        got = con.execute(f"SELECT {cols}, group_concat(timestamp) FROM {src}", (a, a + BATCH, *args)).fetchone()
        raw, k, short, long_, text = got
        if not k:
            continue
        t = np.fromstring(text, dtype=np.int64, sep=",")
        if short == long_:
            lens = np.full(k, short, dtype=np.int64)
        else:
            q = f"SELECT group_concat(length(data)) FROM {src}"
            lens = np.fromstring(con.execute(q, (a, a + BATCH, *args)).fetchone()[0], dtype=np.int64, sep=",")
        if raw is None or len(lens) != k or len(t) != k or len(raw) != lens.sum():
            return False
        yield db3pages.Rows(raw, lens, t, a + BATCH)
    return True


def _span(con: sqlite3.Connection, col: str, cond: str = "") -> tuple[Optional[int], Optional[int]]:
    """The least and the greatest ``col`` (rowid or indexed): two queries, as
    sqlite looks up min() or max() alone in the index but scans the table for both."""
    lo = con.execute(f"SELECT min({col}) FROM messages WHERE 1{cond}").fetchone()[0]
    return lo, con.execute(f"SELECT max({col}) FROM messages WHERE 1{cond}").fetchone()[0]


def _index(con: sqlite3.Connection) -> Optional[str]:
    """The name of an ascending index of messages led by timestamp, if any."""
    for idx in con.execute("PRAGMA index_list(messages)").fetchall():
        first = con.execute(f"PRAGMA index_xinfo('{idx[1]}')").fetchone()
        if first is not None and first[2] == "timestamp" and not first[3]:
            return str(idx[1])
    return None


def _scans_in_order(con: sqlite3.Connection, index: str, where: str, n_ids: int) -> bool:
    """sqlite's plan for an aggregate over ``where``: one range search of the
    timestamp index, so rows come in (timestamp, insertion) order, the order
    of ORDER BY timestamp, id, without the cost of a subquery that says so."""
    q = f"EXPLAIN QUERY PLAN SELECT group_concat(data, x'') FROM messages WHERE {where}"
    plan = [r[3] for r in con.execute(q, (0, 1, *[0] * n_ids))]
    return len(plan) == 1 and plan[0] == f"SEARCH messages USING INDEX {index} (timestamp>? AND timestamp<?)"


def _cursor(con: sqlite3.Connection, ids: list[int], times: bool) -> Iterator[Batch]:
    q = f"SELECT data, timestamp FROM messages WHERE topic_id IN ({_marks(ids)}) ORDER BY timestamp, id"
    cur = con.execute(q, ids)
    while rows := cur.fetchmany(BATCH):
        yield _joined(rows, times)


def _joined(rows: list[tuple[bytes, int]], times: bool) -> Batch:
    return Batch(
        b"".join(r[0] for r in rows),
        np.fromiter((len(r[0]) for r in rows), dtype=np.int64, count=len(rows)),
        np.fromiter((r[1] for r in rows), dtype=np.int64, count=len(rows)) if times else None,
    )


def _fetch(
    con: sqlite3.Connection, where: str, args: tuple, off: Optional[int], times: bool, exact: bool, direct: bool
) -> Optional[Batch]:
    """One batch: the topic's rows ``where`` (the ``off``-th page of them when
    one timestamp holds too many), concatenated by sqlite when ``exact``,
    straight from the table when ``direct`` (its plan keeps the order)."""
    page = f" LIMIT {4 * BATCH} OFFSET {off}" if off is not None else ""
    rows = f"SELECT data, timestamp FROM messages WHERE {where} ORDER BY timestamp, id{page}"
    if exact:
        src = f"messages WHERE {where}" if direct else f"({rows})"
        cols = "CAST(group_concat(data, x'') AS BLOB), count(*), min(length(data)), max(length(data))"
        q = f"SELECT {cols}{', group_concat(timestamp)' if times else ''} FROM {src}"
        raw, k, short, long_, *t = con.execute(q, args).fetchone()
        if not k:
            return None
        if short == long_:
            lens = np.full(k, short, dtype=np.int64)
        else:
            text = con.execute(f"SELECT group_concat(length(data)) FROM {src}", args).fetchone()[0]
            lens = np.fromstring(text, dtype=np.int64, sep=",")
        when = np.fromstring(t[0], dtype=np.int64, sep=",") if times else None
        if raw is not None and len(lens) == k and len(raw) == lens.sum() and (when is None or len(when) == k):
            return Batch(raw, lens, when)
    return _joined(con.execute(rows, args).fetchall(), times)  # a row at a time: what group_concat could not give
