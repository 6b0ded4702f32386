"""The thesis' noise processes as streams of the noise catalogue (imu_allan.noise),
sample by sample, independent of how the stream is cut in blocks.

Per sample i (dt = 1/fs), in the unit of the signal:

    white_i   = white * N(0,1)                       angle/velocity random walk (N = white / sqrt(fs))
    bias_i    = a bias_{i-1} + gm_sigma sqrt(1 - a^2) N(0,1),  a = exp(-dt / gm_tau)
                                                     first-order Gauss-Markov bias (starts stationary)
    walk_i    = walk_{i-1} + rrw * N(0,1)            rate random walk (K = rrw * sqrt(fs))
    flicker_i = a bank of Gauss-Markov processes     1/f bias instability of coefficient B (below)
    quant_i   = Q fs (e_i - e_{i-1}),  e ~ N(0,1)     white angle noise (quantization-like, Q)
    ramp_i    = R i dt                               rate ramp (drift)

Each process draws from its own random stream, so adding a process never
changes the others.  Used by ``imu-allan gen`` (noise/gen.py: offset, clip to
10-bit codes) and by the thesis model of ``analyze`` (noise/model.py).

Flicker (IEEE 952 B; Allan deviation floor 0.664 B): Gauss-Markov processes
with correlation times T_k = 8^k / fs up to 4 times the record, each of
variance B^2 ln 8 / pi, so that their PSDs add up to the flicker PSD
B^2 / (pi f) (one-sided) and the Allan deviation stays within 1.5 % of
0.664 B from 4/fs to a quarter of the record (7 % and 2 % high at 1/fs and
2/fs, where the fastest process, sampled rather than averaged, adds a
little).  The slow ones are drawn once every T_k fs / 32 samples and held
(their share of the variance at shorter taus is negligible), so the cost is
that of about two full-rate processes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass
class NoiseParams:
    """One channel's processes, in the unit u of the signal (0: absent)."""

    white: float = 0.0  # sigma per sample, u
    gm_sigma: float = 0.0  # stationary sigma of the Gauss-Markov bias, u
    gm_tau: float = 1.0  # its correlation time, s
    rrw: float = 0.0  # sigma of each random-walk step, u
    flicker: float = 0.0  # IEEE 952 B, u
    quant: float = 0.0  # Q, u*s
    ramp: float = 0.0  # R, u/s


class NoiseProcess:
    """``add_to(x, start)`` adds samples start .. start + len(x) - 1 of the
    noise to ``x`` in place; call it on consecutive blocks.  Each process is a
    stream of the noise catalogue (imu_allan.noise: WN, AR1, RW, Flicker, QN,
    Ramp) with its own generator (``white_rng`` ...); ``flicker_seed`` spawns
    the flicker bank's; ``n`` (the record length) sets the bank's slowest time."""

    def __init__(
        self,
        p: NoiseParams,
        fs: float,
        n: int,
        white_rng: np.random.Generator,
        gm_rng: np.random.Generator,
        rrw_rng: np.random.Generator,
        quant_rng: Optional[np.random.Generator] = None,
        flicker_seed: Optional[np.random.SeedSequence] = None,
    ) -> None:
        from . import processes as cat

        self.p, self.fs = p, fs
        self.model = cat.Model()
        self.streams = []
        if p.white:
            self.model += cat.WN(p.white / math.sqrt(fs))
            self.streams.append(cat._White(p.white, white_rng))
        if p.gm_sigma:
            gm = cat.AR1(p.gm_sigma, p.gm_tau)
            self.model += gm
            self.streams.append(cat._AR1(p.gm_sigma, gm.phi(fs), gm_rng))
        if p.rrw:
            self.model += cat.RW(p.rrw * math.sqrt(fs))
            self.streams.append(cat._Walk(p.rrw, rrw_rng))
        if p.flicker and flicker_seed is not None:
            from .flicker import Flicker as Bank

            fl = Bank(p.flicker)
            self.model += fl
            self.streams.append(fl.simulator(fs, n, flicker_seed))
        if p.quant and quant_rng is not None:
            self.model += cat.QN(p.quant)
            self.streams.append(cat._Diff(p.quant * fs, quant_rng))
        if p.ramp:
            self.model += cat.Ramp(p.ramp)
            self.streams.append(cat._Ramp(p.ramp / fs))
        self.done = 0

    def add_to(self, x: np.ndarray, start: int) -> None:
        if start != self.done:
            raise ValueError(f"blocks must be consecutive: expected sample {self.done}, got {start}")
        for st in self.streams:  # over the processes, each vectorized
            x += st.take(x.shape[0])
        self.done += x.shape[0]


class Flicker:
    """Flicker rate noise of IEEE 952 coefficient B: the catalogue's bank
    (imu_allan.noise.Flicker), ``take(start, length)`` on consecutive blocks."""

    def __init__(self, b: float, fs: float, n: int, seed: np.random.SeedSequence) -> None:
        from .flicker import Flicker as Bank

        self._bank = Bank(b).simulator(fs, n, seed)
        self._done = 0

    def take(self, start: int, length: int) -> np.ndarray:
        if start != self._done:
            raise ValueError(f"blocks must be consecutive: expected sample {self._done}, got {start}")
        self._done += length
        return self._bank.take(length)
