"""A device capture decoded once: the samples of its raw rows and binary
frames, its complete reports, replies and boots, and the counts of what was
thrown away (stream.py's rules).

``decode_chunks`` is the streaming form (``imu-allan rows`` writes as it
reads, ``monitor`` feeds a port); ``read_capture`` and ``decode_stream`` keep
everything (``analyze``: the samples stay in memory, 14 bytes per sample set,
so the file is read once whatever the statistics need).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Iterator, Optional

import numpy as np

from .files import PathLike, read_blocks
from .records import Boot, DeviceReport
from .stream import Chunk, StreamDecoder


@dataclass
class Capture:
    samples: np.ndarray
    """(7, n) uint16 codes (ax ay az gx gy gz temp) of intact rows and frames, in order."""
    from_frame: np.ndarray
    """(n,) True where the sample came from a binary frame."""
    reports: list[DeviceReport]
    replies: list[str]
    boots: list[Boot]
    counts: dict[str, int]
    """``STREAM_KEYS`` and ``ERROR_KEYS`` of stream.py."""


def decode_chunks(blocks: Iterable[bytes], dec: StreamDecoder) -> Iterator[Chunk]:
    """Feed ``blocks`` to ``dec``; yield each step's chunk, the final one included."""
    for block in blocks:
        yield dec.feed(block)
    yield dec.finish()


def collect(chunks: Iterable[Chunk], dec: StreamDecoder) -> Capture:
    parts = list(chunks)
    return Capture(
        samples=np.concatenate([ch.samples for ch in parts], axis=1),
        from_frame=np.concatenate([ch.from_frame for ch in parts]),
        reports=[r for ch in parts for r in ch.reports],
        replies=[r for ch in parts for r in ch.replies],
        boots=[bt for ch in parts for bt in ch.boots],
        counts=dict(dec.counts),
    )


def decode_stream(data: bytes, line_start: bool = False) -> Capture:
    """Decode a whole capture held in memory (see ``StreamDecoder``)."""
    dec = StreamDecoder(line_start)
    return collect(decode_chunks([data], dec), dec)


def read_capture(path: PathLike, first: Optional[bytes] = None, rest: Optional[Iterable[bytes]] = None) -> Capture:
    """Decode the file ``path`` in one pass.  A caller that already read the
    first block (to look at it) passes it as ``first`` and the iterator of the
    remaining blocks as ``rest``, so that nothing is read twice."""
    dec = StreamDecoder(line_start=True)
    blocks: Iterable[bytes] = read_blocks(path) if first is None else _chain(first, rest or ())
    return collect(decode_chunks(blocks, dec), dec)


def _chain(first: bytes, rest: Iterable[bytes]) -> Iterator[bytes]:
    yield first
    yield from rest
