"""Float64 reference of the device's statistic: non-overlapping Allan
variance at octave cluster sizes m = 1, 2, 4, ... computed from raw codes.

Same definition as allantools' ``adev`` on frequency data at taus m/fs:
    avar(m) = sum_j (mean_{j+1} - mean_j)^2 / (2 * pairs),
with pairs = floor(n/m) - 1 consecutive non-overlapping cluster means.

Two implementations, tested against each other and against allantools:
  * ``octave_avar(x, levels)``: one channel held in memory;
  * ``OctaveCascade``: streaming, any number of channels, blocks of any size.
    Beside the float64 Allan variance it keeps the exact integer sum of
    squared cluster-sum differences (the device's ``acc``), and it can stop
    each (level, channel) after a given number of pairs: the reference over
    exactly the first (pairs + 1) * m samples that a device row covers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

from .kernels import HEAD, exact_sumsq, offset, sumsq


@dataclass(frozen=True)
class OctaveRow:
    level: int
    m: int
    pairs: int
    avar: float


def octave_avar(x: ArrayLike, levels: int) -> list[OctaveRow]:
    """Non-overlapping Allan variance of one channel at m = 2**k, k < levels.

    Uses a cascade of pairwise sums: level k+1's cluster sums are the sums of
    consecutive pairs of level k's, one pass over the data in total (about
    two array passes at level 0, half that at each level above, in reused
    buffers). An offset (the rounded mean of the first samples, so integer
    codes stay exact) is removed first. Levels with fewer than two clusters
    report 0 pairs and avar nan.
    """
    sums = np.asarray(x, dtype=np.float64).ravel()
    n = sums.size
    if n:
        sums = sums - float(offset(sums[:HEAD]))
    diff = np.empty(min(max(n - 1, 0), _CHUNK))
    pingpong = (np.empty(n // 2), np.empty(n // 4 + 1))
    rows: list[OctaveRow] = []
    for k in range(levels):
        m = 1 << k
        pairs = max(sums.size - 1, 0)
        if pairs:
            total = 0.0
            for a in range(0, pairs, _CHUNK):  # differences in a cache-sized buffer
                b = min(a + _CHUNK, pairs)
                total += sumsq(np.subtract(sums[a + 1 : b + 1], sums[a:b], out=diff[: b - a]))
            avar = total / (2.0 * float(m) * float(m) * pairs)
        else:
            avar = float("nan")
        rows.append(OctaveRow(k, m, pairs, avar))
        half = sums.size // 2
        out = pingpong[k % 2][:half]
        sums = np.add(sums[0 : 2 * half : 2], sums[1 : 2 * half : 2], out=out)
    return rows


_CHUNK = 1 << 16


class OctaveCascade:
    """Streaming octave cascade over integer codes, channel-major blocks.

    ``push(block)`` with ``block`` of shape (channels, samples); blocks may
    have any length, the result does not depend on how the stream is cut.
    Cluster sums are exact int64; per (level, channel) it accumulates
      * ``acc``: the exact integer sum of squared cluster-sum differences;
      * the float64 sum of squared cluster-mean differences (pairwise sums
        within a block, ``math.fsum`` across blocks).
    ``limit`` (levels, channels): count at most that many pairs (the first
    ones); None counts all.
    """

    def __init__(self, levels: int, channels: int, limit: Optional[ArrayLike] = None) -> None:
        if levels < 1 or channels < 1:
            raise ValueError("levels and channels must be positive")
        self.levels = levels
        self.channels = channels
        self.limit = None if limit is None else np.asarray(limit, dtype=np.int64).reshape(levels, channels)
        self.n = 0
        self._clusters = [0] * levels
        self._last: list[Optional[np.ndarray]] = [None] * levels
        self._carry = [np.zeros((channels, 0), dtype=np.int64) for _ in range(levels)]
        self._acc = [[0] * channels for _ in range(levels)]
        self._partials: list[list[np.ndarray]] = [[] for _ in range(levels)]

    def push(self, block: ArrayLike) -> None:
        s = np.asarray(block, dtype=np.int64)
        if s.ndim != 2 or s.shape[0] != self.channels:
            raise ValueError(f"block must have shape ({self.channels}, samples)")
        self.n += s.shape[1]
        for k in range(self.levels):  # over levels, each vectorized over its clusters
            if s.shape[1]:
                self._accumulate(k, s)
            buf = np.concatenate((self._carry[k], s), axis=1) if self._carry[k].shape[1] else s
            even = buf.shape[1] & ~1
            self._carry[k] = buf[:, even:]
            s = buf[:, 0:even:2] + buf[:, 1:even:2]
            if not s.shape[1]:
                break  # nothing new reaches the levels above

    def _accumulate(self, k: int, s: np.ndarray) -> None:
        first = self._clusters[k]
        self._clusters[k] += s.shape[1]
        seq = s if self._last[k] is None else np.concatenate((self._last[k][:, None], s), axis=1)
        self._last[k] = s[:, -1].copy()
        d = np.diff(seq, axis=1)  # pair j = clusters j and j+1; this block's first pair:
        if not d.shape[1]:
            return
        base = max(first - 1, 0)
        if self.limit is not None:
            lim = self.limit[k]
            if base >= lim.max():
                return
            if base + d.shape[1] > lim.min():
                keep = (base + np.arange(d.shape[1]))[None, :] < lim[:, None]
                d = np.where(keep, d, 0)
        mean = d.astype(np.float64) / (1 << k)
        self._partials[k].append(np.square(mean).sum(axis=1))
        acc = self._acc[k]
        for c, total in enumerate(exact_sumsq(d)):
            acc[c] += total

    def pairs(self) -> np.ndarray:
        """Pairs counted per (level, channel) (the limit applied)."""
        total = np.array([max(c - 1, 0) for c in self._clusters], dtype=np.int64)
        out = np.repeat(total[:, None], self.channels, axis=1)
        return out if self.limit is None else np.minimum(out, self.limit)

    def available_pairs(self) -> np.ndarray:
        """Pairs the stream pushed so far holds per level (no limit)."""
        return np.array([max(c - 1, 0) for c in self._clusters], dtype=np.int64)

    def acc(self) -> list[list[int]]:
        """Exact sum of squared cluster-sum differences per (level, channel)."""
        return [list(row) for row in self._acc]

    def avar(self) -> np.ndarray:
        """Float64 Allan variance per (level, channel); nan without pairs."""
        pairs = self.pairs()
        out = np.full((self.levels, self.channels), np.nan)
        for k in range(self.levels):
            for c in range(self.channels):
                if pairs[k, c]:
                    total = math.fsum(float(p[c]) for p in self._partials[k])
                    out[k, c] = total / (2.0 * float(pairs[k, c]))
        return out
