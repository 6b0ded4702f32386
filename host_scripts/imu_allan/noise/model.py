"""The thesis' noise model, built from identified terms, simulated; and FIT%.

The thesis (section 6, after Petkov & Slavov) models each sensor as

    x = bias + rrw + white
    bias[k+1] = a bias[k] + b w[k],  a = exp(-dt / T)      (Gauss-Markov)
    rrw[k+1]  = rrw[k] + sigma_K w'[k]                     (rate random walk)
    white[k]  = sigma_N w''[k]                              (angle/velocity random walk)

From the IEEE 952 terms (rate unit u, dt = 1/fs):
    sigma_N = N sqrt(fs)            white noise per sample
    sigma_K = K / sqrt(fs)          random walk step
    GM: the Allan deviation of a first-order Gauss-Markov process of
        stationary sigma peaks at tau = 1.8926 T with value 0.6174 sigma; the
        model puts that peak on the bias-instability floor 0.664 B:
            sigma_GM = 0.664 B / 0.6174 = 1.0755 B,   T = tau_B / 1.8926
        with tau_B the geometric centre of the tau range where B dominates
        (else the tau of the Allan deviation's minimum).
    Q and R, outside the thesis' model, are added when identified: white
        angle noise (Q (e[k] - e[k-1]) fs) and a ramp R t.
A single Gauss-Markov process reproduces a flicker floor only within about
a factor 2 around its peak (0.8 T .. 4.2 T within 10 %); that is the
model's limit, and FIT% shows it.

FIT% (thesis, after Meruane 2008):  FIT = (1 - ||x_sensor - x_model|| / ||x_sensor||) * 100.
What it measures depends on x:
  * on the two time series (the slide's formula with k = 1..L) it compares
    two independent noises of equal power: ||x_s - x_m|| ~ sqrt(2) ||x_s||,
    FIT ~ -41 % for a perfect model; it cannot give the thesis' 98.6 %;
  * on log10 of the Allan deviation curves (the thesis' likely use, like its
    98.5 % everywhere), ||log x_s|| grows with how far the values are from 1
    in the chosen unit, so the number depends on the unit: in deg/s and
    m/s^2 (values 1e-3 .. 1) a 10 % error everywhere already scores ~98 %;
  * ``nrmse`` variants divide by ||x_s - mean(x_s)|| instead (MATLAB's
    ``compare``/``goodnessOfFit``), which is unit-free: 100 % perfect, 0 % no
    better than a constant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterator, Optional

import numpy as np
from numpy.typing import ArrayLike

from .streams import NoiseParams, NoiseProcess

GM_PEAK_X = 1.8926176
"""tau / T at the maximum of a Gauss-Markov process's Allan deviation."""
GM_PEAK_ADEV = 0.6173643
"""That maximum, per unit stationary sigma."""
B_FLOOR = 0.6642824702679406
"""ADEV of flicker rate noise per unit B: sqrt(2 ln 2 / pi)."""
CHUNK = 1 << 17


@dataclass
class ModelParams:
    fs: float
    white: float = 0.0  # sigma per sample, u
    gm_sigma: float = 0.0  # u
    gm_tau: float = 1.0  # s
    rrw: float = 0.0  # u per step
    quant: float = 0.0  # Q, u*s
    ramp: float = 0.0  # R, u/s

    def as_dict(self) -> dict[str, float]:
        return {
            "white_sigma": self.white,
            "gm_sigma": self.gm_sigma,
            "gm_tau_s": self.gm_tau,
            "rrw_sigma": self.rrw,
            "Q": self.quant,
            "R": self.ramp,
        }


def gm_avar(tau: ArrayLike, sigma: float, T: float) -> np.ndarray:
    """Allan variance of a continuous first-order Gauss-Markov process."""
    x = np.asarray(tau, dtype=np.float64) / T
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    v = (2.0 / xs) * (1.0 - (3.0 - 4.0 * np.exp(-xs) + np.exp(-2.0 * xs)) / (2.0 * xs))
    return sigma * sigma * np.where(small, 2.0 * x / 3.0, v)


def from_terms(values: dict[str, Optional[float]], fs: float, tau_b: Optional[float]) -> ModelParams:
    """The thesis model of identified terms (None or 0: absent)."""
    N, B, K = values.get("N") or 0.0, values.get("B") or 0.0, values.get("K") or 0.0
    p = ModelParams(
        fs=fs, white=N * math.sqrt(fs), rrw=K / math.sqrt(fs), quant=values.get("Q") or 0.0, ramp=values.get("R") or 0.0
    )
    if B and tau_b:
        p.gm_sigma = B_FLOOR * B / GM_PEAK_ADEV
        p.gm_tau = tau_b / GM_PEAK_X
    return p


def simulate(p: ModelParams, n: int, seed: int = 0, chunk: int = CHUNK) -> Iterator[np.ndarray]:
    """The model's samples, in blocks (1-D float64), independent of the chunking
    (the one simulator of noise.py, one random stream per process)."""
    rw, rg, rk, rq = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4))
    proc = NoiseProcess(
        NoiseParams(white=p.white, gm_sigma=p.gm_sigma, gm_tau=p.gm_tau, rrw=p.rrw, quant=p.quant, ramp=p.ramp),
        p.fs,
        n,
        white_rng=rw,
        gm_rng=rg,
        rrw_rng=rk,
        quant_rng=rq,
    )
    done = 0
    while done < n:
        x = np.zeros(min(chunk, n - done))
        proc.add_to(x, done)
        yield x
        done += x.size


def fit_percent(sensor: ArrayLike, model: ArrayLike) -> Optional[float]:
    """The thesis' FIT: (1 - ||s - m|| / ||s||) * 100."""
    s, m = np.asarray(sensor, dtype=np.float64), np.asarray(model, dtype=np.float64)
    ok = np.isfinite(s) & np.isfinite(m)
    if not ok.any():
        return None
    den = float(np.linalg.norm(s[ok]))
    return None if den == 0 else (1.0 - float(np.linalg.norm(s[ok] - m[ok])) / den) * 100.0


def fit_nrmse(sensor: ArrayLike, model: ArrayLike) -> Optional[float]:
    """Unit-free: (1 - ||s - m|| / ||s - mean(s)||) * 100 (MATLAB compare)."""
    s, m = np.asarray(sensor, dtype=np.float64), np.asarray(model, dtype=np.float64)
    ok = np.isfinite(s) & np.isfinite(m)
    if ok.sum() < 2:
        return None
    den = float(np.linalg.norm(s[ok] - s[ok].mean()))
    return None if den == 0 else (1.0 - float(np.linalg.norm(s[ok] - m[ok])) / den) * 100.0
