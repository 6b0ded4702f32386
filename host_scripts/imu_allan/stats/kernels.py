"""Numeric kernels shared by the Allan engines (allan.py, reference.py):
the offset removed before summing, and the sums of squares.

The octave and any-m sums have two implementations with the same results
(to ~1e-15; tests/test_octave_kernels.py runs both against an extended-
precision reference): the compiled ``_ckernels`` extension (_ckernels.c,
built by ``pip install`` or ``make ext``) and the numpy code below, used
when the extension is absent or ``IMU_ALLAN_NO_C=1`` is set.

Why an offset: partial sums of raw ADC codes (~500 per sample) grow fast and
lose float64 digits; removing the (rounded) mean of the first block keeps
them small, and a rounded offset keeps integer data integer, so cluster sums
and their differences stay exact and only the final sums of squares round.
"""

from __future__ import annotations

import math
import os
from typing import Callable, Optional

import numpy as np

try:  # the compiled kernels; the numpy code below is the fallback
    from . import _ckernels as _C
except ImportError:  # pragma: no cover - depends on the build
    _C = None
if os.environ.get("IMU_ALLAN_NO_C"):
    _C = None

COMPILED = _C is not None
"""True when the compiled kernels (stats/_ckernels.c) are in use."""

HEAD = 1 << 16
"""Samples whose mean is the offset (the first block of a stream)."""

DOT_MAX = 8192
"""Longest vector handed to one BLAS dot: OpenBLAS threads ddot above 10000
elements, and on a busy machine the thread hand-off costs milliseconds."""

_VECDOT = getattr(np, "vecdot", None)  # numpy >= 2: BLAS dot per row, single-threaded sizes


def offset(head: np.ndarray) -> np.ndarray:
    """The offset of each row of ``head`` (its last axis: samples): the
    mean, rounded to an integer when every value is an integer."""
    h = np.asarray(head, dtype=np.float64)
    mean = h.mean(axis=-1)
    return np.where(np.all(h == np.rint(h), axis=-1), np.rint(mean), mean)


def rowdots(r: np.ndarray) -> np.ndarray:
    """Sum of squares of each row of a 2-D float64 array."""
    if _VECDOT is not None:
        return _VECDOT(r, r)
    return np.einsum("ij,ij->i", r, r)


def sumsq(v: np.ndarray) -> float:
    """Sum of squares of a 1-D float64 vector (BLAS dots of at most DOT_MAX values)."""
    n = v.size
    if n <= DOT_MAX:
        return float(np.dot(v, v))
    full = n - n % DOT_MAX
    r = v[:full].reshape(-1, DOT_MAX)  # a view, also for a strided 1-D vector
    s = float(rowdots(r).sum())
    if full < n:
        t = v[full:]
        s += float(np.dot(t, t))
    return s


def sumsq_any(d: np.ndarray) -> float:
    """``sumsq`` of an integer or float vector."""
    return sumsq(d.astype(np.float64) if d.dtype != np.float64 else d)


def exact_sumsq(d: np.ndarray) -> list[int]:
    """Exact sum over axis 1 of d**2 for int64 d, as Python ints per row (the device's acc)."""
    if d.size == 0:
        return [0] * d.shape[0]
    if int(np.abs(d).max()) < (1 << 31):
        sq = (d * d).view(np.uint64)  # < 2^62, exact
        lo = (sq & np.uint64(0xFFFFFFFF)).sum(axis=1, dtype=np.uint64)  # < 2^32 per term
        hi = (sq >> np.uint64(32)).sum(axis=1, dtype=np.uint64)
        return [(int(h) << 32) + int(low) for h, low in zip(hi, lo)]
    return [sum(int(v) * int(v) for v in row) for row in d.tolist()]


def blocked(total: int, fn: Callable[[int, int], float], chunk: int = 1 << 18) -> float:
    """sum of fn(a, b) over [0, total) in chunks (keeps temporaries in cache)."""
    s = 0.0
    for a in range(0, total, chunk):
        s += fn(a, min(a + chunk, total))
    return s


# ---- in-memory octave kernels (m = 1, 2, 4 ... of one channel) ---------------------

OCTAVE_TILE = 1 << 17
"""Stage-1 tile of the overlapping octave kernel: samples per tile (cache-sized)."""
OCTAVE_SPLIT = 1 << 14
"""First cluster size of stage 2 (its halo: stage-1 tiles read SPLIT - 1 samples more)."""


_C_KINDS = "fiu"


def _c_input(x: np.ndarray) -> Optional[np.ndarray]:
    """x as the compiled kernels take it (1-D, contiguous, native numbers), or None."""
    if _C is None or x.ndim != 1 or x.dtype.kind not in _C_KINDS or not x.dtype.isnative:
        return None
    if x.dtype.kind == "f" and x.itemsize not in (4, 8):
        return None
    return x if x.flags.c_contiguous else None


def _exact(c: np.ndarray, off: float) -> int:
    """1 when the compiled kernels can sum ``c`` exactly: integer codes and an
    integral offset whose partial sums stay below 2^52 (every difference an
    exact float64 integer; the sums of squares then 128-bit integers that
    cannot overflow)."""
    span = max(abs(int(c.max())), abs(int(c.min()))) if c.dtype.kind in "iu" and c.itemsize > 2 and c.size else 0
    return _exact_span(c.dtype, c.size, off, span)


def _exact_span(dt: np.dtype, n: int, off: float, span: int) -> int:
    """``_exact`` from the number type, the count and the largest |value|
    (``span``; the same rule for samples in memory and in a file)."""
    if dt.kind not in "iu" or off != round(off) or not getattr(_C, "EXACT", False) or not n:
        return 0
    amax = (1 << (8 * dt.itemsize)) if dt.itemsize <= 2 else span + abs(int(off))
    a = amax + 1
    # differences below 2^52, and every sum of squares (< n (n a)^2) within 128 bits
    return int(n * a < (1 << 52) and n**3 * a * a < (1 << 127))


Windows = tuple[np.ndarray, int, np.ndarray]
"""(starts, size, out): windows of ``size`` samples at ``starts`` (int64, in order)
whose overlapping sums the same pass writes into ``out`` (float64, (levels, W)):
level k's sum over the terms i in [start, start + size - 2^(k+1)], the sums of
``octave_oavar_sums`` on each window alone (exactly for integer codes, else to
float order) without a second pass."""


def _window_args(windows: Optional[Windows], levels: int) -> tuple:
    if windows is None:
        return ()
    starts, size, out = windows
    if out.shape != (levels, starts.size) or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError("windows: out must be float64 (levels, windows)")
    return (np.ascontiguousarray(starts, dtype=np.int64), int(size), out.reshape(-1))


def octave_file_sums(
    fd: int, dt: np.dtype, n: int, off: float, span: int = 0, windows: Optional[Windows] = None
) -> Optional[tuple[np.ndarray, np.ndarray]]:
    """(overlapping, non-overlapping) octave sums of the n samples of type ``dt``
    stored from byte 0 of the open file ``fd``, read with pread in tiles: the
    numbers ``octave_oavar_sums(x, off, stream=True)`` and ``octave_avar_sums(x, off)``
    give on the same samples in memory (the same C code), in O(1) memory; and
    the ``windows``' sums (see Windows). None without the compiled kernels."""
    dt = np.dtype(dt)
    if _C is None or not dt.isnative or dt.kind not in _C_KINDS:
        return None
    levels = max(_levels(n), 1)
    over, non = np.zeros(levels), np.zeros(levels)
    ex = _exact_span(dt, n, off, span)
    got = _C.octave_file(fd, dt.char, n, float(off), over, non, ex, *_window_args(windows, _levels(n)))
    return over[:got], non[:got]


def _levels(n: int) -> int:
    return int(math.log2(n // 2)) + 1 if n >= 2 else 0


levels = _levels
"""Octave levels of n samples (m = 1, 2, 4 ... n/2)."""


def octave_oavar_sums(
    x: np.ndarray, off: float, stream: bool = False, windows: Optional[Windows] = None
) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping octave sums (see octave_oavar_sums_numpy), compiled when available:
    for integer codes (see _exact) the exact integer sums, rounded once.

    ``stream``: above the first stage, one running second difference per level
    read straight from ``x`` (long double) instead of the buffer of y_SPLIT:
    O(1) extra memory, for an np.memmap of a file larger than memory; and the
    ``windows``' sums (see Windows; stream mode and the compiled kernels only:
    ``out`` is left alone otherwise)."""
    c = _c_input(x)
    if c is None:
        return octave_oavar_sums_numpy(x, off)
    n = c.size
    acc = np.zeros(max(_levels(n), 1))
    more = _window_args(windows, _levels(n)) if stream else ()
    levels = _C.octave_overlap(c, float(off), acc, OCTAVE_TILE, OCTAVE_SPLIT, int(stream), _exact(c, off), *more)
    ms = np.left_shift(1, np.arange(levels, dtype=np.int64))
    return acc[:levels], n - 2 * ms + 1


def octave_avar_sums(x: np.ndarray, off: float, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
    """Non-overlapping octave sums (see octave_avar_sums_numpy), compiled when available."""
    c = _c_input(x)
    if c is None:
        return octave_avar_sums_numpy(x, off, chunk)
    n = c.size
    acc = np.zeros(max(_levels(n), 1))
    levels = _C.octave_nonoverlap(c, float(off), acc, chunk, _exact(c, off))
    ms = np.left_shift(1, np.arange(levels, dtype=np.int64))
    return acc[:levels], n // ms - 1


def any_m_sums(x: np.ndarray, off: float, ms: np.ndarray, overlapping: bool) -> Optional[np.ndarray]:
    """Sums of squared second differences of the phase at each m (nan where there is
    no term), or None without the compiled kernels (the caller's numpy path runs).

    The phase is kept as float64 offsets from a long double base per block of
    4096 samples, so no second difference subtracts large partial sums."""
    c = _c_input(x)
    if c is None:
        return None
    out = np.empty(ms.size)
    _C.any_m(c, float(off), np.ascontiguousarray(ms, dtype=np.int64), out, bool(overlapping), _exact(c, off))
    return out


def octave_oavar_sums_numpy(x: np.ndarray, off: float) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping octave sums: for m = 2^k <= n/2, sum_i (y_m[i+m] - y_m[i])^2 and
    the term count n - 2m + 1, where y_m[i] = sum of x[i .. i+m-1] - m * off.

    The cascade y_2m[i] = y_m[i] + y_m[i+m] (pairwise sums: accurate, exact for
    integer codes) in two cache-blocked stages, so each sample crosses main
    memory about three times in total instead of about three times per level:
      1. levels m < SPLIT over tiles of the input with a halo of SPLIT samples;
         writes y_SPLIT (one array the size of the input: the only big buffer);
      2. levels m >= SPLIT only combine entries of y_SPLIT whose indices agree
         modulo SPLIT, so y_SPLIT viewed as rows of SPLIT columns splits into
         independent column blocks, each cascaded through every upper level in cache.
    """
    n = x.size
    levels = int(math.log2(n // 2)) + 1 if n >= 2 else 0
    acc = np.zeros(levels)
    ms = np.left_shift(1, np.arange(levels, dtype=np.int64))
    terms = n - 2 * ms + 1
    if not levels:
        return acc, terms
    M = min(OCTAVE_SPLIT, 1 << levels)  # 2^levels <= n: y_M has at least one value
    K = M.bit_length() - 1
    T = max(OCTAVE_TILE, 8 * M)
    LY = n - M + 1
    stage2 = K < levels
    Q = -(-LY // M)
    Y = np.empty((Q, M)) if stage2 else None
    bufs = (np.empty(T + M), np.empty(T + M))
    tmp = np.empty(T + M)
    for a in range(0, LY, T):
        b = min(a + T + M - 1, n)
        L = b - a
        last = a + T >= LY  # the last tile takes every remaining term (b = n)
        buf = bufs[0]
        np.subtract(x[a:b], off, out=buf[:L])
        for k in range(K):
            m = 1 << k
            c = n - 2 * m + 1 - a if last else min(T, n - 2 * m + 1 - a)  # terms i in [a, a + c)
            if c <= 0:
                break
            acc[k] += sumsq(np.subtract(buf[m : m + c], buf[:c], out=tmp[:c]))
            L -= m  # y_2m values in the tile
            nxt = bufs[(k + 1) % 2]
            np.add(buf[:L], buf[m : m + L], out=nxt[:L])  # separate buffers: no overlap copy
            buf = nxt
        if Y is not None:
            cnt = min(T, LY - a)
            Y.reshape(-1)[a : a + cnt] = buf[:cnt]
    if Y is None:
        return acc, terms
    R = min(M, 1 << max(3, (max(OCTAVE_TILE // 2 // Q, 1)).bit_length() - 1))
    tiles = (np.empty(Q * R), np.empty(Q * R))
    tmp2 = np.empty(Q * R)
    for r0 in range(0, M, R):
        src = tiles[0]
        np.copyto(src.reshape(Q, R), Y[:, r0 : r0 + R])
        for k in range(K, levels):
            m = 1 << k
            e0 = n - 2 * m - r0  # terms i = q M + r0 + j with i <= n - 2m
            if e0 < 0:
                break
            qf, rem = divmod(e0, M)
            cnt = qf * R + min(R, rem + 1)  # a prefix of the row-major block
            s = (m // M) * R
            acc[k] += sumsq(np.subtract(src[s : s + cnt], src[:cnt], out=tmp2[:cnt]))
            dst = tiles[1] if src is tiles[0] else tiles[0]
            np.add(src[:cnt], src[s : s + cnt], out=dst[:cnt])
            src = dst
    return acc, terms


def octave_avar_sums_numpy(x: np.ndarray, off: float, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
    """Non-overlapping octave sums: for m = 2^k <= n/2, sum_j (S_m[j+1] - S_m[j])^2
    over the floor(n/m) - 1 pairs of consecutive cluster sums S_m (offset removed).

    Cluster sums cascade S_2m[j] = S_m[2j] + S_m[2j+1] inside chunks of ``chunk``
    (a power of two) samples: one pass over the input, nothing written to main
    memory but one sum per chunk; the pair across a chunk boundary uses the
    previous chunk's last sum, kept in slot 0 of each level's buffer."""
    n = x.size
    levels = int(math.log2(n // 2)) + 1 if n >= 2 else 0
    acc = np.zeros(levels)
    ms = np.left_shift(1, np.arange(levels, dtype=np.int64))
    pairs = n // ms - 1
    if not levels:
        return acc, pairs
    KC = chunk.bit_length() - 1
    inner = min(levels, KC + 1)  # levels cascaded inside a chunk (m <= chunk)
    bufs = [np.empty((chunk >> k) + 1) for k in range(inner)]
    have = [False] * inner
    diff = np.empty(chunk)
    top = np.empty(n // chunk + 1)  # level-KC sums, one per full chunk
    ntop = 0
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        L = b - a
        np.subtract(x[a:b], off, out=bufs[0][1 : L + 1])
        for k in range(inner):
            buf = bufs[k]
            lo = 0 if have[k] else 1  # slot 0: the previous chunk's last sum
            if L + 1 - lo >= 2:
                acc[k] += sumsq(np.subtract(buf[lo + 1 : L + 1], buf[lo:L], out=diff[: L - lo]))
            if L >= 1:
                buf[0] = buf[L]
                have[k] = True
            if k + 1 < inner:
                h = L // 2
                if h:
                    np.add(buf[1 : 2 * h : 2], buf[2 : 2 * h + 1 : 2], out=bufs[k + 1][1 : h + 1])
                L = h
            elif inner < levels and L == 1:
                top[ntop] = buf[1]
                ntop += 1
    # levels above the chunk: plain cascade over the chunk sums
    S = top[:ntop]
    for k in range(inner, levels):
        h = S.size // 2
        S = S[0 : 2 * h : 2] + S[1 : 2 * h : 2]
        if S.size >= 2:
            acc[k] = sumsq(np.diff(S))
    return acc, pairs
