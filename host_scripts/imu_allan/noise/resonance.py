"""A resonance of the catalogue: a mechanical mode (the mount, the case, the
proof mass's suspension) rung by the broadband vibration of the bench, seen by
an accelerometer as a narrow band of noise around the mode's frequency.

The process is the exponentially damped cosine of the narrow-band noise
(Rice 1944, section 3.7; Papoulis, "Probability, Random Variables and
Stochastic Processes", 4th ed., section 9.3): a sinusoid of frequency f0 whose
amplitude and phase wander with the correlation time T (two quadrature
Gauss-Markov processes),

    r(t) = sigma^2 exp(-|t| / T) cos(2 pi f0 t)

its spectrum two Lorentzians at +-f0 of half width 1 / (2 pi T) (quality
factor Q = pi f0 T, the peak's frequency over its full width at half height).
Sampled at fs it is the real part of a complex AR(1) with the pole
p = exp(-dt / T + 2 pi i f0 dt), so r(k) = sigma^2 Re(p^k): its Allan variance
is exact through processes.avar_from_poles.  Over a short tau (< T) it acts
as a sinusoid of amplitude sigma sqrt(2), over a long one as a white noise of
density sigma^2 T / (1 + (2 pi f0 T)^2) (u^2 s per half of N^2): a resonance
sitting under an Allan curve's -1/2 line raises its short taus only, which a
white level fitted there would otherwise take.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .filters import lfilter
from .processes import Process, _m, _Stream, avar_from_poles


@dataclass(repr=False)
class Resonance(Process):
    """Narrow-band noise of sd ``sigma`` [u] around ``f0`` [Hz], correlation time ``T`` [s]."""

    sigma: float
    f0: float
    T: float
    name = "RES"
    meaning = "a resonance (a mechanical mode rung by the bench's vibration): narrow-band noise around f0"

    def params(self) -> dict[str, float]:
        return {"sigma": self.sigma, "f0": self.f0, "T": self.T}

    def quality(self) -> float:
        """Q = pi f0 T: the peak's frequency over its full width at half height."""
        return math.pi * self.f0 * self.T

    def pole(self, fs: float) -> complex:
        return complex(math.exp(-1.0 / (fs * self.T)) * np.exp(2j * math.pi * self.f0 / fs))

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        s2 = self.sigma**2
        return avar_from_poles(m, s2, np.array([complex(s2)]), np.array([self.pole(fs)]))

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        a = math.exp(-1.0 / (fs * self.T))
        w, w0 = 2.0 * np.pi * _m(f) / fs, 2.0 * math.pi * self.f0 / fs
        lor = sum((1 - a * a) / (1 - 2 * a * np.cos(w - s * w0) + a * a) for s in (1.0, -1.0))
        return self.sigma**2 * lor / fs

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _ComplexAR1(self.sigma, self.pole(fs), np.random.default_rng(seed))


class _ComplexAR1(_Stream):
    """z_k = p z_(k-1) + e_k, e circular Gaussian; the real part is the resonance."""

    def __init__(self, sigma: float, p: complex, rng: np.random.Generator) -> None:
        self.p, self.rng = p, rng
        self.s = sigma * math.sqrt(1.0 - abs(p) ** 2)  # sd of each quadrature of e
        self.z = complex(sigma * rng.standard_normal(), sigma * rng.standard_normal())  # stationary start

    def take(self, L: int) -> np.ndarray:
        e = self.s * (self.rng.standard_normal(L) + 1j * self.rng.standard_normal(L))
        z, zf = lfilter([1.0], [1.0, -self.p], e, zi=[self.p * self.z])
        if L:
            self.z = complex(z[-1])
        return np.real(z)
