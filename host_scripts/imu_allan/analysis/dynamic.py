"""Dynamic Allan variance: the deviation window by window, and whether each
window departs from the rest of the record (docs/dynamic.md).

Two sources of windows:

* **device reports** (``from_reports``): the device's ``L`` rows are
  cumulative since the last accumulator reset, so the difference of two
  successive reports of one run, ``acc_B - acc_A`` over ``pairs_B - pairs_A``,
  is the exact integer sum of the non-overlapping Allan pairs completed
  between them (pairs pA+1 .. pB: clusters pA .. pB, samples pA*m to
  (pB+1)*m).  A report lost on the radio makes one window longer; a reset
  (a new run ``id``, ``n`` or a pair count going down) starts over.
* **raw samples** (``from_samples``): sliding windows (half a window apart
  by default), the overlapping estimator of ``stats/allan.py`` in each.

``assess`` tests every window against the pooled rest: at each tau the ratio
of the window's variance to the pooled variance of the reference windows
(those that do not depart, none overlapping the window) is F-distributed
with the two EDFs (Greenhall's, ``stats/edf.py``) under the hypothesis that
nothing changed; a window departs on a channel when any of its taus has a
two-sided p-value below the Sidak level that keeps the whole channel's
false-alarm rate at half of ``1 - level`` over all windows and taus tested,
or when it is the first window and a tau's one-sided p-value (more variance)
is below the Sidak level over that window's taus alone at the other half
(``WARMUP_SHARE``: the power for a weak warm-up).  The
warm-up is there when the leading windows depart; it ends where the transient
fitted over them has settled (transient.py), not where they stop departing.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

from ..channels import CHANNELS
from ..device.records import FLAG_RANGE, FLAG_SAT, DeviceReport, LRow
from ..stats import allan, dist, edf

LEVEL = 0.95
"""Confidence of the departure test, per channel over the whole record (family-wise)."""
MIN_PAIRS = 8
"""A device window's level is tested only with at least this many pairs (the device's B rule)."""
MIN_EDF = 4.0
"""... and any window's tau only with at least this EDF."""
RAW_WINDOWS = 16
"""Default raw window: the record split in this many windows, slid by half a window."""
MAX_WINDOWS = 2000
"""At most this many raw windows (each costs a pass over its samples)."""
MIN_EFFECT = 0.05
"""A point departs only when its deviation also differs from the reference's by
more than this fraction: with 1e5 degrees of freedom a 1 % change is
significant, but it does not matter to any term (real sensors show such drifts
at short tau all along; a warm-up is larger)."""
WARMUP_SHARE = 0.5
"""The share of the false-alarm budget ``1 - level`` spent on the warm-up's own
test (the first window alone, one-sided: ``_first_window``); the rest goes to
the test of every window.  Their union is flagged with probability at most ``1 - level``."""
TEMP_MOVE = 2.0
"""Temperature-binned curves when the windows' mean temperature codes span more than this."""


@dataclass
class Windows:
    """Per window w, channel c, octave level l: the Allan variance (code^2 or input
    units^2), its pooling weight (pairs or terms), its EDF; nan where none."""

    source: str  # "device reports" or "raw samples"
    fs: float
    channels: list[str]
    ms: np.ndarray  # (L,) cluster sizes
    t0: np.ndarray  # (W,) s since the run's start
    t1: np.ndarray
    temp: list[Optional[dict]]  # {"mean", "min", "max"} codes, or None
    var: np.ndarray  # (W, C, L)
    weight: np.ndarray  # (W, C, L)
    edf: np.ndarray  # (W, C, L)
    whole: np.ndarray  # (C, L) the whole record's variance
    overlap: float = 0.0  # fraction of a window shared with the next one
    acc: Optional[list] = None  # device: [w][c][l] exact integer sums (None where none)
    pairs: Optional[np.ndarray] = None  # device: (W, C, L) pairs of each window
    notes: list[str] = field(default_factory=list)

    @property
    def taus(self) -> np.ndarray:
        return self.ms / self.fs

    def overlaps(self, i: int, j: int) -> bool:
        return i == j or (self.t0[i] < self.t1[j] and self.t0[j] < self.t1[i] and self.overlap > 0)


# ---- windows from the device's reports -------------------------------------------------


def new_run(a: DeviceReport, b: DeviceReport) -> bool:
    """Whether report ``b`` starts a run other than ``a``'s (a reset in between)."""
    ida, idb = a.header.extra.get("id"), b.header.extra.get("id")
    if ida is not None and idb is not None and ida != idb:
        return True
    if b.header.n < a.header.n or b.header.fs_hz != a.header.fs_hz or b.header.levels != a.header.levels:
        return True
    before = {(r.channel, r.level): r.pairs for r in a.rows}
    return any(r.pairs < before.get((r.channel, r.level), 0) for r in b.rows)


def runs(reports: Sequence[DeviceReport]) -> list[list[DeviceReport]]:
    """The reports cut into runs (a reset starts a new one), in order."""
    out: list[list[DeviceReport]] = []
    for r in reports:
        if not out or new_run(out[-1][-1], r):
            out.append([])
        out[-1].append(r)
    return out


def _cumulative(rep: DeviceReport, chans: list[str], L: int) -> tuple[list, np.ndarray, np.ndarray]:
    acc = [[0] * L for _ in chans]
    pairs = np.zeros((len(chans), L), dtype=np.int64)
    bad = np.zeros((len(chans), L), dtype=bool)
    for r in rep.rows:
        if r.channel in chans and r.level < L:
            c = chans.index(r.channel)
            acc[c][r.level] = r.acc
            pairs[c, r.level] = r.pairs
            bad[c, r.level] = bool(r.flags & (FLAG_SAT | FLAG_RANGE))
    return acc, pairs, bad


def from_reports(reports: Sequence[DeviceReport], channels: Optional[Sequence[str]] = None) -> Windows:
    """One window per report of one run: the report minus the one before it
    (the first: minus nothing, i.e. from the reset).  Exact integers."""
    if not reports:
        raise ValueError("no report")
    h = reports[0].header
    chans = list(channels or CHANNELS)
    L, fs = h.levels, float(h.fs_hz)
    ms = np.array([1 << k for k in range(L)], dtype=np.int64)
    W, C = len(reports), len(chans)
    var = np.full((W, C, L), np.nan)
    pairs_w = np.zeros((W, C, L), dtype=np.int64)
    accs: list = []
    prev_acc, prev_pairs, prev_bad = [[0] * L for _ in chans], np.zeros((C, L), np.int64), np.zeros((C, L), bool)
    t0, t1, temps = np.zeros(W), np.zeros(W), []
    prev_n = 0
    for w, rep in enumerate(reports):
        acc, pairs, bad = _cumulative(rep, chans, L)
        dp = pairs - prev_pairs
        row = []
        for c in range(C):
            cells = []
            for k in range(L):
                d = acc[c][k] - prev_acc[c][k]
                ok = dp[c, k] > 0 and not bad[c, k] and not prev_bad[c, k]
                cells.append(d if ok else None)
                if ok:  # exact integers, one correctly rounded division
                    var[w, c, k] = d / (2 * int(ms[k]) ** 2 * int(dp[c, k]))
            row.append(cells)
        accs.append(row)
        pairs_w[w] = dp
        t0[w], t1[w] = prev_n / fs, rep.header.n / fs
        temps.append(rep.header.temp)
        prev_acc, prev_pairs, prev_bad, prev_n = acc, pairs, bad, rep.header.n
    last_acc, last_pairs, last_bad = _cumulative(reports[-1], chans, L)
    whole = np.full((C, L), np.nan)
    for c in range(C):
        for k in range(L):
            if last_pairs[c, k] and not last_bad[c, k]:
                whole[c, k] = last_acc[c][k] / (2 * int(ms[k]) ** 2 * int(last_pairs[c, k]))
    alphas = _alphas(whole, ms)
    edfs = np.full((W, C, L), np.nan)
    for w in range(W):
        for c in range(C):
            for k in range(L):
                p = int(pairs_w[w, c, k])
                if p > 0 and math.isfinite(var[w, c, k]):
                    edfs[w, c, k] = _edf(int(alphas[c, k]), int(ms[k]), (p + 1) * int(ms[k]) + 1, int(ms[k]))
    return Windows(
        "device reports", fs, chans, ms, t0, t1, temps, var, pairs_w.astype(np.float64), edfs, whole, 0.0, accs, pairs_w
    )


# ---- windows from raw samples ----------------------------------------------------------


def from_samples(
    data: np.ndarray,
    fs: float,
    channels: Sequence[str],
    window_s: Optional[float] = None,
    step_s: Optional[float] = None,
    temp: Optional[np.ndarray] = None,
) -> Windows:
    """Sliding windows over (channels, n) samples; the overlapping AVAR at the
    octave taus that hold at least about ten clusters in a window."""
    from .store import MemoryStore

    return from_store(MemoryStore(np.asarray(data, dtype=np.float64)), fs, channels, window_s, step_s, temp)


def raw_windows(
    n: int, fs: float, window_s: Optional[float] = None, step_s: Optional[float] = None
) -> tuple[np.ndarray, int, int]:
    """(starts, size, step) of ``from_store``'s windows over n samples (an analysis
    plans them before its pass: store.Store.windows)."""
    size = int(round(window_s * fs)) if window_s else n // RAW_WINDOWS
    size = min(max(size, 32), n)
    step = max(int(round(step_s * fs)), 1) if step_s else max(size // 2, 1)
    if (n - size) // step + 1 > MAX_WINDOWS:
        from ..errors import InputError

        raise InputError(f"{(n - size) // step + 1} windows: more than {MAX_WINDOWS}; give a longer --window or --step")
    return np.array(list(range(0, n - size + 1, step)) or [0], dtype=np.int64), size, step


def from_store(
    store: Any,
    fs: float,
    channels: Sequence[str],
    window_s: Optional[float] = None,
    step_s: Optional[float] = None,
    temp: Optional[np.ndarray] = None,
) -> Windows:
    """``from_samples`` of an analysis' store (store.py: memory or files), one
    window of one channel in memory at a time; the whole record's curve from
    the store's octave kernels."""
    C, n = store.channels, store.n
    starts, size, step = raw_windows(n, fs, window_s, step_s)
    ms = np.array([1 << k for k in range(40) if (1 << k) * 10 <= size], dtype=np.int64)
    W, L = len(starts), ms.size
    var, weight, edfs = (np.full((W, C, L), np.nan) for _ in range(3))
    whole = np.full((C, L), np.nan)
    for c in range(C):
        r = store.octave(c)
        whole[c] = r.oavar[np.searchsorted(r.ms, ms), 0]
    alphas = _alphas(whole, ms)
    terms = size - 2 * ms + 1

    def channel(c: int) -> None:  # the kernels release the GIL: channels side by side
        sums = store.window_sums(c, starts, size)  # taken by the record's own pass, when planned
        for w, a in enumerate(starts.tolist()):
            if sums is not None:
                var[w, c], weight[w, c] = sums[np.log2(ms).astype(np.int64), w] / (2.0 * ms * ms * terms), terms
            else:
                var[w, c], weight[w, c] = allan.oavar(store.read(c, a, size).astype(np.float64), ms)

    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max(1, min(2, os.cpu_count() or 1))) as pool:
        list(pool.map(channel, range(C)))
    temps: list[Optional[dict]] = []
    for w, a in enumerate(starts.tolist()):
        for c in range(C):
            edfs[w, c] = [_edf(int(alphas[c, k]), int(ms[k]), size + 1, 1) for k in range(L)]
        if temp is not None and temp.size >= a + size:
            t = temp[a : a + size]
            temps.append({"mean": round(float(t.mean()), 1), "min": int(t.min()), "max": int(t.max())})
        else:
            temps.append(None)
    t0 = starts.astype(np.float64) / fs
    return Windows(
        "raw samples",
        fs,
        list(channels),
        ms,
        t0,
        t0 + size / fs,
        temps,
        var,
        weight,
        edfs,
        whole,
        1.0 - step / size if step < size else 0.0,
    )


def device_reports_from_rows(
    codes: np.ndarray, fs: float, every: int, levels: int = 15, channels: Sequence[str] = CHANNELS
) -> list[DeviceReport]:
    """The reports the device would send every ``every`` samples of (channels, n)
    integer codes, with the exact cumulative ``acc`` and ``pairs`` of its
    ``L`` rows (no flags): the host's emulation, for tests and the docs."""
    from ..device.records import DeviceHeader
    from ..stats.kernels import exact_sumsq

    codes = np.asarray(codes, dtype=np.int64)
    C, n = codes.shape
    csum = np.concatenate((np.zeros((C, 1), np.int64), np.cumsum(codes, axis=1)), axis=1)
    out = []
    for seq, end in enumerate(range(every, n + 1, every)):
        rows = []
        for c in range(C):
            for k in range(levels):
                m = 1 << k
                nclu = end // m
                if nclu < 2:
                    rows.append(LRow(channels[c], k, 0, 0, 0))
                    continue
                s = csum[c, m : nclu * m + 1 : m] - csum[c, 0 : (nclu - 1) * m + 1 : m]
                rows.append(LRow(channels[c], k, nclu - 1, exact_sumsq(np.diff(s)[None, :])[0], 0))
        head = DeviceHeader(
            1,
            None,
            None,
            None,
            None,
            fs,
            levels,
            None,
            end,
            0,
            None,
            None,
            True,
            "allan",
            None,
            None,
            None,
            seq,
            {"id": "0"},
        )
        out.append(DeviceReport(seq, head, rows))
    return out


# ---- EDF and noise type ------------------------------------------------------------------


@functools.lru_cache(maxsize=65536)
def _edf(alpha: int, m: int, N: int, stride: int) -> float:
    try:
        e = edf.edf_greenhall(alpha, 2, m, N, stride=stride)
    except (ValueError, ZeroDivisionError, OverflowError):
        e = math.nan
    if not (math.isfinite(e) and e > 0):
        e = max((N - 1 - 2 * m) // stride + 1, 1) * stride / (3 * m)
    if m == 1:  # Greenhall's sums overstate it there (by 20 % for white noise, measured):
        e = min(e, (N - 2) / 1.5)  # the N - 2 differences of white noise, correlated -1/2
    return float(max(e, 1.0))


def _alphas(whole: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Noise type alpha at each tau from the whole record's local slope."""
    out = np.zeros(whole.shape, dtype=np.int64)
    lm = np.log(ms.astype(np.float64))
    for c in range(whole.shape[0]):
        v = whole[c]
        ok = np.isfinite(v) & (v > 0)
        for k in range(ms.size):
            nb = [j for j in (k - 1, k + 1) if 0 <= j < ms.size and ok[j]]
            if not ok[k] or not nb:
                continue
            lo, hi = min(nb + [k]), max(nb + [k])
            mu = (math.log(v[hi]) - math.log(v[lo])) / (lm[hi] - lm[lo])
            out[c, k] = edf.alpha_from_slope(mu)
    return out


# ---- the departure test ------------------------------------------------------------------


@dataclass
class Verdict:
    level: float
    p: np.ndarray  # (W, C, L) two-sided p-values, nan where untested
    threshold: np.ndarray  # (C,) the per-point level (Sidak over the points tested)
    hit: np.ndarray  # (W, C, L) the points that depart (p below it, effect above MIN_EFFECT)
    departs: np.ndarray  # (W, C) bool
    ref_var: np.ndarray  # (W, C, L) the pooled reference each window was tested against
    warmup_s: dict[str, Optional[float]]
    stationary: dict[str, bool]
    tau_range_s: dict[str, Optional[tuple[float, float]]]
    """Taus at which windows after the warm-up depart (None: none)."""
    iterations: int = 0
    transient: dict[str, Any] = field(default_factory=dict)
    """Per channel: how the warm-up's end was found (transient.Transient, or None)."""
    lead_threshold: Optional[np.ndarray] = None
    """(C,) the first window's own test's per-point level (one-sided; nan: untested)."""


def assess(ws: Windows, level: float = LEVEL) -> Verdict:
    """Test every window against the pooled rest (module docstring)."""
    W, C, L = ws.var.shape
    p = np.full((W, C, L), np.nan)
    ref_var = np.full((W, C, L), np.nan)
    departs = np.zeros((W, C), dtype=bool)
    thr = np.zeros(C)
    lead_thr = np.full(C, np.nan)
    hit = np.zeros((W, C, L), dtype=bool)
    tested = np.isfinite(ws.var) & (ws.edf >= MIN_EDF)
    if ws.source == "device reports":
        tested &= ws.weight >= MIN_PAIRS
    mid = 0.5 * (ws.t0.min() + ws.t1.max()) if W else 0.0
    iterations = 0
    for c in range(C):
        K = int(tested[:, c].sum())
        thr[c] = _sidak((1.0 - level) * (1.0 - WARMUP_SHARE), K) if K else 0.0
        later = (ws.t0 + ws.t1) / 2 >= mid  # the reference: the later half (a sensor settles, it does
        ref = later  # not unsettle), less the windows of it that depart
        for it in range(20):
            iterations = max(iterations, it + 1)
            for w in range(W):
                _test_window(ws, w, c, ref, tested, p, ref_var)
            with np.errstate(invalid="ignore", divide="ignore"):
                big = np.abs(np.log(ws.var[:, c] / ref_var[:, c])) > 2 * math.log1p(MIN_EFFECT)
            hit[:, c] = tested[:, c] & (np.nan_to_num(p[:, c], nan=1.0) < thr[c]) & big
            if W:
                up = (ws.var[0, c] > ref_var[0, c]) & big[0]
                first, lead_thr[c] = _first_window(up, p[0, c], tested[0, c], level)
                hit[0, c] |= first
            dep = hit[:, c].any(axis=1)
            departs[:, c] = dep
            new = later & ~dep
            if not new.any() or np.array_equal(new, ref):
                break
            ref = new
    warm, stat, taus, fits = {}, {}, {}, {}
    with np.errstate(invalid="ignore", divide="ignore"):
        excess = ws.var / ref_var - 1.0
    for c, ch in enumerate(ws.channels):
        fits[ch] = _transient(ws, c, departs[:, c], excess[:, c], tested[:, c], hit[:, c])
        warm[ch], stat[ch], taus[ch] = _warmup(ws, departs[:, c], hit[:, c], fits[ch])
    return Verdict(level, p, thr, hit, departs, ref_var, warm, stat, taus, iterations, fits, lead_thr)


def _sidak(alpha: float, k: int) -> float:
    """The per-point level of k independent tests that together reject with probability alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / k)


def _first_window(up: np.ndarray, p: np.ndarray, tested: np.ndarray, level: float) -> tuple[np.ndarray, float]:
    """The warm-up's own test: the first window alone, one-sided (a warm-up adds
    variance: a drift its slope squared, a settling noise its own; ``up``: above
    the reference by more than MIN_EFFECT), Sidak over its taus at
    ``WARMUP_SHARE`` of ``1 - level``.  Its hits (L,) and per-point level.
    Only the first window: a fixed sequence of windows each at this level
    would need no more correction, but it ran past the warm-up's end (2 of 20
    runs of 30 s device reports, up to 67 % late: one window in forty departs
    by chance at this level)."""
    k = int(tested.sum())
    if not k:
        return np.zeros(p.shape, dtype=bool), math.nan
    thr = _sidak((1.0 - level) * WARMUP_SHARE, k)
    one_sided = np.where(up, 0.5 * np.nan_to_num(p, nan=2.0), 1.0)
    return tested & up & (one_sided < thr), thr


def _test_window(
    ws: Windows, w: int, c: int, ref: np.ndarray, tested: np.ndarray, p: np.ndarray, ref_var: np.ndarray
) -> None:
    others = [j for j in range(len(ws.t0)) if ref[j] and not ws.overlaps(w, j)]
    if not others:
        p[w, c] = np.nan
        return
    v, wt, e = ws.var[others, c], ws.weight[others, c], ws.edf[others, c]
    ok = np.isfinite(v) & np.isfinite(e)
    num = np.where(ok, v * wt, 0.0).sum(axis=0)
    den = np.where(ok, wt, 0.0).sum(axis=0)
    e_ref = np.where(ok, e, 0.0).sum(axis=0) * (1.0 - ws.overlap)
    with np.errstate(invalid="ignore", divide="ignore"):
        pooled = num / den
    ref_var[w, c] = pooled
    sel = tested[w, c] & (den > 0) & (e_ref >= MIN_EDF) & (pooled > 0)
    out = np.full(ws.ms.size, np.nan)
    if sel.any():
        ratio = ws.var[w, c, sel] / pooled[sel]
        d1, d2 = ws.edf[w, c, sel], e_ref[sel]
        lo, hi = dist.f_cdf(ratio, d1, d2), dist.f_sf(ratio, d1, d2)
        out[sel] = np.minimum(2.0 * np.minimum(lo, hi), 1.0)
    p[w, c] = out


def _stretch(dep: np.ndarray) -> int:
    """The last window of the leading stretch of departing windows (one calm
    window inside it bridged); -1 when the first window does not depart."""
    W = dep.size
    last = -1
    i = 0
    while i < W:
        if dep[i]:
            last = i
            i += 1
        elif last >= 0 and i + 1 < W and dep[i + 1]:
            i += 1
        else:
            break
    return last


def _transient(ws: Windows, c: int, dep: np.ndarray, excess: np.ndarray, tested: np.ndarray, hits: np.ndarray) -> Any:
    """The warm-up's end fitted over the windows (transient.py), when a
    stretch departs, windows follow it and none departs in the record's later
    half: a channel whose settled part departs is not one transient settling
    (a sensor whose oscillations come and go), and its stretch's end stands."""
    from .transient import warmup_end

    last = _stretch(dep)
    mid = 0.5 * (ws.t0.min() + ws.t1.max())
    if last < 0 or last + 1 >= dep.size or (dep & (ws.t0 >= max(mid, ws.t1[last]))).any():
        return None
    return warmup_end(ws.t0, ws.t1, excess, ws.edf[:, c], tested, hits, last, ws.overlap)


def _warmup(
    ws: Windows, dep: np.ndarray, hits: np.ndarray, fit: Any = None
) -> tuple[Optional[float], bool, Optional[tuple[float, float]]]:
    """The warm-up's end, in s: the transient's fitted end (``fit``), else
    where the leading stretch of departing windows ends; whether nothing
    departs after it; the taus at which later windows depart."""
    W = dep.size
    last = _stretch(dep)
    warm = None
    if last >= 0 and last + 1 < W:
        warm = fit.end_s if fit is not None else float(ws.t0[last + 1])
    start = max(ws.t1[last], warm or 0.0) if last >= 0 else -1
    after = [w for w in range(last + 1, W) if dep[w] and ws.t0[w] >= start]
    if last == W - 1 and W:
        after = list(range(W))  # departs throughout: no settled part to compare with
    stationary = not after
    taus = None
    if after:
        hit = np.zeros(ws.ms.size, dtype=bool)
        for w in after:
            hit |= hits[w]
        if hit.any():
            t = ws.taus[hit]
            taus = (float(t.min()), float(t.max()))
    return warm, stationary, taus


def temperature_bins(ws: Windows, move: float = TEMP_MOVE) -> list[dict]:
    """When the windows' mean temperature spans more than ``move`` codes: the
    pooled variance of the windows in each ``move``-wide temperature bin."""
    means = np.array([t["mean"] if t else np.nan for t in ws.temp], dtype=np.float64)
    ok = np.isfinite(means)
    if ok.sum() < 2 or np.ptp(means[ok]) <= move:
        return []
    lo = math.floor(means[ok].min() / move) * move
    out = []
    for b in np.arange(lo, means[ok].max() + move, move):
        sel = ok & (means >= b) & (means < b + move)
        if not sel.any():
            continue
        v, wt = ws.var[sel], ws.weight[sel]
        good = np.isfinite(v)
        with np.errstate(invalid="ignore", divide="ignore"):
            pooled = np.where(good, v * wt, 0).sum(axis=0) / np.where(good, wt, 0).sum(axis=0)
        out.append({"temp": [float(b), float(b + move)], "windows": int(sel.sum()), "var": pooled})
    return out


__all__ = [
    "Windows",
    "Verdict",
    "from_reports",
    "from_samples",
    "runs",
    "new_run",
    "assess",
    "temperature_bins",
    "device_reports_from_rows",
    "LEVEL",
    "TEMP_MOVE",
]
