"""ROS 1 bags (format 2.0) read a chunk at a time: the message data records
of a topic's connections found by numpy, a run of records of one layout at a
time, never a Python object per message.

rosbags reads a ROS 1 bag's index into a Python object per message when it
opens it, then each message by seeking to it. Here the bag's own index
records (connections, chunk infos) are read, each chunk decompressed with
rosbags' decompressors and its records walked in runs: a record whose header
has the layout of the run's first one (every byte equal but the connection
and the time) is a message data record of the same length, checked before
anything is taken from it. The order is rosbags' (by time, then chunk, then
place in the chunk): each chunk sorted by time (stably), chunks in file
order, when no chunk starts before the previous one ends (else ``open_bag``
returns None and rosbags reads the bag).
"""

from __future__ import annotations

from typing import BinaryIO, Iterator, NamedTuple, Optional

import numpy as np

from .imumsg import in_time_order

MAGIC = b"#ROSBAG V2.0\n"
RUN0 = 64
"""Records first checked as one run; doubled while the run holds."""


class Conn(NamedTuple):
    id: int
    topic: str
    msgtype: str  # as rosbags names it: pkg/msg/Name
    md5sum: str


class Bag(NamedTuple):
    conns: list[Conn]
    chunks: list[tuple[int, int, int]]  # (position, start time, end time), in file order
    counts: dict[int, int]  # messages of each connection


def _fields(buf: bytes) -> dict[str, bytes]:
    out, p = {}, 0
    while p + 4 <= len(buf):
        n = int.from_bytes(buf[p : p + 4], "little")
        name, _, value = buf[p + 4 : p + 4 + n].partition(b"=")
        out[name.decode("latin-1")] = value
        p += 4 + n
    return out


def _record(f: BinaryIO) -> tuple[dict[str, bytes], bytes]:
    n = int.from_bytes(f.read(4), "little")
    head = _fields(f.read(n))
    size = int.from_bytes(f.read(4), "little")
    return head, f.read(size)


def _time(v: bytes) -> int:
    return int.from_bytes(v[:4], "little") * 1_000_000_000 + int.from_bytes(v[4:8], "little")


def _msgtype(name: str) -> str:
    pkg, _, typ = name.partition("/")
    return f"{pkg}/msg/{typ}" if "/msg/" not in name else name


def open_bag(f: BinaryIO) -> Optional[Bag]:
    """The connections and chunks of an indexed, unencrypted bag with chunks in time order."""
    if f.read(len(MAGIC)) != MAGIC:
        return None
    head, _ = _record(f)
    if head.get("op") != b"\x03" or head.get("encryptor"):
        return None
    index = int.from_bytes(head["index_pos"], "little")
    n_conn = int.from_bytes(head["conn_count"], "little")
    n_chunk = int.from_bytes(head["chunk_count"], "little")
    if not index:
        return None
    f.seek(index)
    conns = []
    for _ in range(n_conn):
        h, data = _record(f)
        d = _fields(data)
        conns.append(
            Conn(
                int.from_bytes(h["conn"], "little"),
                h["topic"].decode(),
                _msgtype(d["type"].decode()),
                d["md5sum"].decode(),
            )
        )
    chunks, counts = [], dict.fromkeys((c.id for c in conns), 0)
    for _ in range(n_chunk):
        h, data = _record(f)
        if h.get("op") != b"\x06":
            return None
        chunks.append((int.from_bytes(h["chunk_pos"], "little"), _time(h["start_time"]), _time(h["end_time"])))
        pairs = np.frombuffer(data, dtype="<u4").reshape(-1, 2)
        for c, k in pairs.tolist():
            counts[c] = counts.get(c, 0) + k
    in_order = all(b[1] >= a[2] and b[0] > a[0] for a, b in zip(chunks, chunks[1:]))
    return Bag(conns, chunks, counts) if in_order else None


def chunk_messages(f: BinaryIO, bag: Bag, ids: set[int]) -> Iterator[tuple[bytes, np.ndarray, np.ndarray]]:
    """(raw messages end to end, lengths, times) of connections ``ids``, chunk by chunk."""
    from rosbags.rosbag1.reader import decompressors

    for pos, _, _ in bag.chunks:
        f.seek(pos)
        head, data = _record(f)
        if head.get("op") != b"\x05":
            raise ValueError(f"no chunk at {pos}")
        raw = decompressors[head["compression"].decode()](data)
        got = _records(raw, ids)
        if got is not None:
            yield got


def _layout(data: bytes, p: int) -> tuple[int, int, int, int, int]:
    """(header length, data length, op, connection offset, time offset) of the record at ``p``."""
    hlen = int.from_bytes(data[p : p + 4], "little")
    q, end = p + 4, p + 4 + hlen
    op, conn_at, time_at = -1, -1, -1
    while q + 4 <= end:
        n = int.from_bytes(data[q : q + 4], "little")
        name = data[q + 4 : q + 4 + n].partition(b"=")[0]
        value_at = q + 4 + len(name) + 1
        if name == b"op":
            op = data[value_at]
        elif name == b"conn":
            conn_at = value_at - p
        elif name == b"time":
            time_at = value_at - p
        q += 4 + n
    dlen = int.from_bytes(data[end : end + 4], "little")
    return hlen, dlen, op, conn_at, time_at


def _records(data: bytes, ids: set[int]) -> Optional[tuple[bytes, np.ndarray, np.ndarray]]:
    """The message data records of ``ids`` in a chunk, sorted by time (stably)."""
    u8 = np.frombuffer(data, dtype=np.uint8)
    n, p = len(data), 0
    parts, lens, times = [], [], []
    want = np.array(sorted(ids), dtype=np.uint32)
    while p < n:
        hlen, dlen, op, conn_at, time_at = _layout(data, p)
        stride = 8 + hlen + dlen
        if p + stride > n:
            raise ValueError("a record runs past its chunk")
        if op != 2 or conn_at < 0 or time_at < 0:
            p += stride
            continue
        same = np.ones(8 + hlen, dtype=bool)  # the bytes every record of the run repeats
        same[conn_at : conn_at + 4] = same[time_at : time_at + 8] = False
        w = RUN0
        while p < n:
            m = min(w, (n - p) // stride)
            if m == 0:
                break
            rows = u8[p : p + m * stride].reshape(m, stride)
            head = rows[:, : 4 + hlen + 4]
            ok = np.all(head[:, same] == u8[p : p + 8 + hlen][same], axis=1)
            run = m if ok.all() else int(np.argmin(ok))
            if run == 0:
                break
            conn = rows[:run, conn_at : conn_at + 4].copy().view("<u4")[:, 0]
            mine = np.isin(conn, want)
            if mine.any():
                parts.append(rows[:run][mine, 8 + hlen :].reshape(-1))
                lens.append(np.full(int(mine.sum()), dlen, dtype=np.int64))
                t = rows[:run][mine, time_at : time_at + 8].copy().view("<u4").astype(np.int64)
                times.append(t[:, 0] * 1_000_000_000 + t[:, 1])
            p += run * stride
            if run < m:
                break
            w *= 2
    if not parts:
        return None
    return in_time_order(times, lens, parts)  # rosbags sorts a chunk by log time
