"""Float64 reference of the device's statistic: non-overlapping Allan
variance at octave cluster sizes m = 1, 2, 4, ... computed from raw codes.

Same definition as allantools' ``adev`` on frequency data at taus m/fs:
    avar(m) = sum_j (mean_{j+1} - mean_j)^2 / (2 * pairs),
with pairs = floor(n/m) - 1 consecutive non-overlapping cluster means.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class OctaveRow:
    level: int
    m: int
    pairs: int
    avar: float


def octave_avar(x: ArrayLike, levels: int) -> list[OctaveRow]:
    """Non-overlapping Allan variance of one channel at m = 2**k, k < levels.

    Uses a cascade of pairwise sums: level k+1's cluster sums are the sums of
    consecutive pairs of level k's, one pass over the data in total.
    Levels with fewer than two clusters report 0 pairs and avar nan.
    """
    sums = np.asarray(x, dtype=np.float64).ravel()
    rows: list[OctaveRow] = []
    for k in range(levels):
        m = 1 << k
        pairs = max(sums.size - 1, 0)
        if pairs:
            d = np.diff(sums) / m
            avar = float(np.dot(d, d) / (2.0 * pairs))
        else:
            avar = float("nan")
        rows.append(OctaveRow(k, m, pairs, avar))
        even = sums.size - (sums.size & 1)
        sums = sums[0:even:2] + sums[1:even:2]
    return rows
