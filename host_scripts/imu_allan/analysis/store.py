"""The samples of one analysis, read once from the source and kept channel by
channel: in memory when they fit ``--memory``, else in temporary files (the
spill), one per channel, in the source's own number type (ADC codes stay 2
bytes a sample).

Every statistic reads them through the same two doors, whatever the store:
``blocks(c)`` (the channel in pieces of ``BLOCK`` samples, the same pieces
from memory and from a file) and ``octave(c)`` (the compiled octave kernels,
on the array in memory or on the file read with pread, the same C code). So
an analysis in memory and one streamed through files give the same numbers,
and a streamed one holds a few blocks and the kernels' tiles, whatever the
length (the files live in the page cache or on disk, not in the process).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import Any, Iterator, Optional

import numpy as np

from ..errors import InputError
from ..progress import Progress, Quiet
from ..stats import allan, kernels

BLOCK = 1 << 18
"""Samples per piece handed to the statistics (2 MB of float64)."""


class Store:
    """(channels, n) samples, one channel at a time."""

    n: int
    dtypes: list[np.dtype]
    held = False
    """True when the samples are in memory (MemoryStore)."""

    @property
    def channels(self) -> int:
        return len(self.dtypes)

    def read(self, c: int, start: int, count: int) -> np.ndarray:
        raise NotImplementedError

    def blocks(self, c: int, size: int = BLOCK) -> Iterator[np.ndarray]:
        """Channel ``c`` in pieces of ``size`` samples (the last one shorter)."""
        for a in range(0, self.n, size):
            yield self.read(c, a, min(size, self.n - a))

    def offset(self, c: int) -> float:
        """The offset the kernels remove (kernels.offset of the first HEAD samples)."""
        return float(kernels.offset(self.read(c, 0, min(kernels.HEAD, self.n))))

    windows: Optional[tuple[np.ndarray, int]] = None
    """(starts, size): windows whose overlapping sums ``octave`` takes from its
    own pass (dynamic.from_store's warm-up windows), set before the first ``octave``."""

    def octave(self, c: int) -> allan.OctaveResult:
        """Overlapping and non-overlapping AVAR of channel ``c`` at every octave
        (every offset: stride 1), by the compiled kernels when built; computed once
        (with the sums of ``windows``, when set, from the same pass)."""
        memo = self.__dict__.setdefault("_octaves", {})
        if c not in memo:
            plan = None
            if self.windows is not None:
                starts, size = self.windows
                plan = (starts, size, np.full((kernels.levels(self.n), starts.size), np.nan))
            memo[c] = self._octave(c, plan)
            if plan is not None and np.all(np.isfinite(plan[2])):  # not filled: no compiled kernels
                self.__dict__.setdefault("_wsums", {})[c] = (starts, size, plan[2])
        return memo[c]

    def window_sums(self, c: int, starts: np.ndarray, size: int) -> Optional[np.ndarray]:
        """The overlapping sums (levels, windows) of windows (starts, size) of channel
        ``c`` that ``octave`` took from its pass, or None (not planned)."""
        got = self.__dict__.get("_wsums", {}).get(c)
        if got is None or got[1] != size or not np.array_equal(got[0], starts):
            return None
        return got[2]

    def _octave(self, c: int, windows: Optional[kernels.Windows] = None) -> allan.OctaveResult:
        raise NotImplementedError

    def in_memory(self) -> Optional[np.ndarray]:
        """The (channels, n) array when the samples are held, else None."""
        return None

    def close(self) -> None:
        base = getattr(self, "base", None)
        if base is not None:
            base.close()


class MemoryStore(Store):
    held = True

    def __init__(self, data: Any) -> None:
        self.data = [np.ascontiguousarray(row) for row in data]
        self.n = int(self.data[0].size) if self.data else 0
        self.dtypes = [row.dtype for row in self.data]
        self.base: Optional[Store] = None

    def read(self, c: int, start: int, count: int) -> np.ndarray:
        return self.data[c][start : start + count]

    def _octave(self, c: int, windows: Optional[kernels.Windows] = None) -> allan.OctaveResult:
        return allan.octave_mapped(self.data[c], windows=windows)

    def in_memory(self) -> Optional[np.ndarray]:
        if len({d for d in self.dtypes}) == 1:
            return np.stack(self.data)
        return np.stack([d.astype(np.float64) for d in self.data])


class SpillStore(Store):
    """The channels in temporary files (removed by ``close``)."""

    def __init__(self, dtypes: list[np.dtype], where: Optional[str] = None) -> None:
        self.dir = tempfile.mkdtemp(prefix="imu-allan-", dir=where)
        self.dtypes = [np.dtype(d) for d in dtypes]
        self.files = [open(os.path.join(self.dir, f"ch{c}.bin"), "w+b") for c in range(len(dtypes))]
        self.n = 0
        self.span = [0] * len(dtypes)  # integer codes: the largest |value| (whether sums are exact)
        self.own: Optional[set[int]] = None  # the channels whose files are this store's (None: all)
        self.base: Optional[Store] = None  # closed with this one

    def append(self, block: np.ndarray) -> None:
        for c, f in enumerate(self.files):
            row, dt = block[c], self.dtypes[c]
            if not np.can_cast(row.dtype, dt, "safe"):
                raise ValueError(f"a block of {row.dtype} after blocks of {dt}")
            if dt.kind in "iu" and dt.itemsize > 2 and row.size:  # 1 or 2 bytes: the type bounds them
                self.span[c] = max(self.span[c], abs(int(row.max())), abs(int(row.min())))
            f.write(memoryview(np.ascontiguousarray(row, dtype=dt)))
        self.n += block.shape[1]

    def flush(self) -> None:
        for f in self.files:
            f.flush()

    def read(self, c: int, start: int, count: int) -> np.ndarray:
        dt = self.dtypes[c]
        raw = os.pread(self.files[c].fileno(), count * dt.itemsize, start * dt.itemsize)
        if len(raw) != count * dt.itemsize:
            raise InputError(f"the samples' temporary file {self.files[c].name} is short (disk full?)")
        return np.frombuffer(raw, dtype=dt)

    def _octave(self, c: int, windows: Optional[kernels.Windows] = None) -> allan.OctaveResult:
        dt = self.dtypes[c]
        r = kernels.octave_file_sums(self.files[c].fileno(), dt, self.n, self.offset(c), self.span[c], windows)
        if r is None:  # no compiled kernels: the numpy ones on the channel in memory
            return allan.octave_mapped(self.read(c, 0, self.n))
        return allan.octave_from_sums(self.n, *r)

    def derive(self, changes: dict[int, Iterator[np.ndarray]]) -> "SpillStore":
        """A store whose channels in ``changes`` are new float64 files written from
        their pieces, the others this store's files (shared: this one closes them)."""
        new = SpillStore([], where=os.path.dirname(self.dir))
        new.n, new.span = self.n, list(self.span)
        new.files, new.dtypes, new.own = list(self.files), list(self.dtypes), set()
        for c, pieces in changes.items():
            f = open(os.path.join(new.dir, f"ch{c}.f64"), "w+b")
            for p in pieces:
                f.write(np.ascontiguousarray(p, dtype=np.float64).tobytes())
            f.flush()
            new.files[c], new.dtypes[c] = f, np.dtype(np.float64)
            new.own.add(c)
        return new

    def close(self) -> None:
        for c, f in enumerate(self.files):
            if self.own is None or c in self.own:
                f.close()
        shutil.rmtree(self.dir, ignore_errors=True)
        if self.base is not None:
            self.base.close()


def collect(
    blocks: Iterator[np.ndarray], sel: list[int], budget: int, name: str, hint: Optional[int], quiet: bool = False
) -> Store:
    """Read ``blocks`` (channels, rows) once, keeping channels ``sel``: in memory
    while they fit ``budget`` bytes of float64, else spilled to files. A
    progress line counts the rows read, their rate and the time left."""
    kept: list[np.ndarray] = []
    kept_bytes = 0
    spill: Optional[SpillStore] = None
    n = 0
    with (Quiet if quiet else Progress)(f"reading {name}", hint, unit=" rows") as bar:
        for block in ahead(blocks):
            b = block[sel] if len(sel) != block.shape[0] else block
            if not b.shape[1]:
                continue
            n += b.shape[1]
            if spill is None:
                kept.append(b)
                kept_bytes += b.shape[1] * len(sel) * 8
                if kept_bytes > budget:
                    spill = SpillStore([b.dtype] * len(sel))
                    for k in kept:
                        spill.append(k)
                    kept = []
            else:
                spill.append(b)
            bar.update(n)
    if spill is not None:
        spill.flush()
        return spill
    if not kept:
        return MemoryStore(np.zeros((len(sel), 0)))
    return MemoryStore(np.concatenate(kept, axis=1))


_AHEAD: dict[int, tuple[Any, list[int], int, Any]] = {}
"""Reads started by ``read_ahead``: id(samples) -> (samples, channels, budget, future store)."""


def read_ahead(samples: Any, wanted: Optional[list[str]], budget: int) -> None:
    """Start reading ``samples`` (``collect``, channels ``wanted`` or all) in another
    thread, for the analysis that ``take_ahead`` hands it to: the command reads
    the file while it loads the statistics' modules (scipy: a second or two)."""
    if samples is None or (wanted and any(c not in samples.channels for c in wanted)):
        return
    import atexit
    from concurrent.futures import ThreadPoolExecutor

    sel = [i for i, c in enumerate(samples.channels) if not wanted or c in wanted]
    pool = ThreadPoolExecutor(1)
    fut = pool.submit(collect, samples.open_blocks(), sel, budget, samples.name, samples.n_hint)
    pool.shutdown(wait=False)
    if not _AHEAD:
        atexit.register(_drop_ahead)
    _AHEAD[id(samples)] = (samples, sel, budget, fut)


def take_ahead(samples: Any, sel: list[int], budget: int) -> Optional[Store]:
    """The store ``read_ahead`` read of ``samples`` (its errors raised here), or None."""
    got = _AHEAD.get(id(samples))
    if got is None or got[0] is not samples or got[1] != sel or got[2] != budget:
        return None
    del _AHEAD[id(samples)]
    return got[3].result()


def _drop_ahead() -> None:
    """At exit: the stores read ahead and never taken (an error before the statistics)."""
    for _, _, _, fut in _AHEAD.values():
        if not fut.cancelled() and fut.exception() is None:
            fut.result().close()
    _AHEAD.clear()


def ahead(blocks: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    """``blocks``, the next one read and parsed in another thread while this one
    is stored (the compiled readers and the writes release the GIL)."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(1) as pool:
        nxt = pool.submit(next, blocks, None)
        while True:
            block = nxt.result()
            if block is None:
                return
            nxt = pool.submit(next, blocks, None)
            yield block


def _pieces(store: Store, c: int) -> Iterator[tuple[int, np.ndarray]]:
    """(start, samples) of channel ``c``: ``c`` bound now, read later."""
    for a in range(0, store.n, BLOCK):
        yield a, store.read(c, a, min(BLOCK, store.n - a))


def replaced(store: Store, found: Any) -> Store:
    """A store with the outliers ``found`` (outliers.OutlierScan) replaced
    (outliers.replaced_pieces); the channels without any are shared."""
    from .outliers import replaced_pieces

    changes = {}
    for c, ch in enumerate(found.channels):
        if ch.spans.size == 0:
            continue
        s, t = ch.spans[:, 0], ch.spans[:, 1]
        ends = (
            np.array([float(store.read(c, int(i), 1)[0]) for i in s - 1]),
            np.array([float(store.read(c, int(i), 1)[0]) for i in t]),
        )
        changes[c] = replaced_pieces(_pieces(store, c), ch.spans, ends)
    if isinstance(store, SpillStore):
        out: Store = store.derive(changes)
    else:
        out = MemoryStore(
            [
                np.concatenate(list(changes[c])) if c in changes else store.read(c, 0, store.n)
                for c in range(store.channels)
            ]
        )
    out.windows = store.windows
    for key in ("_octaves", "_wsums"):  # the unchanged channels'
        memo = store.__dict__.get(key, {})
        out.__dict__[key] = {c: r for c, r in memo.items() if c not in changes}
    return out
