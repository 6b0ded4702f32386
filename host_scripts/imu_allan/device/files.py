"""The one way bytes are read from a file or stdin (``-``): in blocks, with a
read error turned into one line naming the file."""

from __future__ import annotations

import gzip
import sys
from pathlib import Path
from typing import BinaryIO, Iterator, Union

from ..errors import InputError

BLOCK_BYTES = 1 << 23
"""Bytes read at a time: large enough for vectorized decoding, small enough for memory."""

PathLike = Union[str, Path]
GZIP_MAGIC = b"\x1f\x8b"


def input_name(path: PathLike) -> str:
    """How messages name an input: ``<stdin>`` for ``-``."""
    return "<stdin>" if str(path) == "-" else str(path)


def open_input(path: PathLike) -> BinaryIO:
    """Open ``path`` for binary reading (``-`` is stdin); InputError if it cannot.
    A gzip file (told by its magic bytes, whatever its name) is read decompressed,
    as recordings are often shipped (``imu-allan analyze rec.tsv.gz``)."""
    if str(path) == "-":
        return sys.stdin.buffer
    try:
        f = open(path, "rb")
        if f.peek(2)[:2] != GZIP_MAGIC:
            return f
        f.close()
        return gzip.open(path, "rb")  # type: ignore[return-value]
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror or exc}") from None


def read_blocks(path: PathLike, block_bytes: int = BLOCK_BYTES) -> Iterator[bytes]:
    """The bytes of ``path`` in blocks of at most ``block_bytes`` (none for an
    empty file).  The file is opened now (a missing file fails here, before
    any output is written), read as the blocks are taken."""
    return _blocks(open_input(path), input_name(path), block_bytes)


def _blocks(f: BinaryIO, name: str, block_bytes: int) -> Iterator[bytes]:
    try:
        while True:
            try:
                block = f.read(block_bytes)
            except (OSError, EOFError) as exc:  # EOFError: a gzip file cut short
                raise InputError(f"cannot read '{name}': {getattr(exc, 'strerror', None) or exc}") from None
            if not block:
                return
            yield block
    finally:
        if f is not sys.stdin.buffer:
            inner = f.fileobj if isinstance(f, gzip.GzipFile) else None  # GzipFile leaves it open
            f.close()
            if inner is not None:
                inner.close()


def read_all(path: PathLike) -> bytes:
    """The whole of ``path`` (a device log for ``decode`` and ``check``)."""
    return b"".join(read_blocks(path))
