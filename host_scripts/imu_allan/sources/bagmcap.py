"""ROS 2 bags stored in MCAP, read a chunk at a time: the message records of
a channel found by numpy, a run of records of one length at a time, never a
Python object per message.

rosbags reads an MCAP record by record in Python. Here its own reader gives
the chunk index (where each chunk lies, its time span, its channels) and its
own ``decompress`` (lz4, zstd, the CRC); the records inside a chunk are
walked in runs of equal length, checked as records (opcode 0x05, length)
before anything is taken from them. The order is rosbags': each chunk's
messages sorted by log time (stably), chunks one after another, which is the
order of its merge when no chunk starts before the previous one ends (else
None: rosbags reads the bag).
"""

from __future__ import annotations

from typing import Any, Iterator, Optional

import numpy as np

from .imumsg import in_time_order

RUN0 = 64
"""Records first checked as one run; doubled while the run holds."""


def chunks_in_order(storage: Any) -> bool:
    """The chunk index is in file order and no chunk's span starts before the previous one's ends."""
    cs = list(getattr(storage, "chunks", None) or [])
    if not cs:
        return False
    offsets = [c.chunk_start_offset for c in cs]
    spans = all(b.message_start_time >= a.message_end_time for a, b in zip(cs, cs[1:]))
    return offsets == sorted(offsets) and spans


def chunk_messages(storage: Any, ids: set[int]) -> Iterator[tuple[bytes, np.ndarray, np.ndarray]]:
    """(raw messages end to end, lengths, log times) of channels ``ids``, chunk by chunk."""
    from rosbags.rosbag2.storage_mcap import decompress

    bio = storage.bio
    for c in storage.chunks:
        if not any(c.channel_count.get(i, 0) for i in ids):
            continue
        bio.seek(c.chunk_start_offset + 9 + 24)
        crc = int.from_bytes(bio.read(4), "little")
        bio.seek(c.chunk_start_offset + 9 + 40 + len(c.compression))
        data = decompress(bio.read(c.compressed_size), c.compression, c.uncompressed_size, crc)
        got = _records(data, ids)
        if got is not None:
            yield got


_REC = {"names": ["op", "len", "ch", "log"], "formats": ["u1", "<u8", "<u2", "<u8"], "offsets": [0, 1, 9, 15]}


def _records(data: bytes, ids: set[int]) -> Optional[tuple[bytes, np.ndarray, np.ndarray]]:
    """The message records of ``ids`` in a chunk's records, sorted by log time (stably)."""
    u8 = np.frombuffer(data, dtype=np.uint8)
    n, p = len(data), 0
    parts: list[np.ndarray] = []
    lens: list[np.ndarray] = []
    times: list[np.ndarray] = []
    want = np.array(sorted(ids), dtype=np.uint16)
    while p < n:
        op, size = data[p], int.from_bytes(data[p + 1 : p + 9], "little")
        if p + 9 + size > n:
            raise ValueError("a record runs past its chunk")
        if op != 0x05 or size < 22:
            p += 9 + size
            continue
        stride, w = 9 + size, RUN0
        while p < n and data[p] == 0x05 and int.from_bytes(data[p + 1 : p + 9], "little") == size:
            m = min(w, (n - p) // stride)
            if m == 0:
                raise ValueError("a record runs past its chunk")
            rec = np.frombuffer(data, dtype=np.dtype({**_REC, "itemsize": stride}), count=m, offset=p)
            ok = (rec["op"] == 0x05) & (rec["len"] == size)
            run = m if ok.all() else int(np.argmin(ok))
            mine = np.isin(rec["ch"][:run], want)
            if mine.any():
                parts.append(u8[p : p + run * stride].reshape(run, stride)[mine, 31:].reshape(-1))
                lens.append(np.full(int(mine.sum()), size - 22, dtype=np.int64))
                times.append(rec["log"][:run][mine].astype(np.int64))
            p += run * stride
            if run < m:
                break
            w *= 2
    if not parts:
        return None
    return in_time_order(times, lens, parts)  # rosbags sorts a chunk by log time
