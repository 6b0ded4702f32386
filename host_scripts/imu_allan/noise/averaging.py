"""White noise through averaging filters, sampled: the band limit of a part that
averages before it is read (a moving average; two in cascade, the Bartlett
window of ADI's iSensor parts, whose FIR runs at an internal rate far above the
rate the host reads them at).

The part's internal rate being high, the filter is taken in continuous time:
white noise of two-sided density N^2 through ``stages`` cascaded averages of
width w (the kernel a box, or for two stages a triangle of span 2 w), read every
dt = 1/fs.  The kernel's autocorrelation is the B-spline of degree
2 stages - 1 (the box's: the hat; the triangle's: the cubic B-spline,
support +-2 w), so the samples' autocovariance is exact and finite:

    r(k) = N^2 / w * beta_{2 stages - 1}(k dt / w),   r(k) = 0 for |k| dt >= stages w

and their Allan variance follows in closed form from S(m) = sum_{|k|<m} (m - |k|) r(k)
(processes.py).  The r are normalized so that dt sum_k r(k) = N^2: N is the
samples' low-frequency density, as for the other band limits (reading faster
than 1 / w aliases, and that sum is not exactly the kernel's area).

fc is the kernel's -3 dB frequency, |H| = |sinc(f w)|^stages: w = X3DB / fc.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike

X3DB = {1: 0.44294647, 2: 0.31891670}
"""fc w of the -3 dB point of one average (sinc) and of two in cascade (sinc^2)."""


def bspline(x: np.ndarray, degree: int) -> np.ndarray:
    """The centred cardinal B-spline of ``degree`` (support |x| < (degree + 1) / 2),
    by its truncated-power sum."""
    x = np.abs(np.asarray(x, dtype=np.float64))
    n = degree + 1
    out = np.zeros(x.shape)
    for j in range(n + 1):  # over the knots (a few)
        out += (-1) ** j * math.comb(n, j) * np.maximum(x + n / 2.0 - j, 0.0) ** degree
    return np.maximum(out / math.factorial(degree), 0.0)


@functools.lru_cache(maxsize=4096)
def average_autocov(fc: float, fs: float, stages: int) -> np.ndarray:
    """r(0..q) of unit-density (N = 1) white noise through ``stages`` averages of
    -3 dB frequency fc, read at fs; dt sum_{|k| <= q} r(k) = 1."""
    if stages not in X3DB:
        raise ValueError(f"averaging stages must be 1 or 2, got {stages}")
    w = X3DB[stages] / float(fc) * fs  # the width in samples
    q = int(math.ceil(stages * w))
    r = bspline(np.arange(q + 1) / w, 2 * stages - 1)
    nz = np.flatnonzero(r)  # the trailing zeros cut (numpy.trim_zeros, at a tenth of its cost)
    r = r[: nz[-1] + 1 if nz.size else 0]
    r = r * (fs / (r[0] + 2.0 * r[1:].sum()))
    r.setflags(write=False)  # shared by the cache
    return r


def avar_from_autocov(m: ArrayLike, r: np.ndarray) -> np.ndarray:
    """Exact AVAR at cluster sizes m of a sequence with autocovariance r(0..q)
    (zero beyond q): S(m) = m (r0 + 2 C0) - 2 C1, C0 and C1 the sums of r(k) and
    k r(k) for k < m."""
    m = np.asarray(m, dtype=np.float64)
    k = np.arange(1, r.size)
    c0 = np.concatenate(([0.0], np.cumsum(r[1:])))
    c1 = np.concatenate(([0.0], np.cumsum(k * r[1:])))

    def S(n: np.ndarray) -> np.ndarray:
        j = np.minimum(np.maximum(np.ceil(n).astype(np.int64) - 1, 0), r.size - 1)  # lags 1 .. j, j < n
        return n * (r[0] + 2.0 * c0[j]) - 2.0 * c1[j]

    return (4.0 * S(m) - S(2.0 * m)) / (2.0 * m * m)


def psd_from_autocov(f: ArrayLike, fs: float, r: np.ndarray) -> np.ndarray:
    """One-sided PSD (u^2/Hz) of the samples: 2 dt (r0 + 2 sum r(k) cos(2 pi f k dt))."""
    f = np.asarray(f, dtype=np.float64)
    k = np.arange(1, r.size)
    w = 2.0 * np.pi * f[..., None] * k / fs
    return 2.0 / fs * (r[0] + 2.0 * np.sum(r[1:] * np.cos(w), axis=-1))


def ma_factor(r: np.ndarray) -> np.ndarray:
    """Taps b (causal, minimum phase) with sum_j b_j b_{j+k} = r(k): the white
    noise through b has exactly this autocovariance (Kolmogorov's cepstral
    factorization of the PSD on a fine grid; the factor of a degree-q trigonometric
    polynomial has q + 1 taps)."""
    q = r.size - 1
    if q == 0:
        return np.array([math.sqrt(r[0])])
    n = 1 << max(12, int(math.ceil(math.log2(64 * (q + 1)))))
    full = np.zeros(n)
    full[: q + 1] = r
    full[n - q :] = r[1:][::-1]
    spec = np.maximum(np.fft.fft(full).real, 1e-12 * r[0])
    cep = np.fft.ifft(np.log(spec)).real
    fold = np.zeros(n)
    fold[0] = cep[0]
    fold[1 : n // 2] = 2.0 * cep[1 : n // 2]
    fold[n // 2] = cep[n // 2]
    b = np.fft.ifft(np.exp(np.fft.fft(fold) / 2.0)).real
    return b[: q + 1]
