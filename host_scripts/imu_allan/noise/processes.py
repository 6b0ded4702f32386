"""The catalogue of noise processes: each one knows its exact discrete-time
Allan variance at the sample rate, its PSD, how to simulate itself and what
it means in IEEE Std 952-1997 / Kalibr words.  A model is a sum
(``WN(N) + AR1(sigma, T) + RW(K)``), after the latent processes of GMWM
(Guerrier et al. 2013; the SMAC-Group ``simts`` / ``gmwm`` packages).

Rate samples y_i at fs (dt = 1/fs), in the channel's rate unit u.  The Allan
variance of cluster size m (tau = m dt) of a stationary process with
autocovariance r(k) is exact in closed form:

    S(m)    = sum_{|k| < m} (m - |k|) r(k)          variance of a sum of m samples
    AVAR(m) = (4 S(m) - S(2m)) / (2 m^2)

(the difference of two adjacent m-sums has variance 4 S(m) - S(2m)).  Where
r(k) = sum_i c_i p_i^|k| for k >= 1 (every ARMA process: the autoregressive
poles p_i), sum_{k=1}^{m-1} (m - k) p^k = p (m (1 - p) - (1 - p^m)) / (1 - p)^2
makes each tau O(1).  Non-stationary processes have their own exact forms
(random walk: q (2 m^2 + 1) / (6 m), simts' ``av_rw``).

PSDs are one-sided, u^2/Hz, at f in (0, fs/2] (the convention of psd.py).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

from . import averaging
from .filters import (
    arma_factor,
    butter4_autocov,
    filter_autocov,
    freq_response,
    lfilter,
    lowpass_filter,
    mean_pole_autocov,
)


def _m(m: ArrayLike) -> np.ndarray:
    return np.asarray(m, dtype=np.float64)


def _geo_sum(m: np.ndarray, p: complex | float) -> np.ndarray:
    """sum_{k=1}^{m-1} (m - k) p^k, vectorized over m (p real or complex, |p| < 1)."""
    if isinstance(p, complex):  # numpy's complex scalars too
        if p.imag == 0.0:
            p = float(p.real)
    elif np.iscomplexobj(p) and abs(np.imag(p)) == 0.0:
        p = float(np.real(p))
    with np.errstate(under="ignore"):
        pm = np.power(p, m)
    return p * (m * (1 - p) - (1 - pm)) / (1 - p) ** 2


def avar_from_poles(m: ArrayLike, r0: float, c: np.ndarray, p: np.ndarray) -> np.ndarray:
    """AVAR of a stationary sequence with r(0) = r0 and r(k) = sum c_i p_i^k (k >= 1)."""
    m = _m(m)
    if len(p) == 1 and not np.iscomplexobj(p):  # one real pole (RC, Gauss-Markov): the common case
        return real_pole_avar(m.ravel(), r0, float(c[0]), float(p[0])).reshape(m.shape)
    if len(p) == 1 and m.ndim == 1 and np.imag(p[0]) != 0.0:  # one complex pole: a resonance
        return complex_pole_avar(m, r0, c[0], complex(p[0]))
    mm = np.concatenate((m.ravel(), 2.0 * m.ravel()))  # S at m and 2m in one pass
    tot = mm * r0
    for ci, pi in zip(c, p):  # over the poles (one or two)
        if np.iscomplexobj(pi) and np.imag(pi) != 0.0:
            tot = tot + 2.0 * (ci * _geo_sum(mm, complex(pi))).real
        else:
            tot = tot + 2.0 * float(np.real(ci)) * _geo_sum(mm, float(np.real(pi)))
    S1, S2 = tot[: m.size].reshape(m.shape), tot[m.size :].reshape(m.shape)
    return (4.0 * S1 - S2) / (2.0 * m * m)


def real_pole_avar(m: np.ndarray, r0: float, c1: float, p1: float) -> np.ndarray:
    """avar_from_poles of one real pole (1-d float64 m), in place, with m's products kept (the
    fit asks for thousands of columns): 4 S(m) - S(2m) = 2 m r0 + 2 c p (2 m (1 - p) -
    (1 - p^m)(3 - p^m)) / (1 - p)^2, one power."""
    two_m, m_sq = _m_products(m)[:2]
    with np.errstate(under="ignore"):
        q = np.power(p1, m)
    d = 1.0 - p1
    g = two_m * d
    h = 1.0 - q
    q = np.subtract(3.0, q, out=q)
    h *= q
    g -= h
    g *= c1 * p1
    g /= d**2
    out = m * r0
    out += g
    out /= m_sq
    return out


def complex_pole_avar(m: np.ndarray, r0: float, c1: complex, p: complex) -> np.ndarray:
    """avar_from_poles of one complex pole p (1-d float64 m, p.imag != 0): the general loop's
    operations in the same order, without its conversions (a resonance's column)."""
    mm, two_m_sq = _m_products(m)[2:]
    with np.errstate(under="ignore"):
        pm = np.power(p, mm)
    geo = p * (mm * (1 - p) - (1 - pm)) / (1 - p) ** 2
    tot = mm * r0 + 2.0 * (c1 * geo).real
    n = m.size
    return (4.0 * tot[:n] - tot[n:]) / two_m_sq


_M_PRODUCTS: dict[bytes, tuple] = {}


def _m_products(m: np.ndarray) -> tuple:
    """(2 m, m m, [m, 2 m], 2 m m) of the cluster sizes m, kept (the fit asks for thousands of
    columns on the same taus)."""
    key = m.tobytes() + str(m.shape).encode()
    v = _M_PRODUCTS.get(key)
    if v is None:
        v = (2.0 * m, m * m, np.concatenate((m.ravel(), 2.0 * m.ravel())), 2.0 * m * m)
        for a in v:
            a.setflags(write=False)
        if len(_M_PRODUCTS) > 64:
            _M_PRODUCTS.clear()
        _M_PRODUCTS[key] = v
    return v


class Process:
    """One latent process.  Subclasses define ``params`` (name -> value),
    ``avar(m, fs)``, ``psd(f, fs)``, ``simulator(fs, n, seed)`` and ``meaning``."""

    name = "?"
    meaning = ""

    def __add__(self, other: "Process | Model") -> "Model":
        return Model([self]) + other

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def adev_at(self, tau: ArrayLike, fs: float) -> np.ndarray:
        """ADEV at tau (s), cluster sizes m = tau fs (rounded to at least 1)."""
        m = np.maximum(np.rint(np.asarray(tau, dtype=np.float64) * fs), 1.0)
        return np.sqrt(self.avar(m, fs))

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> "_Stream":
        raise NotImplementedError  # pragma: no cover

    def simulate(self, n: int, fs: float, seed: int | np.random.SeedSequence = 0) -> np.ndarray:
        """n samples at fs (seeded; the same as the blocks of ``simulator``)."""
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        return self.simulator(fs, n, ss).take(n)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"

    def params(self) -> dict[str, float]:  # pragma: no cover - abstract
        raise NotImplementedError


class _Stream:
    """Consecutive blocks of one process (``take(L)``), independent of the cutting."""

    def take(self, L: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


# ---- the processes ------------------------------------------------------------------------


@dataclass(repr=False)
class QN(Process):
    """Angle quantization Q [u s]: white angle noise, y_i = Q fs (e_i - e_{i-1}).
    AVAR = 3 Q^2 / tau^2 exactly at every m (IEEE 952 C.1)."""

    Q: float
    name = "Q"
    meaning = "angle (velocity) quantization noise Q: white noise of the integrated signal"

    def params(self) -> dict[str, float]:
        return {"Q": self.Q}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        m = _m(m)
        return 3.0 * (self.Q * fs) ** 2 / (m * m)

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        f = _m(f)
        return 2.0 * (self.Q * fs) ** 2 * 4.0 * np.sin(np.pi * f / fs) ** 2 / fs

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _Diff(self.Q * fs, np.random.default_rng(seed))


class _Diff(_Stream):
    def __init__(self, c: float, rng: np.random.Generator) -> None:
        self.c, self.rng, self.prev = c, rng, rng.standard_normal()

    def take(self, L: int) -> np.ndarray:
        e = self.rng.standard_normal(L)
        out = self.c * np.diff(np.concatenate(([self.prev], e)))
        if L:
            self.prev = float(e[-1])
        return out


@dataclass(repr=False)
class WN(Process):
    """White rate noise N [u sqrt(s)] (angle / velocity random walk, Kalibr's
    noise density): sigma per sample N sqrt(fs); AVAR = N^2 / tau exactly."""

    N: float
    name = "N"
    meaning = "white rate noise N (angle/velocity random walk; Kalibr noise_density)"

    def params(self) -> dict[str, float]:
        return {"N": self.N}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        return self.N**2 * fs / _m(m)

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        return np.full(np.shape(f), 2.0 * self.N**2)

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _White(self.N * math.sqrt(fs), np.random.default_rng(seed))


class _White(_Stream):
    def __init__(self, s: float, rng: np.random.Generator) -> None:
        self.s, self.rng = s, rng

    def take(self, L: int) -> np.ndarray:
        return self.s * self.rng.standard_normal(L)


FC_CEILING = {"pole": 0.49, "average": 0.49, "pole_mean": 5.0}
"""The highest cutoff (in fs) of each band-limit form the fit searches: a point sample of a
filter above fs / 2 is all but white (the spectrum folds flat), while a sample that averages
over its period still carries the filter's delay, 1.5 / (2 pi fc) tau under N's line in AVAR
(4.8 % at the first point and 2.4 % at the second for fc = 5 fs)."""


@functools.lru_cache(maxsize=4096)
def _lp_shape(fc: float, fs: float, order: int, shape: str = "pole") -> tuple:
    """(b, a, r0, c, p, scale): the filter and the autocovariance of its output, scale the
    input variance per unit N^2 (the low-frequency density of the output N^2)."""
    if shape == "pole_mean":  # continuous time, per unit density already: fc may pass fs / 2
        r0, c, p = mean_pole_autocov(fc, fs, order)
        return None, None, r0, c, p, 1.0  # b, a only to simulate (_filter): the fit needs r alone
    b, a = lowpass_filter(fc, fs, order)
    if order == 1:  # an AR(1): r(k) = r0 a1^k, r0 = b0^2 / (1 - a1^2), with real numbers
        a1 = -float(a[1])
        r0 = float(b[0]) ** 2 / (1.0 - a1 * a1)
        c, p = np.array([r0]), np.array([a1])
    elif order == 4:
        r0, c, p = butter4_autocov(fc, fs, b, a)
    else:
        r0, c, p = filter_autocov(b, a)
    dc = float(b.sum() / a.sum())  # unit white in -> low-frequency gain dc
    return b, a, r0, c, p, fs / dc**2


@dataclass(repr=False)
class LP(Process):
    """White rate noise through a one-, two- or four-pole low-pass of cutoff fc
    (band-limited white noise; ``shape`` "pole"), or through one or two cascaded
    averages (``shape`` "average", order the number of averages: 2 is the Bartlett
    window; averaging.py), or through a continuous RC or Butterworth whose output
    each sample averages over its period (``shape`` "pole_mean": integrate and dump,
    or a faster record averaged down; fc may lie above fs / 2, where the samples
    still show the filter's delay; filters.mean_pole_autocov): N [u sqrt(s)] is its
    LOW-FREQUENCY density in the samples (the level of the -1/2 line at long tau,
    what a navigation filter needs); below ~1/(2 pi fc) the curve bends under that line."""

    N: float
    fc: float
    order: int = 1
    shape: str = "pole"
    name = "LP"
    meaning = (
        "white rate noise through the sensor's low-pass (band-limited white): N is its "
        "low-frequency density, fc the cutoff"
    )

    def params(self) -> dict[str, float]:
        return {"N": self.N, "fc": self.fc, "order": self.order, "shape": self.shape}

    def _shape(self, fs: float) -> tuple:
        return _lp_shape(float(self.fc), float(fs), int(self.order), self.shape)

    def _acov(self, fs: float) -> np.ndarray:
        return averaging.average_autocov(float(self.fc), float(fs), int(self.order))

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        if self.shape == "average":
            return self.N**2 * averaging.avar_from_autocov(m, self._acov(fs))
        b, a, r0, c, p, scale = self._shape(fs)
        return self.N**2 * scale * avar_from_poles(m, r0, c, p)

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        if self.shape == "average":
            return self.N**2 * averaging.psd_from_autocov(f, fs, self._acov(fs))
        b, a, scale = self._filter(fs)
        h = freq_response(b, a, _m(f), fs)
        return 2.0 * self.N**2 * scale / fs * np.abs(h) ** 2

    def variance(self, fs: float) -> float:
        """Variance of the samples, u^2."""
        if self.shape == "average":
            return self.N**2 * float(self._acov(fs)[0])
        b, a, r0, c, p, scale = self._shape(fs)
        return self.N**2 * scale * r0

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        if self.shape == "average":  # the taps carry the whole scale (unit white in)
            b = averaging.ma_factor(self._acov(fs))
            return _Filtered(b, np.array([1.0]), self.N, np.random.default_rng(seed))
        b, a, scale = self._filter(fs)
        return _Filtered(b, a, self.N * math.sqrt(scale), np.random.default_rng(seed))

    def _filter(self, fs: float) -> tuple:
        """(b, a, scale): white noise of variance scale N^2 per sample through b/a is the process."""
        b, a, r0, c, p, scale = self._shape(fs)
        if b is None:
            b, a = arma_factor(r0, c, p)
        return b, a, scale


class _Filtered(_Stream):
    """Gaussian white noise through b/a, started stationary (a long warm-up)."""

    def __init__(self, b: np.ndarray, a: np.ndarray, s: float, rng: np.random.Generator) -> None:
        self.b, self.a, self.s, self.rng = b, a, s, rng
        zi = np.zeros(max(a.size, b.size) - 1)
        pmax = float(np.max(np.abs(np.roots(a)))) if a.size > 1 else 0.0
        warm = int(min(max(50.0 / max(1e-12, -math.log(max(pmax, 1e-12))), 16, b.size), 1 << 20))
        _, self.zi = lfilter(b, a, s * rng.standard_normal(warm), zi=zi)

    def take(self, L: int) -> np.ndarray:
        y, self.zi = lfilter(self.b, self.a, self.s * self.rng.standard_normal(L), zi=self.zi)
        return y


@dataclass(repr=False)
class AR1(Process):
    """First-order Gauss-Markov process (sigma [u], correlation time T [s]):
    AR(1) with phi = exp(-dt / T), stationary variance sigma^2; its ADEV peaks at
    tau = 1.89 T with 0.617 sigma (Kalibr: a bias whose T is longer than the
    record acts as a random walk K = sigma sqrt(2 / T))."""

    sigma: float
    T: float
    name = "GM"
    meaning = "Gauss-Markov (first-order) process: a correlated bias of sd sigma and time T"

    def params(self) -> dict[str, float]:
        return {"sigma": self.sigma, "T": self.T}

    def phi(self, fs: float) -> float:
        return math.exp(-1.0 / (fs * self.T))

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        ph = self.phi(fs)
        s2 = self.sigma**2
        return avar_from_poles(m, s2, np.array([s2]), np.array([ph]))

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        ph = self.phi(fs)
        w = 2.0 * np.pi * _m(f) / fs
        return 2.0 * self.sigma**2 * (1 - ph * ph) / (1 - 2 * ph * np.cos(w) + ph * ph) / fs

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _AR1(self.sigma, self.phi(fs), np.random.default_rng(seed))


class _AR1(_Stream):
    def __init__(self, sigma: float, phi: float, rng: np.random.Generator) -> None:
        self.phi, self.b, self.rng = phi, sigma * math.sqrt(1.0 - phi * phi), rng
        self.state = phi * sigma * rng.standard_normal()  # lfilter's zi: phi * a stationary x_{-1}

    def take(self, L: int) -> np.ndarray:
        y, zf = lfilter([self.b], [1.0, -self.phi], self.rng.standard_normal(L), zi=[self.state])
        self.state = float(zf[0])
        return y


@dataclass(repr=False)
class RW(Process):
    """Rate random walk K [u / sqrt(s)]: steps of sd K / sqrt(fs).  Exact
    discrete AVAR (K^2 / fs) (2 m^2 + 1) / (6 m) = K^2 tau / 3 + K^2 / (6 fs^2 tau)."""

    K: float
    name = "K"
    meaning = "rate random walk K (Kalibr random_walk; ADEV rising as tau^+1/2)"

    def params(self) -> dict[str, float]:
        return {"K": self.K}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        m = _m(m)
        return self.K**2 / fs * (2.0 * m * m + 1.0) / (6.0 * m)

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        return self.K**2 / (2.0 * np.pi**2 * _m(f) ** 2)

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _Walk(self.K / math.sqrt(fs), np.random.default_rng(seed))


class _Walk(_Stream):
    def __init__(self, s: float, rng: np.random.Generator) -> None:
        self.s, self.rng, self.x = s, rng, 0.0

    def take(self, L: int) -> np.ndarray:
        steps = np.cumsum(self.s * self.rng.standard_normal(L))
        out = self.x + steps
        if L:
            self.x = float(out[-1])
        return out


@dataclass(repr=False)
class Ramp(Process):
    """Rate ramp R [u / s] (a drift): AVAR = R^2 tau^2 / 2 exactly."""

    R: float
    name = "R"
    meaning = "rate ramp R (a steady drift)"

    def params(self) -> dict[str, float]:
        return {"R": self.R}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        t = _m(m) / fs
        return self.R**2 * t * t / 2.0

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        return self.R**2 / (2.0 * np.pi) ** 3 / _m(f) ** 3 * 2.0

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        return _Ramp(self.R / fs)


class _Ramp(_Stream):
    def __init__(self, step: float) -> None:
        self.step, self.i = step, 0

    def take(self, L: int) -> np.ndarray:
        out = self.step * np.arange(self.i, self.i + L, dtype=np.float64)
        self.i += L
        return out


@dataclass(repr=False)
class Sine(Process):
    """A sinusoid of amplitude A [u] and frequency f0 [Hz] (random phase):
    AVAR = A^2 sin^4(pi f0 m dt) / (m sin(pi f0 dt))^2, the continuous
    A^2 sin^4(pi f0 tau) / (pi f0 tau)^2 (ADEV peak at tau = 0.371 / f0) at fine dt."""

    A: float
    f0: float
    name = "S"
    meaning = "a sinusoid (vibration, a pump, a fan)"

    def params(self) -> dict[str, float]:
        return {"A": self.A, "f0": self.f0}

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        m = _m(m)
        x = np.pi * self.f0 / fs
        return self.A**2 * np.sin(x * m) ** 4 / (m * np.sin(x)) ** 2

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        f = _m(f)
        out = np.zeros(f.shape)
        if f.size:
            out[np.argmin(np.abs(f - self.f0))] = np.inf
        return out

    def simulator(self, fs: float, n: int, seed: np.random.SeedSequence) -> _Stream:
        ph = float(np.random.default_rng(seed).uniform(0, 2 * np.pi))
        return _SineStream(self.A, 2 * np.pi * self.f0 / fs, ph)


class _SineStream(_Stream):
    def __init__(self, A: float, w: float, ph: float) -> None:
        self.A, self.w, self.ph, self.i = A, w, ph, 0

    def take(self, L: int) -> np.ndarray:
        out = self.A * np.sin(self.w * np.arange(self.i, self.i + L) + self.ph)
        self.i += L
        return out


# ---- the sum ------------------------------------------------------------------------------


@dataclass
class Model:
    """A sum of independent processes: AVAR and PSD add; each process draws
    from its own random stream (adding one never changes the others)."""

    parts: list[Process] = field(default_factory=list)

    def __add__(self, other: "Process | Model") -> "Model":
        more = other.parts if isinstance(other, Model) else [other]
        return Model(self.parts + list(more))

    def __iter__(self):
        return iter(self.parts)

    def __repr__(self) -> str:
        return " + ".join(repr(p) for p in self.parts) or "Model()"

    def avar(self, m: ArrayLike, fs: float) -> np.ndarray:
        out = np.zeros(np.shape(m))
        for p in self.parts:
            out = out + p.avar(m, fs)
        return out

    def psd(self, f: ArrayLike, fs: float) -> np.ndarray:
        out = np.zeros(np.shape(f))
        for p in self.parts:
            out = out + p.psd(f, fs)
        return out

    def simulator(self, fs: float, n: int, seed: int | np.random.SeedSequence = 0) -> "ModelStream":
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        return ModelStream([p.simulator(fs, n, s) for p, s in zip(self.parts, ss.spawn(len(self.parts)))])

    def simulate(self, n: int, fs: float, seed: int | np.random.SeedSequence = 0) -> np.ndarray:
        return self.simulator(fs, n, seed).take(n)


@dataclass
class ModelStream:
    streams: list[_Stream]

    def take(self, L: int) -> np.ndarray:
        out = np.zeros(L)
        for s in self.streams:
            out += s.take(L)
        return out


def GM(sigma: float, T: float) -> AR1:
    """A Gauss-Markov process: the AR(1) of the catalogue."""
    return AR1(sigma, T)


def find(model: Model, kind: type) -> Optional[Process]:
    """The first process of ``kind`` in ``model`` (None if absent)."""
    return next((p for p in model.parts if isinstance(p, kind)), None)
