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
    coefficients); order 4 the four-pole Butterworth (a steeper DLPF).  fc at most 0.49 fs."""
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
    if order == 4:  # two bilinear biquads of the analog prototype's dampings 2 cos(pi / 8), 2 cos(3 pi / 8)
        k = math.tan(math.pi * fc / fs)
        b, a = np.array([1.0]), np.array([1.0])
        for d in (2.0 * math.cos(math.pi / 8.0), 2.0 * math.cos(3.0 * math.pi / 8.0)):
            g = 1.0 / (1.0 + d * k + k * k)
            b = np.convolve(b, k * k * g * np.array([1.0, 2.0, 1.0]))
            a = np.convolve(a, np.array([1.0, 2.0 * (k * k - 1.0) * g, (1.0 - d * k + k * k) * g]))
        return b, a
    raise ValueError(f"low-pass order must be 1, 2 or 4, got {order}")


def filter_autocov(b: np.ndarray, a: np.ndarray, p: np.ndarray | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """Autocovariance of unit white noise through b/a (len(b) <= len(a), distinct
    poles ``p``, the roots of a when not given): r(0) and (c, p) with r(k) = sum c_i p_i^k
    for k >= 1, by residues: r(k) = sum_i Res_{p_i} H(z) H(1/z) z^(k-1), plus H(0) H(inf)
    at k = 0.  One or two poles one at a time (their columns' very bits), more at once."""
    na = a.size - 1
    bp = np.concatenate((b, np.zeros(na + 1 - b.size)))  # numerator in powers of z, degree na
    p = _poles(a) if p is None else p
    if na > 2:
        d = p[:, None] - p[None, :]
        d[np.diag_indices(na)] = 1.0
        q = 1.0 / p
        c = np.polyval(bp, p) / d.prod(axis=1) * (np.polyval(bp, q) / np.polyval(a, q)) / p
    else:

        def H(z: np.complex128) -> np.complex128:
            return _polyval(bp, z) / _polyval(a, z)

        c = np.empty(na, dtype=np.complex128)
        for i in range(na):
            others = p[i] - p[1 - i] if na > 1 else 1.0
            c[i] = _polyval(bp, p[i]) / others * H(1.0 / p[i]) / p[i]
    h0 = bp[-1] / a[-1]  # H(0) (z -> 0 of the z-polynomial form)
    r0 = float((h0 * bp[0] + c.sum()).real)
    return r0, c, p


def butter4_autocov(fc: float, fs: float, b: np.ndarray, a: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """filter_autocov of the four-pole Butterworth b/a (lowpass_filter's) with its poles in
    closed form (the bilinear images z = (2 fs + s) / (2 fs - s) of the prewarped analog ones
    s = W e^(i theta), theta = 5 pi / 8 ... 11 pi / 8, the upper half-plane pair first),
    returned as that pair with c doubled: the conjugate pair's terms of r(k) are each
    other's conjugates, so r(k) = sum Re(2 c_i p_i^k) over the pair (what avar_from_poles
    sums), at half the cost."""
    w = 2.0 * fs * math.tan(math.pi * fc / fs)
    s = w * np.exp(1j * np.pi * np.array([5.0, 7.0, 9.0, 11.0]) / 8.0)
    r0, c, p = filter_autocov(b, a, (2.0 * fs + s) / (2.0 * fs - s))
    return r0, 2.0 * c[:2], p[:2]


def _polyval(coef: np.ndarray, z: np.complex128) -> np.complex128:
    """numpy.polyval at one complex point by its own steps (z as a 0-d array: numpy's complex
    product of arrays may fuse a multiply and an add, its scalars' do not), without its
    conversions (the fit asks for thousands of cutoffs: numpy.polyval costs 20 us a call)."""
    x = np.asanyarray(z)
    y = _ZERO
    for v in coef:
        y = y * x + v
    return y


_ZERO = np.zeros((), dtype=np.complex128)


def _poles(a: np.ndarray) -> np.ndarray:
    """Roots of the denominator a (z-polynomial form): in closed form for one or two
    poles (the fit asks for thousands of cutoffs; np.roots' eigenvalues cost most of it)."""
    if a.size == 2:
        return np.array([-a[1] / a[0]], dtype=np.complex128)
    if a.size == 3:
        q = np.sqrt(complex(a[1] * a[1] - 4.0 * a[0] * a[2]))
        return np.array([(-a[1] + q) / (2.0 * a[0]), (-a[1] - q) / (2.0 * a[0])], dtype=np.complex128)
    return np.roots(a).astype(np.complex128)


def mean_pole_autocov(fc: float, fs: float, order: int) -> tuple[float, np.ndarray, np.ndarray]:
    """Autocovariance of the block means (over each dt = 1/fs: integrate and dump, or a
    faster record averaged down) of unit-density white noise (dt sum r = 1) through the
    continuous one-pole RC (order 1) or two-pole Butterworth (order 2) of cutoff fc:
    r(0) and (c, p) with r(k) = sum c_i p_i^k for k >= 1, valid for fc above fs / 2 too.

    The filter's output has R(t) = sum_i A_i exp(l_i |t|) (l_i its poles, A_i the
    residues of H(s) H(-s) there); a mean over dt has, with x_i = l_i dt and p_i = e^x_i,
    r(0) = sum 2 A_i (p_i - 1 - x_i) / x_i^2 and r(k) = sum A_i (p_i - 1)^2 / x_i^2 p_i^(k - 1),
    so that its Allan variance at m samples is the continuous one at tau = m dt (for order 1
    IEEE 952's band-limited white noise, annex C's exponentially correlated noise)."""
    wc = 2.0 * math.pi * float(fc)
    if order == 1:  # one real pole: the complex arithmetic below on floats (the fit asks for thousands)
        return _mean_rc_autocov(wc, float(fs))
    if order == 2:
        l1 = wc * np.exp(0.75j * math.pi)
        lam = np.array([l1, np.conj(l1)])
        A = np.array([wc**4 / ((u - v) * (-2.0 * u) * (-(u + v))) for u, v in ((lam[0], lam[1]), (lam[1], lam[0]))])
    else:
        raise ValueError(f"low-pass order must be 1 or 2, got {order}")
    x = lam / float(fs)
    em1 = np.expm1(x)
    r0 = float((2.0 * A * (em1 - x) / x**2).sum().real)
    p = em1 + 1.0
    c = A * em1**2 / (x**2 * p)
    return r0, c, p


def _mean_rc_autocov(wc: float, fs: float) -> tuple[float, np.ndarray, np.ndarray]:
    """mean_pole_autocov of the RC (pole -wc, residue wc / 2), each complex operation of the
    general form done on the real parts it reduces to, so as to give its very bits: numpy
    divides complex numbers by the reciprocal of the divisor (Smith's method), so a / b is
    a * (1 / b) here; a square is x * x."""
    x = -wc * (1.0 / fs)
    em1 = math.expm1(x)
    A = wc / 2.0
    r0 = (2.0 * A * (em1 - x)) * (1.0 / (x * x))
    p = em1 + 1.0
    c = (A * (em1 * em1)) * (1.0 / ((x * x) * p))
    return r0, np.array([c]), np.array([p])


def arma_factor(r0: float, c: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) such that unit white noise through b/a has the autocovariance r(0) = r0,
    r(k) = sum c_i p_i^k (k >= 1): a the polynomial of the poles p, b the minimum-phase
    factor (averaging.ma_factor) of the autocovariance of a * y, which is zero beyond
    the order (an ARMA(q, q))."""
    from .averaging import ma_factor

    a = np.real(np.poly(p))
    q = a.size - 1
    lags = np.arange(2 * q + 1)
    r = np.concatenate(([r0], np.real([np.sum(c * p**k) for k in lags[1:]])))
    pairs = [(i, j) for i in range(q + 1) for j in range(q + 1)]
    g = np.array([sum(a[i] * a[j] * r[abs(k + i - j)] for i, j in pairs) for k in range(q + 1)])
    return ma_factor(g), a
