"""Digital filters of the noise catalogue: the LP process's low-pass, the
autocovariance of white noise through it (by residues, for its exact Allan
variance), its frequency response, and lfilter for simulation. scipy.signal is
imported only where a stream is simulated: its import brings scipy.stats (~0.7 s
of CPU), which fitting a curve does not need."""

from __future__ import annotations

import math

import numpy as np


def lfilter(*args, **kw):
    """scipy.signal.lfilter, imported when a stream is simulated: the import costs
    ~0.7 s of CPU (it brings scipy.stats), which ``analyze`` does not need."""
    from scipy import signal

    return signal.lfilter(*args, **kw)


def freq_response(b: np.ndarray, a: np.ndarray, f: np.ndarray, fs: float) -> np.ndarray:
    """H(e^{j 2 pi f / fs}) of the digital filter b/a (scipy.signal.freqz's sum at
    the given frequencies, without importing scipy.signal)."""
    zm1 = np.exp(-2j * np.pi * np.asarray(f, dtype=np.float64) / fs)
    return np.polynomial.polynomial.polyval(zm1, b) / np.polynomial.polynomial.polyval(zm1, a)


def lowpass_filter(fc: float, fs: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The discrete low-pass of the LP process: order 1 the sampled RC (a pole at
    exp(-2 pi fc / fs), what an analog one-pole gives the samples); order 2 a
    digital Butterworth (bilinear, as a sensor's DLPF; scipy.signal.butter's
    coefficients).  fc at most 0.49 fs."""
    fc = min(float(fc), 0.49 * fs)
    if order == 1:
        a1 = math.exp(-2.0 * math.pi * fc / fs)
        return np.array([1.0 - a1]), np.array([1.0, -a1])
    if order == 2:
        k = math.tan(math.pi * fc / fs)
        g = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
        b0 = k * k * g
        return (
            np.array([b0, 2.0 * b0, b0]),
            np.array([1.0, 2.0 * (k * k - 1.0) * g, (1.0 - math.sqrt(2.0) * k + k * k) * g]),
        )
    raise ValueError(f"low-pass order must be 1 or 2, got {order}")


def filter_autocov(b: np.ndarray, a: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Autocovariance of unit white noise through b/a (len(b) <= len(a), distinct
    poles): r(0) and (c, p) with r(k) = sum c_i p_i^k for k >= 1, by residues:
    r(k) = sum_i Res_{p_i} H(z) H(1/z) z^(k-1), plus H(0) H(inf) at k = 0."""
    na = a.size - 1
    bp = np.concatenate((b, np.zeros(na + 1 - b.size)))  # numerator in powers of z, degree na
    p = _poles(a)

    def H(z: np.ndarray) -> np.ndarray:
        return np.polyval(bp, z) / np.polyval(a, z)

    c = np.empty(na, dtype=np.complex128)
    for i in range(na):  # over the poles (one or two)
        others = np.prod([p[i] - p[j] for j in range(na) if j != i]) if na > 1 else 1.0
        c[i] = np.polyval(bp, p[i]) / others * H(1.0 / p[i]) / p[i]
    h0 = bp[-1] / a[-1]  # H(0) (z -> 0 of the z-polynomial form)
    r0 = float(np.real(h0 * bp[0] + np.sum(c)))
    return r0, c, p


def _poles(a: np.ndarray) -> np.ndarray:
    """Roots of the denominator a (z-polynomial form): in closed form for one or two
    poles (the fit asks for thousands of cutoffs; np.roots' eigenvalues cost most of it)."""
    if a.size == 2:
        return np.array([-a[1] / a[0]], dtype=np.complex128)
    if a.size == 3:
        q = np.sqrt(complex(a[1] * a[1] - 4.0 * a[0] * a[2]))
        return np.array([(-a[1] + q) / (2.0 * a[0]), (-a[1] - q) / (2.0 * a[0])], dtype=np.complex128)
    return np.roots(a).astype(np.complex128)
