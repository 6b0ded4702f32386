"""Flicker rate noise of the catalogue (IEEE 952 C.3, bias instability): its Allan
variance as the samples see it (sampled as points up to fs/2, or as means of a
continuous 1/f over each sample), its PSD, and its simulation by a bank of
Gauss-Markov processes (the classic sum of relaxation processes of 1/f noise,
correlation times spaced by a constant ratio)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .filters import lfilter
from .processes import Process, _m, _Stream
from .terms import B_FACTOR


@dataclass(repr=False)
class Flicker(Process):
    """Flicker rate noise B [u] (bias instability): PSD B^2 / (pi f) one-sided
    (IEEE 952 C.3), ADEV floor 0.664 B.  ``sampling`` says how the samples see it:
    - "point" (samples of the 1/f up to fs/2, as a textbook generator makes it):
      AVAR of the sampled PSD averaged over m samples (``flicker_ratio``), the
      IEEE 952 constant (2 ln 2 / pi) B^2 times 1.189 at m = 1, 1.089 at 2,
      1.029 at 4, 1.003 at 16, within 4e-6 of it from m = 1024;
    - "mean" (each sample the average of a continuous 1/f over its period, as in
      a part that integrates or averages): the IEEE constant at every m, exactly.
    The constant misfits point samples' first octaves by up to 19 %, which decides
    B wherever a low-pass has taken the white noise out of them.  Simulation: a
    bank of Gauss-Markov processes, correlation times 8^k dt up to 4 records, each
    of variance B^2 ln 8 / pi (the fastest FLICKER_FAST times that), the slow ones
    drawn every T fs / 32 samples and held: within 1.3 % of the point AVAR at
    every m; "mean" averages that bank run FLICKER_MEAN_UP times faster."""

    B: float
    sampling: str = "point"
    name = "B"
    meaning = "flicker rate noise B (bias instability; the flat floor of ADEV at 0.664 B)"

    def params(self) -> dict[str, float]:
        return {"B": self.B}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        if self.sampling == "mean":
            return np.full(np.shape(m), B_FACTOR * self.B**2)
        return B_FACTOR * self.B**2 * flicker_ratio(m)

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        return self.B**2 / (np.pi * _m(f))

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        if self.sampling == "mean":
            return _Averaged(_FlickerBank(self.B, fs * FLICKER_MEAN_UP, n * FLICKER_MEAN_UP, seed), FLICKER_MEAN_UP)
        return _FlickerBank(self.B, fs, n, seed)


class _Averaged(_Stream):
    """Means of ``up`` consecutive samples of a faster stream."""

    def __init__(self, fast: _Stream, up: int) -> None:
        self.fast, self.up = fast, up

    def take(self, length: int) -> np.ndarray:
        return self.fast.take(length * self.up).reshape(length, self.up).mean(axis=1)


FLICKER_SPACING = 8.0
FLICKER_MEAN_UP = 8
"""A "mean" flicker is the bank at this many times the rate, averaged: its AVAR at m
is the point form's at 8 m, within 0.9 % of the constant (and the bank's 1.3 %)."""
FLICKER_FAST = 1.056
"""The bank's fastest process (T = dt) carries this times its share: the minimax
choice that brings the bank's AVAR within 1.3 % of the sampled 1/f's at every m
(3.9 % under it at m = 1-8 with equal shares)."""
FLICKER_EXACT_TO = 1024
"""From this m on the sampled 1/f's AVAR is the IEEE constant to 4e-6."""


@functools.lru_cache(maxsize=1)
def _flicker_curve():  # -> scipy.interpolate.PchipInterpolator
    """log ratio against log m, a monotone cubic through every m from 1 to 16 (between
    integers the ratio bends most), then 4 points per octave to FLICKER_EXACT_TO (where it
    goes as ln m / m^2): built once a process."""
    from scipy.interpolate import PchipInterpolator

    top = math.log2(FLICKER_EXACT_TO)
    m = np.concatenate((np.arange(1.0, 16.0), 2.0 ** np.linspace(4.0, top, 4 * int(round(top - 4.0)) + 1)))
    return PchipInterpolator(np.log(m), np.log([_flicker_ratio_at(v) for v in m]))


def _flicker_ratio_at(m: float) -> float:
    """(2 / pi) int_0^1/2 sin^4(pi u m) / (u m^2 sin^2(pi u)) du / B_FACTOR: the AVAR
    of a one-sided B^2 / (pi f) PSD seen through the m-sample average's difference,
    |H|^2 = sin^4(pi f m dt) / (m sin(pi f dt))^2, by the midpoint rule (256 points a
    period of the integrand; the 1/u at 0 is integrable: the integrand goes as u)."""
    n = int(max(256 * m, 4096))
    u = (np.arange(n) + 0.5) / (2 * n)
    f = np.sin(np.pi * u * m) ** 4 / (u * m * m * np.sin(np.pi * u) ** 2)
    return float(f.sum() / (2 * n) / math.log(2.0))


def flicker_ratio(m: ArrayLike) -> np.ndarray:
    """AVAR of sampled flicker over the IEEE 952 constant at cluster size m (1 from
    FLICKER_EXACT_TO on): a monotone cubic through the table, within 2e-5 of the integral at every integer m."""
    m = _m(m)
    x = np.log(np.clip(m, 1.0, FLICKER_EXACT_TO))
    return np.where(m >= FLICKER_EXACT_TO, 1.0, np.exp(_flicker_curve()(x)))


class _FlickerBank(_Stream):
    def __init__(self, b: float, fs: float, n: int, seed: np.random.SeedSequence) -> None:
        r = FLICKER_SPACING
        t_lo, t_hi = 1.0 / fs, max(4.0 * n / fs, 8.0 / fs)
        count = int(math.ceil(math.log(t_hi / t_lo) / math.log(r))) + 1
        share = b * math.sqrt(math.log(r) / math.pi)
        self.procs = []
        self.pos = 0
        for k, ss in enumerate(seed.spawn(count)):
            sigma = share * math.sqrt(FLICKER_FAST) if k == 0 else share
            T = t_lo * r**k
            D = 1 << max(int(math.floor(math.log2(max(T * fs / 32.0, 1.0)))), 0)
            a = math.exp(-D / (fs * T))
            rng = np.random.default_rng(ss)
            g = {"D": D, "a": a, "b": sigma * math.sqrt(1.0 - a * a), "rng": rng, "q": -1}
            self.procs.append(dict(g, v=sigma * rng.standard_normal()))

    def take(self, length: int) -> np.ndarray:
        start = self.pos
        out = np.zeros(length)
        if length == 0:
            return out
        for g in self.procs:  # over the bank (about ten processes), each vectorized
            D, q_first, q_last = g["D"], start // g["D"], (start + length - 1) // g["D"]
            new = q_last - g["q"]
            if new > 0:
                y, _ = lfilter([g["b"]], [1.0, -g["a"]], g["rng"].standard_normal(new), zi=[g["a"] * g["v"]])
                vals = np.concatenate(([g["v"]], y)) if q_first == g["q"] else y
                g["q"], g["v"] = q_last, float(y[-1])
            else:
                vals = np.array([g["v"]])
            held = np.repeat(vals, D) if D > 1 else vals
            off = start - q_first * D
            out += held[off : off + length]
        self.pos += length
        return out
