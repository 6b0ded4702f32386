"""Allan-family variances of rate samples, float64, vectorized.

Definitions (x: n rate samples at fs, tau = m / fs; X: the n + 1 partial
sums of x, X[0] = 0, i.e. the "phase" of NIST SP 1065 in sample units):

    overlapping AVAR   sum_i (X[i+2m] - 2 X[i+m] + X[i])^2 / (2 m^2 (n - 2m + 1)),  i = 0 .. n-2m
    non-overlapping    the same over i = 0, m, 2m, ...: floor(n/m) - 1 pairs (the device's statistic)
    modified AVAR      sum_j (sum_{i=j}^{j+m-1} X[i+2m] - 2 X[i+m] + X[i])^2 / (2 m^4 (n - 3m + 2))
    overlapping HVAR   sum_i (X[i+3m] - 3 X[i+2m] + 3 X[i+m] - X[i])^2 / (6 m^2 (n - 3m + 1))

exactly as allantools' ``oadev``, ``adev``, ``mdev``, ``ohdev`` compute them
from frequency data (checked to 1e-9 in the tests, and against the NBS
test values of NIST SP 1065).

Integer data (ADC codes) are handled in exact integer arithmetic up to the
squares: partial sums and differences are exact, only the final sums of
squares round. Float data have their first block's mean removed first.

Octave grids (every m a power of two) in memory go to the cache-blocked
kernels of kernels.py: the overlapping cascade of moving sums in two stages
(octave_oavar_sums) and the non-overlapping pair-sum cascade in chunks
(octave_avar_sums); pairwise sums keep them within ~1e-13 of an
extended-precision evaluation of the definitions (tests/test_octave_kernels.py).

``OctaveEngine`` is the streaming path: overlapping and non-overlapping AVAR
at m = 1, 2, 4, ... in one pass over blocks of any size, O(n) per level
(a pipelined cascade of moving sums y_{2m}[i] = y_m[i] + y_m[i+m] kept in
cache-sized blocks, with ring buffers for the levels longer than a block).
Levels up to ``exact_max`` are exact; above it (only for streams longer
than 2 * exact_max) the overlapping estimate uses the offsets that are
multiples of D = exact_max / 1024 (stride D instead of 1: the same
statistic with at least 2048 offsets per tau, its EDF computed for that
stride), so memory stays bounded for files larger than memory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterable, Optional

import numpy as np
from numpy.typing import ArrayLike

from ..progress import ProgressFn
from . import TAU_KINDS  # noqa: F401  (numpy-free in __init__.py, for the CLI parser)
from .kernels import DOT_MAX, HEAD, Windows, any_m_sums, octave_avar_sums, octave_oavar_sums, offset, rowdots
from .kernels import blocked as _blocked
from .kernels import sumsq as _ssq
from .kernels import sumsq_any as _sumsq

BLOCK = 1 << 16
EXACT_MAX = 1 << 22
STRIDE_OFFSETS = 1024
"""Above exact_max the overlapping estimate keeps 2 * exact_max / D >= this many offsets."""


# ---- tau grids -------------------------------------------------------------------


def tau_grid(kind: str, max_m: int, per_decade: int = 10) -> np.ndarray:
    """Cluster sizes m (int64, sorted, unique) up to ``max_m``.

    octave 1, 2, 4, ...; decade 1, 2, 4, 10, 20, 40, ... (Stable32 and
    allantools); log about ``per_decade`` per decade; all 1 .. max_m.
    """
    if max_m < 1:
        return np.zeros(0, dtype=np.int64)
    if kind == "octave":
        return 1 << np.arange(int(math.log2(max_m)) + 1, dtype=np.int64)
    if kind == "decade":
        out = [b * 10**k for k in range(int(math.log10(max_m)) + 1) for b in (1, 2, 4)]
        return np.array([m for m in out if m <= max_m], dtype=np.int64)
    if kind == "log":
        top = math.log10(max_m)
        m = np.unique(np.round(np.logspace(0, top, max(int(per_decade * top) + 1, 2))).astype(np.int64))
        return m[(m >= 1) & (m <= max_m)]
    if kind == "all":
        return np.arange(1, max_m + 1, dtype=np.int64)
    raise ValueError(f"unknown tau kind {kind!r} (one of {', '.join(TAU_KINDS)})")


def max_m(stat: str, n: int) -> int:
    """Largest m with at least one term: AVAR n - 2m + 1 >= 1 (n/2), HVAR and MVAR n/3."""
    return n // 2 if stat in ("oavar", "avar") else n // 3


# ---- in-memory statistics ----------------------------------------------------------


def _prepare(x: ArrayLike) -> np.ndarray:
    """Rate samples -> partial sums X (n + 1), int64 when x is integer-valued.

    Built chunk by chunk with the offset removed on the way, so the only
    array the size of the input is X itself (peak memory ~1x the input)."""
    a = np.asarray(x)
    if a.ndim != 1:
        raise ValueError("one channel at a time: x must be 1-D")
    integral = np.issubdtype(a.dtype, np.integer) or (a.dtype == np.float64 and a.size and _integral(a))
    dtype = np.int64 if integral else np.float64
    X = np.empty(a.size + 1, dtype=dtype)
    X[0] = 0
    if not a.size:
        return X
    off = offset(a[:BLOCK])
    off = int(off) if integral else float(off)
    carry = dtype(0)
    tmp = np.empty(min(a.size, 1 << 18), dtype=dtype)
    for s in range(0, a.size, tmp.size):
        e = min(s + tmp.size, a.size)
        t = tmp[: e - s]
        t[...] = a[s:e]  # widen first: unsigned codes must not wrap
        t -= off
        np.cumsum(t, out=X[s + 1 : e + 1])
        X[s + 1 : e + 1] += carry
        carry = X[e]
    return X


def _integral(a: np.ndarray) -> bool:
    return bool(np.all(np.abs(a) < 2**31)) and bool(np.all(a == np.rint(a)))


def oavar(x: ArrayLike, ms: Iterable[int], progress: ProgressFn = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping AVAR at each m; returns (avar, terms). nan where no term.

    Octave grids (every m a power of two) take the cache-blocked cascade of
    kernels.octave_oavar_sums; other grids the compiled phase kernel
    (kernels.any_m_sums) or, without it, the partial sums X."""
    return _avar_on_grid(x, ms, True, progress)


def avar(x: ArrayLike, ms: Iterable[int], progress: ProgressFn = None) -> tuple[np.ndarray, np.ndarray]:
    """Non-overlapping AVAR (floor(n/m) - 1 pairs) at each m; returns (avar, pairs).

    Octave grids take the chunked pair-sum cascade of kernels.octave_avar_sums."""
    return _avar_on_grid(x, ms, False, progress)


def _avar_on_grid(
    x: ArrayLike, ms: Iterable[int], overlapping: bool, progress: ProgressFn
) -> tuple[np.ndarray, np.ndarray]:
    """The one path of oavar and avar: octave cascade, compiled any-m, or partial sums."""
    m_a = np.asarray(list(ms), dtype=np.int64)
    if _octaves(m_a):
        return _octave(x, m_a, octave_oavar_sums if overlapping else octave_avar_sums)
    r = _any_m(x, m_a, overlapping=overlapping)
    if r is not None:
        return r
    return _second_diff(_prepare(x), m_a, overlapping=overlapping, progress=progress)


def _one_channel(x: ArrayLike) -> np.ndarray:
    a = np.asarray(x)
    if a.ndim != 1:
        raise ValueError("one channel at a time: x must be 1-D")
    if not (np.issubdtype(a.dtype, np.integer) or a.dtype == np.float64):
        a = a.astype(np.float64)
    return a


def _any_m(x: ArrayLike, ms: np.ndarray, overlapping: bool) -> Optional[tuple[np.ndarray, np.ndarray]]:
    """AVAR at any m from the compiled phase kernel; None without it."""
    a = _one_channel(x)
    n = a.size
    off = float(offset(a[:HEAD])) if n else 0.0
    sums = any_m_sums(a, off, ms, overlapping)
    if sums is None:
        return None
    m = np.maximum(ms, 1)
    cnt = np.where(ms >= 1, (n - 2 * m + 1) if overlapping else (n // m - 1), 0)
    cnt = np.maximum(cnt, 0)
    out = np.full(ms.size, np.nan)
    ok = cnt > 0
    mf = ms[ok].astype(np.float64)
    out[ok] = sums[ok] / (2.0 * mf * mf * cnt[ok])
    return out, cnt.astype(np.int64)


def _octaves(ms: np.ndarray) -> bool:
    return bool(ms.size) and bool(np.all((ms > 0) & ((ms & (ms - 1)) == 0)))


def _octave(x: ArrayLike, ms: np.ndarray, kernel) -> tuple[np.ndarray, np.ndarray]:
    """The octave kernel's sums at every level, picked at ``ms``."""
    a = _one_channel(x)
    off = float(offset(a[:HEAD])) if a.size else 0.0
    sums, count = kernel(a, off)
    k = np.log2(ms).astype(np.int64)
    have = k < sums.size
    out = np.full(ms.size, np.nan)
    cnt = np.zeros(ms.size, dtype=np.int64)
    kk = k[have]
    cnt[have] = np.maximum(count[kk], 0)
    ok = have.copy()
    ok[have] = count[kk] > 0
    m = ms[ok].astype(np.float64)
    out[ok] = sums[k[ok]] / (2.0 * m * m * count[k[ok]])
    return out, cnt


def _per_m(
    X: np.ndarray, ms: np.ndarray, progress: ProgressFn, one: Callable[[int, int], Optional[tuple[float, int]]]
) -> tuple[np.ndarray, np.ndarray]:
    """The one loop over cluster sizes behind every statistic here: ``one(n, m)``
    gives (variance, terms) at m, or None where m is too long for n + 1 phase points."""
    n = X.size - 1
    out = np.full(ms.size, np.nan)
    count = np.zeros(ms.size, dtype=np.int64)
    for j, m in enumerate(ms.tolist()):
        if progress:
            progress(j)
        r = one(n, m)
        if r is not None:
            out[j], count[j] = r
    return out, count


def _second_diff(
    X: np.ndarray, ms: np.ndarray, overlapping: bool, progress: ProgressFn
) -> tuple[np.ndarray, np.ndarray]:
    """AVAR (NIST SP 1065 eq. 11, 12) from second differences of the phase X."""

    def one(n: int, m: int) -> Optional[tuple[float, int]]:
        if overlapping:
            c = n - 2 * m + 1
            if c < 1:
                return None
            s = _blocked(c, lambda a, b: _sumsq(X[a + 2 * m : b + 2 * m] - 2 * X[a + m : b + m] + X[a:b]))
        else:
            c = n // m - 1
            if c < 1:
                return None
            P = X[::m]
            s = _sumsq(P[2 : c + 2] - 2 * P[1 : c + 1] + P[:c])
        return s / (2.0 * m * m * c), c

    return _per_m(X, ms, progress, one)


def mvar(x: ArrayLike, ms: Iterable[int], progress: ProgressFn = None) -> tuple[np.ndarray, np.ndarray]:
    """Modified AVAR at each m (allantools' mdev algorithm, NIST SP 1065 eq. 14); returns (mvar, terms)."""
    X = _prepare(x)

    def one(n: int, m: int) -> Optional[tuple[float, int]]:
        e = n + 1 - 3 * m  # third differences of X
        if e < 0:
            return None
        v0 = (X[2 * m : 3 * m] - 2 * X[m : 2 * m] + X[0:m]).sum()
        s = float(v0) * float(v0)
        carry = v0
        for a in range(0, e, 1 << 18):  # cumulative sums with a carry across chunks
            b = min(a + (1 << 18), e)
            w = X[a + 3 * m : b + 3 * m] - 3 * X[a + 2 * m : b + 2 * m] + 3 * X[a + m : b + m] - X[a:b]
            v = np.cumsum(w)
            v += carry
            carry = v[-1]
            s += _sumsq(v)
        return s / (2.0 * float(m) ** 4 * (e + 1)), e + 1

    return _per_m(X, np.asarray(list(ms), dtype=np.int64), progress, one)


def ohvar(x: ArrayLike, ms: Iterable[int], progress: ProgressFn = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Hadamard variance at each m (NIST SP 1065 eq. 17); returns (hvar, terms)."""
    X = _prepare(x)

    def one(n: int, m: int) -> Optional[tuple[float, int]]:
        c = n + 1 - 3 * m
        if c < 1:
            return None
        s = _blocked(
            c,
            lambda a, b: _sumsq(
                X[a + 3 * m : b + 3 * m] - 3 * X[a + 2 * m : b + 2 * m] + 3 * X[a + m : b + m] - X[a:b]
            ),
        )
        return s / (6.0 * m * m * c), c

    return _per_m(X, np.asarray(list(ms), dtype=np.int64), progress, one)


# ---- streaming octave engine -----------------------------------------------------------


@dataclass
class OctaveResult:
    """Per level k (m = 2^k) and channel: overlapping and non-overlapping AVAR."""

    n: int
    ms: np.ndarray  # (levels,)
    oavar: np.ndarray  # (levels, channels); nan without terms
    terms: np.ndarray  # (levels,) second differences behind oavar
    stride: np.ndarray  # (levels,) 1 exact, D for the strided levels
    avar: np.ndarray  # (levels, channels) non-overlapping; nan without pairs
    pairs: np.ndarray  # (levels,) floor(n/m) - 1 (or fewer, strided levels)


@dataclass
class _Level:
    m: int
    buf: np.ndarray  # (channels, m + B): linear [tail m | block] or a ring
    ring: bool
    acc: np.ndarray = field(default_factory=lambda: np.zeros(0))
    acc_n: np.ndarray = field(default_factory=lambda: np.zeros(0))
    views: dict = field(default_factory=dict)  # cached per-channel views of the steady state

    @property
    def cap(self) -> int:
        return self.buf.shape[1]


class OctaveEngine:
    """Streaming overlapping + non-overlapping octave AVAR of several channels.

    ``push(block)`` takes (channels, samples) of any length (any dtype; integer
    codes stay exact); ``finish()`` returns an ``OctaveResult``. The result
    does not depend on how the stream was cut.
    """

    def __init__(
        self,
        channels: int,
        exact_max: Optional[int] = EXACT_MAX,
        block: Optional[int] = None,
        total: Optional[int] = None,
        nonoverlapping: bool = True,
        _offset: Optional[np.ndarray] = None,
    ) -> None:
        if channels < 1:
            raise ValueError("channels must be positive")
        self.C = channels
        if block is None:  # short known streams: smaller blocks, less buffer memory
            block = BLOCK if total is None else int(min(BLOCK, max(4096, 1 << int(math.log2(max(total, 1) / 32)))))
        self.B = block
        self.exact_max = exact_max
        self.total = total
        self.nonoverlapping = nonoverlapping
        self.n = 0
        self._pending: list[np.ndarray] = []
        self._pending_n = 0
        self._levels: list[_Level] = []
        self._x0: Optional[np.ndarray] = _offset
        self._tmp = np.empty((channels, block))
        self._finished = False
        self._coarse: Optional[OctaveEngine] = None
        self._D = 0
        if exact_max is not None:
            self._D = max(1, (2 * exact_max) // (2 * STRIDE_OFFSETS))
            self._dcarry = np.zeros((channels, 0))

    # -- input --
    def push(self, block: ArrayLike) -> None:
        if self._finished:
            raise RuntimeError("push after finish")
        a = np.asarray(block)
        if a.ndim != 2 or a.shape[0] != self.C:
            raise ValueError(f"block must have shape ({self.C}, samples)")
        if not a.shape[1]:
            return
        if self._x0 is None:  # an offset keeps the sums small; integral data keep an integer one
            self._x0 = offset(a[:, : self.B])
        if self._D and (self.total is None or self.total > 2 * self.exact_max):  # type: ignore[operator]
            self._decimate(a.astype(np.float64) - self._x0[:, None])
        i = 0
        L = a.shape[1]
        if self._pending_n:  # complete the pending block first
            take = min(self.B - self._pending_n, L)
            self._pending.append(a[:, :take])
            self._pending_n += take
            i = take
            if self._pending_n == self.B:
                self._block(np.concatenate(self._pending, axis=1))
                self._pending, self._pending_n = [], 0
        while L - i >= self.B:
            self._block(a[:, i : i + self.B])
            i += self.B
        if i < L:
            self._pending.append(a[:, i:].copy())
            self._pending_n += L - i

    def _decimate(self, a: np.ndarray) -> None:
        """Non-overlapping sums of D samples, fed to the coarse engine (strided levels)."""
        buf = np.concatenate((self._dcarry, a), axis=1) if self._dcarry.shape[1] else a
        full = buf.shape[1] - buf.shape[1] % self._D
        if full:
            sums = buf[:, :full].reshape(self.C, -1, self._D).sum(axis=2)
            if self._coarse is None:
                self._coarse = OctaveEngine(self.C, exact_max=None, block=self.B, _offset=np.zeros(self.C))
            self._coarse.push(sums)
        self._dcarry = buf[:, full:].copy()

    def finish(self) -> OctaveResult:
        if not self._finished:
            if self._pending_n:
                self._block(np.concatenate(self._pending, axis=1))
            self._pending = []
            self._finished = True
            self._coarse_result = self._coarse.finish() if self._coarse is not None else None
        return self._result()

    # -- the cascade --
    def _new_level(self, k: int) -> Optional[_Level]:
        m = 1 << k
        if self.exact_max is not None and m > self.exact_max:
            return None
        ring = m >= self.B
        lv = _Level(m, np.zeros((self.C, m + self.B)), ring)
        lv.acc = np.zeros(self.C)
        lv.acc_n = np.zeros(self.C)
        return lv

    def _block(self, x: np.ndarray) -> None:
        """One block of samples through every level (each vectorized over the block)."""
        s, L = self.n, x.shape[1]
        self.n += L
        if not self._levels:
            self._levels.append(self._new_level(0))  # type: ignore[arg-type]
        B, C, tmp = self.B, self.C, self._tmp
        k = 0
        while k < len(self._levels):
            lv = self._levels[k]
            m, W = lv.m, lv.buf
            if lv.ring:
                cap = lv.cap
                newpos, apos = s % cap, (s - m) % cap
            else:
                newpos, apos = m, 0
            if k == 0:  # the samples, offset removed
                for c in range(C):
                    np.subtract(x[c], self._x0[c], out=W[c, newpos : newpos + L])  # type: ignore[index]
            start = 2 * m - 1 - s
            up = self._levels[k + 1] if k + 1 < len(self._levels) else None
            uppos = ((s % up.cap) if up.ring else up.m) if up is not None else 0
            if L == B and start < 0:  # steady state: cached views, fewest calls
                key = (newpos, uppos, up is not None)
                views = lv.views.get(key)
                if views is None:
                    views = lv.views[key] = self._views(lv, up, newpos, apos, uppos, tmp)
                t0 = (2 * m - 1 - s) % m
                for c, (a_c, b_c, z_c, z2_c, up_c) in enumerate(views):
                    np.subtract(b_c, a_c, out=z_c)
                    o = float(rowdots(z2_c).sum())
                    lv.acc[c] += o
                    if m == 1:
                        lv.acc_n[c] += o
                    elif self.nonoverlapping and t0 < L:
                        lv.acc_n[c] += _ssq(z_c[t0::m])
                    if up_c is not None:
                        np.add(a_c, b_c, out=up_c)
                if not lv.ring:
                    W[:, :m] = W[:, L : L + m]
                k += 1
                continue
            a = W[:, apos : apos + L]
            b = W[:, newpos : newpos + L]
            # block column t holds y_k[j], j = s - m + 1 + t; pairs (j - m, j) need j - m >= 0
            if start < L:
                start = max(start, 0)
                t0 = (2 * m - 1 - s) % m  # non-overlapping: j - m = i a multiple of m
                if t0 < start:
                    t0 += m * (-(-(start - t0) // m))
                for c in range(C):  # over channels; 1-D contiguous rows are fastest
                    z = np.subtract(b[c], a[c], out=tmp[c, :L])
                    zz = z[start:]
                    o = _ssq(zz)
                    lv.acc[c] += o
                    if m == 1:
                        lv.acc_n[c] += o
                    elif t0 < L and self.nonoverlapping:
                        lv.acc_n[c] += _ssq(z[t0::m])
                if k + 1 == len(self._levels) and (self.total is None or 2 * m <= self.total // 2):
                    nxt = self._new_level(k + 1)
                    if nxt is not None:
                        self._levels.append(nxt)
                        up = nxt
                        uppos = (s % up.cap) if up.ring else up.m
            if up is not None:
                for c in range(C):
                    np.add(a[c], b[c], out=up.buf[c, uppos : uppos + L])
            if not lv.ring:
                for c in range(C):
                    W[c, :m] = W[c, L : L + m]
            k += 1

    def _views(
        self, lv: _Level, up: Optional[_Level], newpos: int, apos: int, uppos: int, tmp: np.ndarray
    ) -> list[tuple[np.ndarray, ...]]:
        B = self.B
        out = []
        for c in range(self.C):
            z = tmp[c]
            z2 = z.reshape(-1, DOT_MAX) if B % DOT_MAX == 0 else z[None, :]
            out.append(
                (
                    lv.buf[c, apos : apos + B],
                    lv.buf[c, newpos : newpos + B],
                    z,
                    z2,
                    up.buf[c, uppos : uppos + B] if up is not None else None,
                )
            )
        return out

    def _result(self) -> OctaveResult:
        n = self.n
        levels = max(int(math.log2(n // 2)) + 1, 0) if n >= 2 else 0
        ms = 1 << np.arange(levels, dtype=np.int64)
        ov = np.full((levels, self.C), np.nan)
        nv = np.full((levels, self.C), np.nan)
        terms = np.zeros(levels, dtype=np.int64)
        pairs = np.zeros(levels, dtype=np.int64)
        stride = np.ones(levels, dtype=np.int64)
        coarse = getattr(self, "_coarse_result", None)
        for k in range(levels):
            m = int(ms[k])
            if k < len(self._levels):
                lv = self._levels[k]
                terms[k] = n - 2 * m + 1
                pairs[k] = n // m - 1
                if terms[k] > 0:
                    ov[k] = lv.acc / (2.0 * m * m * terms[k])
                if pairs[k] > 0:
                    nv[k] = lv.acc_n / (2.0 * m * m * pairs[k])
            elif coarse is not None:
                r = m // self._D
                kc = int(math.log2(r))
                if kc < coarse.ms.size:
                    D2 = float(self._D) ** 2
                    terms[k], stride[k] = coarse.terms[kc], self._D
                    pairs[k] = coarse.pairs[kc]
                    ov[k] = coarse.oavar[kc] / D2
                    nv[k] = coarse.avar[kc] / D2
        keep = terms > 0
        return OctaveResult(n, ms[keep], ov[keep], terms[keep], stride[keep], nv[keep], pairs[keep])


def octave_oavar(x: ArrayLike, exact_max: Optional[int] = None, nonoverlapping: bool = True) -> OctaveResult:
    """One channel or (channels, n) in memory through the engine (exact at every level)."""
    a = np.asarray(x)
    a2 = a[None, :] if a.ndim == 1 else a
    eng = OctaveEngine(a2.shape[0], exact_max=exact_max, total=a2.shape[1], nonoverlapping=nonoverlapping)
    eng.push(a2)
    return eng.finish()


def octave_mapped(x: ArrayLike, nonoverlapping: bool = True, windows: Optional[Windows] = None) -> OctaveResult:
    """One channel too large for memory, e.g. ``np.load(path, mmap_mode="r")`` of an
    .npy file: overlapping (and non-overlapping) AVAR at m = 1, 2, 4 ... n/2,
    exact at every octave (every offset, stride 1), with O(1) extra memory.

    The compiled kernel reads the mapping in place: the levels below 2^14 in
    cache-sized tiles, each level above as one running second difference
    d_m(i+1) = d_m(i) + x[i+2m] - 2 x[i+m] + x[i] (long double; exact for
    integer codes) advancing over the file with three pointers. Without the
    compiled kernels this falls back to the in-memory kernels (a buffer the
    size of the input). ``windows``: their sums from the same pass (kernels.Windows;
    compiled kernels only)."""
    a = np.asarray(x)
    if a.ndim != 1:
        raise ValueError("one channel at a time: x must be 1-D")
    n = a.size
    off = float(offset(a[:HEAD])) if n else 0.0
    acc, _ = octave_oavar_sums(a, off, stream=True, windows=windows)
    return octave_from_sums(n, acc, octave_avar_sums(a, off)[0] if nonoverlapping else None)


def octave_from_sums(n: int, acc: np.ndarray, nacc: Optional[np.ndarray]) -> OctaveResult:
    """The octave result of one channel of n samples from the kernels' sums of
    squares per level: overlapping ``acc``, non-overlapping ``nacc`` (None: not computed)."""
    levels = acc.size
    ms = 1 << np.arange(levels, dtype=np.int64)
    terms = n - 2 * ms + 1
    ov = (acc / (2.0 * ms * ms * np.maximum(terms, 1)))[:, None]
    pairs = n // ms - 1
    if nacc is not None:
        nv = np.where(pairs > 0, nacc / (2.0 * ms * ms * np.maximum(pairs, 1)), np.nan)[:, None]
    else:
        nv = np.full((levels, 1), np.nan)
    return OctaveResult(n, ms, ov, terms, np.ones(levels, dtype=np.int64), nv, pairs)


def oadev_octave(x: ArrayLike, fs: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(taus, overlapping ADEV) at m = 1, 2, 4 ... n/2 of one channel: the fast path.

    Same values as ``allantools.oadev(x, rate=fs, data_type="freq", taus="octave")``.
    """
    a = np.asarray(x, dtype=np.float64)
    ms = 1 << np.arange(max(int(math.log2(a.size // 2)) + 1, 0) if a.size >= 2 else 0, dtype=np.int64)
    v, _ = oavar(a, ms)
    return ms / float(fs), np.sqrt(v)
