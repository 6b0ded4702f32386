"""The one noise simulator: a rate signal made of the IEEE 952 / thesis noise
processes, sample by sample, independent of how the stream is cut in blocks.

Per sample i (dt = 1/fs), in the unit of the signal:

    white_i   = white * N(0,1)                       angle/velocity random walk (N = white / sqrt(fs))
    bias_i    = a bias_{i-1} + gm_sigma sqrt(1 - a^2) N(0,1),  a = exp(-dt / gm_tau)
                                                     first-order Gauss-Markov bias (starts stationary)
    walk_i    = walk_{i-1} + rrw * N(0,1)            rate random walk (K = rrw * sqrt(fs))
    flicker_i = a bank of Gauss-Markov processes     1/f bias instability of coefficient B (below)
    quant_i   = Q fs (e_i - e_{i-1}),  e ~ N(0,1)     white angle noise (quantization-like, Q)
    ramp_i    = R i dt                               rate ramp (drift)

Each process draws from its own random stream, so adding a process never
changes the others.  Used by ``imu-allan gen`` (stats/gen.py: offset, clip to
10-bit codes) and by the thesis model of ``analyze`` (stats/model.py).

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
from scipy.signal import lfilter


@dataclass
class NoiseParams:
    """One channel's processes, in the unit u of the signal (0: absent)."""
    white: float = 0.0       # sigma per sample, u
    gm_sigma: float = 0.0    # stationary sigma of the Gauss-Markov bias, u
    gm_tau: float = 1.0      # its correlation time, s
    rrw: float = 0.0         # sigma of each random-walk step, u
    flicker: float = 0.0     # IEEE 952 B, u
    quant: float = 0.0       # Q, u*s
    ramp: float = 0.0        # R, u/s


class NoiseProcess:
    """``add_to(x, start)`` adds samples start .. start + len(x) - 1 of the
    noise to ``x`` in place; call it on consecutive blocks.  Each process has
    its own generator (``white_rng`` ...); ``flicker_seed`` spawns the
    flicker bank's; ``n`` (the record length) sets the bank's slowest time."""

    def __init__(self, p: NoiseParams, fs: float, n: int, white_rng: np.random.Generator,
                 gm_rng: np.random.Generator, rrw_rng: np.random.Generator,
                 quant_rng: Optional[np.random.Generator] = None,
                 flicker_seed: Optional[np.random.SeedSequence] = None) -> None:
        self.p, self.fs = p, fs
        self.dt = 1.0 / fs
        self._rw, self._rg, self._rk, self._rq = white_rng, gm_rng, rrw_rng, quant_rng
        self._a = float(np.exp(-self.dt / p.gm_tau)) if p.gm_sigma else 0.0
        self._b = float(p.gm_sigma * np.sqrt(-np.expm1(-2.0 * self.dt / p.gm_tau))) if p.gm_sigma else 0.0
        # lfilter's zi: a * (a stationary bias before sample 0)
        self._gm_state = self._a * p.gm_sigma * gm_rng.standard_normal() if p.gm_sigma else 0.0
        self._walk = 0.0
        self._q_prev = quant_rng.standard_normal() if p.quant and quant_rng is not None else 0.0
        self._flicker = (Flicker(p.flicker, fs, n, flicker_seed)
                         if p.flicker and flicker_seed is not None else None)

    def add_to(self, x: np.ndarray, start: int) -> None:
        p, L = self.p, x.shape[0]
        if p.white:
            x += p.white * self._rw.standard_normal(L)
        if p.gm_sigma:
            y, zf = lfilter([self._b], [1.0, -self._a], self._rg.standard_normal(L), zi=[self._gm_state])
            self._gm_state = float(zf[0])
            x += y
        if p.rrw:
            steps = np.cumsum(p.rrw * self._rk.standard_normal(L))
            x += self._walk + steps
            self._walk += float(steps[-1])
        if self._flicker is not None:
            x += self._flicker.take(start, L)
        if p.quant and self._rq is not None:
            e = self._rq.standard_normal(L)
            x += p.quant * self.fs * np.diff(np.concatenate(([self._q_prev], e)))
            self._q_prev = float(e[-1])
        if p.ramp:
            x += p.ramp * (np.arange(start, start + L) * self.dt)


FLICKER_SPACING = 8.0
"""Ratio of consecutive correlation times of the flicker bank."""


class Flicker:
    """Flicker rate noise of IEEE 952 coefficient B, sample by sample,
    independent of how the stream is cut: each Gauss-Markov process of the
    bank has its own random stream, drawn once per coarse step."""

    def __init__(self, b: float, fs: float, n: int, seed: np.random.SeedSequence) -> None:
        r = FLICKER_SPACING
        t_lo, t_hi = 1.0 / fs, max(4.0 * n / fs, 8.0 / fs)
        count = int(math.ceil(math.log(t_hi / t_lo) / math.log(r))) + 1
        sigma = b * math.sqrt(math.log(r) / math.pi)
        self.procs = []
        for k, ss in enumerate(seed.spawn(count)):
            T = t_lo * r ** k
            D = 1 << max(int(math.floor(math.log2(max(T * fs / 32.0, 1.0)))), 0)
            a = math.exp(-D / (fs * T))
            rng = np.random.default_rng(ss)
            self.procs.append({"D": D, "a": a, "b": sigma * math.sqrt(1.0 - a * a), "rng": rng,
                               "q": -1, "v": sigma * rng.standard_normal()})

    def take(self, start: int, length: int) -> np.ndarray:
        out = np.zeros(length)
        for g in self.procs:  # over the bank (about ten processes), each vectorized
            D, q_first, q_last = g["D"], start // g["D"], (start + length - 1) // g["D"]
            new = q_last - g["q"]
            if new > 0:
                y, _ = lfilter([g["b"]], [1.0, -g["a"]], g["rng"].standard_normal(new),
                               zi=[g["a"] * g["v"]])
                vals = np.concatenate(([g["v"]], y)) if q_first == g["q"] else y
                g["q"], g["v"] = q_last, float(y[-1])
            else:
                vals = np.array([g["v"]])
            held = np.repeat(vals, D) if D > 1 else vals
            off = start - q_first * D
            out += held[off:off + length]
        return out
