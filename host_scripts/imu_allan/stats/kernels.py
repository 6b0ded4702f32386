"""Numeric kernels shared by the Allan engines (allan.py, reference.py):
the offset removed before summing, and the sums of squares.

Why an offset: partial sums of raw ADC codes (~500 per sample) grow fast and
lose float64 digits; removing the (rounded) mean of the first block keeps
them small, and a rounded offset keeps integer data integer, so cluster sums
and their differences stay exact and only the final sums of squares round.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

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
        return [(int(h) << 32) + int(l) for h, l in zip(hi, lo)]
    return [sum(int(v) * int(v) for v in row) for row in d.tolist()]


def blocked(total: int, fn: Callable[[int, int], float], chunk: int = 1 << 18) -> float:
    """sum of fn(a, b) over [0, total) in chunks (keeps temporaries in cache)."""
    s = 0.0
    for a in range(0, total, chunk):
        s += fn(a, min(a + chunk, total))
    return s
