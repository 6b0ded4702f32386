"""Power spectral density by Welch's method (as MATLAB's pwelch), streaming,
and the PSD levels of the IEEE 952 noise terms.

``Welch`` follows pwelch's defaults: symmetric Hamming window (hamming(n)), segments of
floor(n / 4.5) samples (eight segments with 50 % overlap), mean removed per
segment, one-sided density in u^2/Hz. Segments are capped at 2^16 samples
(resolution fs / 2^16: 0.015 Hz at 1 kHz, the PSD of taus to about a
minute; the Allan curves cover the longer ones) so that a file of any length
streams through at the cost of FFTs that fit in cache; a longer record then
averages more segments. ``scipy.signal.welch`` with the
same parameters gives the same numbers (tested). Segments of ``SINGLE_FROM``
samples and more (records from 4.5 x 2^16 = 295,000 samples) are transformed
in float32, demeaned and windowed in float64 first and their periodograms
summed in float64: 2.4x faster than float64 transforms, within 1e-5 of them
(tested) where float64's own agreement with scipy's is 1e-10 (the rounding of
float32 sits ~1e-14 under a bin's power, below a Hamming window's leakage).

One-sided PSD of each term (rate unit u, IEEE 952 Annex C, f in Hz, fs the
sample rate):
    Q   8 Q^2 fs sin^2(pi f / fs)   (white angle noise; ~ (2 pi f)^2 2 Q^2 / fs)
    N   2 N^2
    B   B^2 / (pi f)                (flicker)
    K   K^2 / (2 pi^2 f^2)
    R   R^2 / (4 pi^3 f^3)          (a ramp is deterministic: IEEE's nominal level)
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

SEGMENT_MAX = 1 << 16
SINGLE_FROM = 1 << 16
"""Segments at least this long go through float32 transforms (see above)."""


def _rfft(seg: np.ndarray, nfft: int) -> np.ndarray:
    """rfft along the last axis (scipy.fft: it lets other threads run meanwhile)."""
    try:
        import scipy.fft as sf
    except ImportError:  # pragma: no cover - scipy is a dependency
        return np.fft.rfft(seg, n=nfft, axis=-1)
    return sf.rfft(seg, n=nfft, axis=-1, overwrite_x=True)


def segment_length(n: int) -> int:
    """pwelch's default for n samples (8 segments, 50 % overlap), capped."""
    return int(max(min(n // 4.5 if n >= 9 else n, SEGMENT_MAX), 1))


class Welch:
    """Streaming Welch PSD of several channels: push (channels, samples) blocks."""

    def __init__(self, channels: int, fs: float, nperseg: int) -> None:
        self.C = channels
        self.fs = float(fs)
        self.nseg = max(int(nperseg), 2)
        self.step = self.nseg - self.nseg // 2  # overlap floor(nseg / 2), as pwelch
        self.window = np.hamming(self.nseg) if self.nseg > 1 else np.ones(1)
        self.nfft = max(256, 1 << int(math.ceil(math.log2(self.nseg))))
        self.scale = 1.0 / (self.fs * float(np.sum(self.window**2)))
        self.single = self.nseg >= SINGLE_FROM
        self.acc = np.zeros((channels, self.nfft // 2 + 1))
        self.count = 0
        self.buf = np.zeros((channels, 0))

    def push(self, block: ArrayLike) -> None:
        """Take (channels, samples); every whole segment is transformed and its
        periodogram added in segment order, so the result does not depend on
        how the stream was cut."""
        a = np.asarray(block, dtype=np.float64)
        buf = np.concatenate((self.buf, a), axis=1) if self.buf.shape[1] else np.ascontiguousarray(a)
        nfull = (buf.shape[1] - self.nseg) // self.step + 1 if buf.shape[1] >= self.nseg else 0
        per_call = max(1, (1 << 19) // self.nseg)  # segments per FFT call: a few MB
        for k0 in range(0, nfull, per_call):
            k1 = min(k0 + per_call, nfull)
            for c in range(self.C):
                self._segments(buf[c], k0, k1, self.acc[c])
            self.count += k1 - k0
        self.buf = buf[:, nfull * self.step :].copy()

    def _segments(self, x: np.ndarray, k0: int, k1: int, acc: np.ndarray) -> None:
        """Segments k0 .. k1-1 of one channel's buffer ``x`` into ``acc``: demeaned,
        windowed, transformed, squared, added (compiled where built: the same
        operations in the same order, fewer passes)."""
        from .kernels import _C

        seg = np.lib.stride_tricks.sliding_window_view(x, self.nseg)[k0 * self.step : k1 * self.step : self.step]
        mean = seg.mean(axis=1)
        one = self.single
        if _C is not None:
            w = np.empty(seg.shape, dtype=np.float32 if one else np.float64)
            _C.welch_prep(x[k0 * self.step :], self.nseg, self.step, k1 - k0, mean, self.window, w, one)
            spec = _rfft(w, self.nfft)
            _C.welch_acc(spec, k1 - k0, spec.shape[1], acc, spec.dtype == np.complex64)
            return
        w = seg - mean[:, None]
        w *= self.window
        spec = _rfft(w.astype(np.float32) if one else w, self.nfft)
        # re, im interleaved (float64): squared in place, then paired
        ri = spec.view(np.float32).astype(np.float64) if spec.dtype == np.complex64 else spec.view(np.float64)
        ri *= ri
        p = ri[:, 0::2] + ri[:, 1::2]
        for j in range(k1 - k0):
            acc += p[j]

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """(f, psd (channels, f)) one-sided in u^2/Hz; empty without a whole segment."""
        f = np.fft.rfftfreq(self.nfft, 1.0 / self.fs)
        if not self.count:
            return f[:0], np.zeros((self.C, 0))
        p = self.acc / self.count * self.scale
        p[:, 1:] *= 2.0
        p[:, -1] /= 2.0  # nfft is even: the Nyquist bin is not doubled
        return f, p


def log_bins(f: np.ndarray, p: np.ndarray, per_decade: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """Average a PSD (channels, f) in log-spaced frequency bins (DC dropped)."""
    keep = f > 0
    f, p = f[keep], p[:, keep]
    if not f.size:
        return f, p
    edges = np.logspace(
        math.log10(f[0]), math.log10(f[-1]) + 1e-12, max(int(per_decade * math.log10(f[-1] / f[0])) + 2, 2)
    )
    which = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, edges.size - 2)
    counts = np.bincount(which, minlength=edges.size - 1)
    ok = counts > 0
    fb = np.bincount(which, weights=np.log(f), minlength=edges.size - 1)[ok] / counts[ok]
    pb = np.stack([np.bincount(which, weights=row, minlength=edges.size - 1)[ok] / counts[ok] for row in p])
    return np.exp(fb), pb


def term_psd(f: ArrayLike, values: dict[str, Optional[float]], fs: float) -> dict[str, np.ndarray]:
    """One-sided PSD level of each present term at frequencies f (u^2/Hz)."""
    f = np.asarray(f, dtype=np.float64)
    out: dict[str, np.ndarray] = {}
    if values.get("Q"):
        out["Q"] = 8.0 * values["Q"] ** 2 * fs * np.sin(np.pi * f / fs) ** 2
    if values.get("N"):
        out["N"] = np.full_like(f, 2.0 * values["N"] ** 2)
    if values.get("B"):
        out["B"] = values["B"] ** 2 / (np.pi * f)
    if values.get("K"):
        out["K"] = values["K"] ** 2 / (2.0 * np.pi**2 * f**2)
    if values.get("R"):
        out["R"] = values["R"] ** 2 / (4.0 * np.pi**3 * f**3)
    return out
