"""The passes behind outliers.scan over one channel's first differences,
read piece by piece: from an array in memory or from the analysis' store
(store.py), so that a recording of any length is scanned in bounded memory,
with the same numbers whatever the pieces (counts, minima, maxima and order
statistics are exact; nothing is summed in floating point).

A piece is (index of its first difference, float64 differences)."""

from __future__ import annotations

import math
from typing import Callable, Iterator, Optional

import numpy as np

Pieces = Callable[[], Iterator[tuple[int, np.ndarray]]]
"""Starts a pass: the differences of one channel in order, as (first index, values)."""

COLLECT = 1 << 22
"""Values an order statistic may hold at once (32 MB): a window of the data
narrower than this is read whole and sorted; a wider one is cut into BINS."""
BINS = 4096


def of_array(d: np.ndarray) -> Pieces:
    """The differences of one array as a single piece."""
    return lambda: iter([(0, d)])


def of_store(store, c: int) -> Pieces:
    """The first differences of channel ``c`` of a store (float64, across pieces)."""

    def gen() -> Iterator[tuple[int, np.ndarray]]:
        prev: Optional[float] = None
        pos = 0
        for b in store.blocks(c):
            x = b.astype(np.float64)
            d = np.diff(x) if prev is None else np.diff(np.concatenate(([prev], x)))
            if x.size:
                prev = float(x[-1])
            if d.size:
                yield pos, d
                pos += d.size

    gen.samples = lambda: (b.astype(np.float64) for b in store.blocks(c))  # type: ignore[attr-defined]
    return gen


def _compiled(pieces: Pieces) -> Optional[Callable[[], Iterator[tuple[int, float, bool, np.ndarray]]]]:
    """The pieces as (first difference's index, previous sample, whether there is
    one, float64 samples) for the compiled passes (stats/ck_text.c: the same
    differences, one pass each, no array of them), when they come from samples
    and the kernels are built; else None."""
    from ..stats.kernels import _C

    samples = getattr(pieces, "samples", None)
    if _C is None or samples is None:
        return None

    def gen() -> Iterator[tuple[int, float, bool, np.ndarray]]:
        prev, has, pos = 0.0, False, 0
        for x in samples():
            if x.size:
                yield pos, prev, has, x
                pos += x.size - (not has)
                prev, has = float(x[-1]), True

    return gen


def _first_look_compiled(pieces: Pieces, n: int, keep: int) -> Optional[tuple[np.ndarray, float, float, float]]:
    from ..stats.kernels import _C

    blocks = _compiled(pieces)
    if blocks is None:
        return None
    step = max(n >> keep, 1)
    st = np.array([math.inf, -math.inf, math.inf, 0.0])
    sub = []
    for pos, prev, has, x in blocks():
        out = np.empty(x.size // step + 1)
        k = _C.diff_look(x, prev, has, pos, step, out, st)
        sub.append(out[:k])
    if st[3]:  # a value not finite: numpy's rules
        return None
    return (np.concatenate(sub) if sub else np.zeros(0)), float(st[0]), float(st[1]), float(st[2])


def first_look(pieces: Pieces, n: int, keep: int) -> tuple[np.ndarray, float, float, float]:
    """One pass: the subsample d[::max(n >> keep, 1)], the smallest nonzero |d|
    (inf when none), and the largest and smallest d."""
    fast = _first_look_compiled(pieces, n, keep)
    if fast is not None:
        return fast
    step = max(n >> keep, 1)
    sub, nzmin, hi, lo = [], math.inf, -math.inf, math.inf
    for pos, d in pieces():
        sub.append(d[(-pos) % step :: step].copy())  # a copy: a view would hold the whole piece
        nz = np.abs(d[d != 0])
        if nz.size:
            nzmin = min(nzmin, float(nz.min()))
        hi, lo = max(hi, float(d.max())), min(lo, float(d.min()))
    return (np.concatenate(sub) if sub else np.zeros(0)), nzmin, hi, lo


def grid_counts(pieces: Pieces, q: float, grid_max: int) -> np.ndarray:
    """Counts of rint(d / q), clipped to +-grid_max, at index k + grid_max."""
    cnt = np.zeros(2 * grid_max + 1, dtype=np.int64)
    blocks = _compiled(pieces)
    if blocks is not None:
        from ..stats.kernels import _C

        bad = sum(_C.diff_grid(x, prev, has, q, grid_max, cnt) for _, prev, has, x in blocks())
        if not bad:
            return cnt
        cnt[:] = 0
    for _, d in pieces():
        k = np.clip(np.rint(d / q), -grid_max, grid_max).astype(np.int64) + grid_max
        cnt += np.bincount(k, minlength=2 * grid_max + 1)
    return cnt


def quantiles(pieces: Pieces, n: int, qs: list[float], f: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """The quantiles ``qs`` of f(d) over n values, linear between order
    statistics (numpy's default): v[j] + (v[j+1] - v[j]) g, h = (n - 1) q."""
    ranks: list[int] = []
    plan = []
    for q in qs:
        h = (n - 1) * q
        j = int(math.floor(h))
        g = h - j
        plan.append((j, g))
        ranks += [j] + ([j + 1] if g > 0 and j + 1 < n else [])
    keys = sorted(set(ranks))
    vals = dict(zip(keys, order_stats(pieces, keys, f)))
    out = []
    for j, g in plan:
        a = vals[j]
        out.append(a + (vals[j + 1] - a) * g if g > 0 and j + 1 < n else a)
    return out


def order_stats(pieces: Pieces, ranks: list[int], f: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """The values at sorted positions ``ranks`` (0-based) of f(d), exactly:
    windows (lo, hi] of the values narrowed by histograms until the window
    holding each rank is small enough to sort."""
    win = {r: (-math.inf, math.inf, 0) for r in ranks}  # (lo, hi, values <= lo)
    edges: dict[int, np.ndarray] = {}
    out: dict[int, float] = {}
    while len(out) < len(ranks):
        todo = [r for r in ranks if r not in out]
        cnt = {r: 0 for r in todo}
        ext = {r: [math.inf, -math.inf] for r in todo}
        got: dict[int, Optional[list[np.ndarray]]] = {r: [] for r in todo if r not in edges}
        hist = {r: np.zeros(BINS, dtype=np.int64) for r in todo if r in edges}
        for _, d in pieces():
            v = f(d)
            for r in todo:
                lo, hi, _ = win[r]
                w = v[(v > lo) & (v <= hi)]
                if r in hist:
                    hist[r] += np.bincount(np.searchsorted(edges[r], w, side="left") - 1, minlength=BINS)[:BINS]
                    continue
                cnt[r] += w.size
                if w.size:
                    ext[r] = [min(ext[r][0], float(w.min())), max(ext[r][1], float(w.max()))]
                keep = got[r]
                if keep is not None:
                    got[r] = keep + [w] if sum(k.size for k in keep) + w.size <= COLLECT else None
        for r in todo:
            lo, hi, below = win[r]
            if r in hist:  # the bin holding rank r is the next window
                cum = np.cumsum(hist.pop(r))
                j = int(np.searchsorted(cum, r - below, side="right"))
                e = edges.pop(r)
                win[r] = (float(e[j]), float(e[j + 1]), below + (int(cum[j - 1]) if j else 0))
                continue
            keep = got[r]
            if keep is not None:
                out[r] = float(np.partition(np.concatenate(keep), r - below)[r - below])
            elif ext[r][0] == ext[r][1]:
                out[r] = ext[r][0]
            else:  # bins (e_j, e_j+1] over [min, max]
                e = np.linspace(ext[r][0], ext[r][1], BINS + 1)
                e[0] = np.nextafter(ext[r][0], -math.inf)
                edges[r] = e
    return [out[r] for r in ranks]


def runs_above(
    pieces: Pieces, med: float, s: float, extend: float, core: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The runs [start, stop) of |d - med| / s > extend, each with whether it
    holds a value above ``core`` and its largest value (runs joined across pieces)."""
    starts, stops, cores, peaks = [], [], [], []
    open_run: Optional[list] = None  # [start, has core, peak] of a run reaching the piece's end
    end = 0
    for pos, d in pieces():
        z = np.abs(d - med) / s
        flag = z > extend
        e = np.diff(np.concatenate(([0], flag.view(np.int8), [0])))
        a, b = np.flatnonzero(e == 1), np.flatnonzero(e == -1)
        for i in range(a.size):
            seg = z[a[i] : b[i]]
            hc, pk = bool((seg > core).any()), float(seg.max())
            if open_run is not None and a[i] == 0:  # the run of the last piece goes on
                open_run = [open_run[0], open_run[1] or hc, max(open_run[2], pk)]
            else:
                if open_run is not None:
                    starts.append(open_run[0]), stops.append(pos), cores.append(open_run[1]), peaks.append(open_run[2])
                open_run = [pos + int(a[i]), hc, pk]
            if b[i] < d.size:  # closed inside this piece
                starts.append(open_run[0]), stops.append(pos + int(b[i]))
                cores.append(open_run[1]), peaks.append(open_run[2])
                open_run = None
        if a.size == 0 and open_run is not None:
            starts.append(open_run[0]), stops.append(pos), cores.append(open_run[1]), peaks.append(open_run[2])
            open_run = None
        end = pos + d.size
    if open_run is not None:
        starts.append(open_run[0]), stops.append(end), cores.append(open_run[1]), peaks.append(open_run[2])
    return (
        np.array(starts, dtype=np.int64),
        np.array(stops, dtype=np.int64),
        np.array(cores, dtype=bool),
        np.array(peaks, dtype=np.float64),
    )


CHUNK = 64
"""Differences per count of ``counts_above``'s record-wide tally."""


def counts_above(
    pieces: Pieces, med: float, s: float, level: float, spans: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How many differences have |d - med| / s > ``level``: in each run of
    ``CHUNK`` differences of the channel (the last one shorter), and inside
    each span [a, b) of difference indices (counts: exact whatever the pieces)."""
    chunks: list[np.ndarray] = []
    carry = np.zeros(0, dtype=bool)
    inside = np.zeros(len(spans), dtype=np.int64)
    for pos, d in pieces():
        flag = np.abs(d - med) > level * s
        if len(spans):
            c = np.concatenate(([0], np.cumsum(flag, dtype=np.int64)))
            inside += c[np.clip(spans[:, 1] - pos, 0, d.size)] - c[np.clip(spans[:, 0] - pos, 0, d.size)]
        f = np.concatenate((carry, flag))
        k = f.size // CHUNK * CHUNK
        chunks.append(f[:k].reshape(-1, CHUNK).sum(axis=1))
        carry = f[k:]
    if carry.size:
        chunks.append(np.array([carry.sum()]))
    return (np.concatenate(chunks) if chunks else np.zeros(0, dtype=np.int64)), inside
