"""Spikes and short bursts (a knock on the bench) found before the statistics.

A recording at rest is noise; a spike (one wild sample: an ADC glitch, a bit
error) or a burst (the bench knocked: a second of large swings on every axis)
is not, and a few of them move the short-tau Allan variance, hence N, a lot:
one spike of amplitude A adds about A^2/n to the variance at tau0 = 1/fs.

The method (a Hampel-type identifier, Hampel 1974; Pearson 2002, "Outliers
in process modeling and identification", IEEE Trans. Control Syst. Technol.
10(1), on first differences; MAD scale as in Rousseeuw & Croux 1993, JASA 88):

1. Per channel, the first differences d[i] = x[i+1] - x[i] (a spike makes two
   large ones of opposite sign, a burst a run of them; a slow drift or a
   random walk makes none) and their robust scale
   s = 1.4826 * median(|d - median(d)|), the standard deviation of d if d were
   Gaussian, unmoved by up to half the differences being wild.
   Quantized data (ADC codes): the median of rounded values is read with the
   grouped-data interpolation (values spread evenly over their rounding cell),
   else a quiet channel whose differences are mostly 0 or +-1 code gets a
   scale of 0 or 1 code, far from its true spread; and s is never below half
   a quantization step (a jump of a few steps on a quiet channel is not a spike).
2. A difference is a *core* when |d - median(d)| > ``SPIKE_SIGMA`` * s. Under
   Gaussian differences the chance of that is erfc(12/sqrt(2)) = 4e-33 per
   difference (design: at most 1e-10); the threshold is set that high by real
   sensors, not by the Gaussian: quantized MEMS noise has heavier tails (the
   ADIS16405's y accelerometer, kurtosis 3.9, reaches 9.4 s in 1e6 samples,
   isolated blips of 8-11 codes that are its noise, not disturbances). A
   spike that escapes it (below 12 s) moves the variance at tau0 by at most
   2 * 144 / n of itself: 100 of them in 1e6 samples, 3 % at tau0, < 1.5 % on N.
3. Hysteresis: the runs of differences above ``EXTEND_SIGMA`` * s, merged
   when closer than ``BRIDGE_S`` seconds on the same channel (a knock's swings
   dip under any threshold between their peaks), are one group when they hold
   a core (a spike's second difference, a burst's decaying tail).
4. Groups of every channel closer than ``MERGE_S`` are one *event* (a knock
   hits every axis at once). Its time is its first disturbed sample. An event
   of ``BURST_S`` or longer (a burst) is tested on the channels that did not
   flag it: one whose differences in its span exceed ``BURST_LEVEL`` s more
   often than its quiet stretches of that length do (mean + ``BURST_Z``
   standard deviations of their counts) was shaken too, by swings too slow
   for its differences to pass 12 s (a knock at 1 kHz on a wide-band axis).
5. A group of differences i = a .. b disturbs samples a+1 .. b: they are
   replaced, on the channels where it was seen, by the straight line between
   the good samples x[a] and x[b+1], so the series stays evenly sampled. A
   group of one difference (a jump that stays: a level shift) disturbs no
   sample: it is listed as a step and left as it is.

What it cannot tell: a spike in the first or last sample (one difference only:
a step); spikes smaller than 12 s (they are noise to it); a burst of slow swings
whose differences stay under 12 s on every channel; a recording whose samples are mostly
spikes (spikes on about an eighth to a half of the samples: refused, see
``mostly_spikes``; more, and they are the noise as far as any median can
tell); dense spikes one by one (closer than ``BRIDGE_S`` they are replaced
as one span, the good samples between them with them); what the sensor did
during a burst (the line between its ends is no measurement).
"""

from __future__ import annotations

import dataclasses
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Iterator, Optional

import numpy as np

from . import diffscan

SPIKE_SIGMA = 12.0
"""Core threshold, in robust standard deviations of the first differences."""
EXTEND_SIGMA = 4.0
"""Hysteresis: neighbours of a core above this belong to its event."""
MERGE_S = 0.25
"""Disturbances closer than this (seconds), on any channels, are one event."""
BRIDGE_S = 0.05
"""Disturbed runs of one channel closer than this (seconds) are replaced as one
span (the samples between a burst's swings are displaced too)."""
MOSTLY = 0.2
"""Fraction of a channel's samples flagged above which the recording is refused."""
CORE_RATIO = 1.5
"""The MAD scale over the lower quartile's above which the differences have no
core of noise left (the median is among the spikes). Both read about the same
sigma for the differences of any one symmetric law: 1.00 white Gaussian noise
or a random walk, 1.02 Student-t(3), 1.04 Laplace, 1.14 Cauchy, 0.87 a sinusoid,
up to 1.09 the real ADIS16405; spikes on 30 % of the samples give 1.8."""
MAD_TO_SIGMA = 1.482602218505602
"""1 / Phi^-1(3/4): MAD to the standard deviation of a Gaussian."""
Q1_TO_SIGMA = 1.0 / 0.31863936396437514
"""1 / Phi^-1(5/8): the lower quartile of |d| to the standard deviation of a Gaussian."""
BURST_S = 0.1
"""A disturbance this long (seconds) or longer is a burst: the channels that did not
flag it are tested over its span (``_bursts_elsewhere``)."""
BURST_LEVEL = 1.5
"""Level (robust sigmas) of the differences counted in that test."""
BURST_Z = 5.0
"""The test's threshold, in standard deviations of the channel's own counts (``_usual``)."""
MODES = ("replace", "keep")
GRID_MAX = 1 << 16
"""Quantized differences are counted up to this many steps (wilder ones count as
this many: only the lower half of the counts is read)."""


@dataclass(frozen=True)
class ChannelScan:
    """One channel's disturbances: its difference scale and the spans replaced."""

    scale: float
    """Robust standard deviation of the first differences (input units)."""
    quantum: float
    """Quantization step seen in the differences (0: continuous values)."""
    spans: np.ndarray
    """(k, 2) int64 [start, stop) sample spans disturbed, sorted."""
    steps: np.ndarray
    """Sample indices where a lone jump (a level shift) starts: kept."""
    peak: float
    """Largest |d - median(d)| / scale (0 on a constant channel)."""
    core_ratio: float
    """MAD scale over the lower quartile's: ~1 for a Gaussian core."""

    @property
    def count(self) -> int:
        return int((self.spans[:, 1] - self.spans[:, 0]).sum())


@dataclass(frozen=True)
class Event:
    """A disturbance on one or more channels: samples [start, stop) (stop ==
    start for a step), the channels that saw it, and its size."""

    start: int
    stop: int
    channels: tuple[int, ...]
    peak: float
    """Largest |difference| in it, in robust standard deviations."""

    @property
    def step(self) -> bool:
        return self.stop == self.start


@dataclass
class OutlierScan:
    """What ``scan`` found in a (channels, n) array sampled at ``fs``."""

    n: int
    fs: float
    channels: list[ChannelScan]
    events: list[Event] = field(default_factory=list)

    @property
    def count(self) -> int:
        return sum(c.count for c in self.channels)

    def event_samples(self, c: int) -> np.ndarray:
        """Samples of channel ``c`` replaced in each event (events in time order)."""
        starts = np.array([e.start for e in self.events], dtype=np.int64)
        sp = self.channels[c].spans
        idx = np.searchsorted(starts, sp[:, 0], side="right") - 1
        return np.bincount(idx, weights=sp[:, 1] - sp[:, 0], minlength=starts.size).astype(np.int64)

    def channel_events(self, c: int) -> list[tuple[Event, int]]:
        """The events in which channel ``c`` had samples replaced, with how many."""
        k = self.event_samples(c)
        return [(self.events[i], int(k[i])) for i in np.flatnonzero(k)]

    def channel_steps(self, c: int) -> list[Event]:
        """The events in which channel ``c`` only jumped (a level shift, kept)."""
        k = self.event_samples(c)
        return [e for i, e in enumerate(self.events) if c in e.channels and not k[i]]


def scale_of_differences(d: np.ndarray) -> tuple[float, float, float, float]:
    """(median, robust sigma, quantum, core ratio) of first differences ``d``:
    sigma = 1.4826 MAD (grouped-data median when ``d`` is quantized), at least
    half a quantization step; core ratio = sigma over 1/Phi^-1(5/8) times the
    lower quartile of |d - median|."""
    return _scale(diffscan.of_array(d), d.size)[:4]


def _scale(pieces: diffscan.Pieces, n: int) -> tuple[float, float, float, float, float, float]:
    """``scale_of_differences`` over the pieces of n differences, and their max and min."""
    if n == 0:
        return 0.0, 0.0, 0.0, 1.0, 0.0, 0.0
    # the grid: read on up to 2^16 differences spread over the record (all of them on a
    # channel too quiet to show 100 nonzero ones there); a few odd values (a glitch
    # between codes) allowed
    sub, nzmin, dmax, dmin = diffscan.first_look(pieces, n, 16)
    nz = np.abs(sub[sub != 0])
    q = float(nz.min()) if nz.size >= 100 else (nzmin if math.isfinite(nzmin) else 0.0)
    quantized = False
    if q > 0:
        k = sub / q
        kr = np.rint(k)
        quantized = float(np.mean(np.abs(k - kr) < 1e-6)) > 0.999 and float(np.median(np.abs(kr))) < GRID_MAX
    if quantized:
        cnt = diffscan.grid_counts(pieces, q, GRID_MAX)
        mid = int(np.searchsorted(np.cumsum(cnt), n / 2))  # the median's cell
        med = q * (mid - GRID_MAX)
        folded = cnt[mid:].copy()  # counts of |k - median| = 0, 1, 2 ...
        left = cnt[: mid + 1][::-1]
        folded[1 : left.size] += left[1 : folded.size]
        mad = q * _grouped_quantile(folded, 0.5)
        q1 = q * _grouped_quantile(folded, 0.25)
    else:  # exact order statistics, read in windows (diffscan.order_stats)
        med = diffscan.quantiles(pieces, n, [0.5], lambda v: v)[0]
        mad, q1 = diffscan.quantiles(pieces, n, [0.5, 0.25], lambda v: np.abs(v - med))
    s = max(MAD_TO_SIGMA * mad, q / 2)
    s1 = max(Q1_TO_SIGMA * q1, q / 2)
    ratio = float(s / s1) if s1 > 0 else 1.0
    return float(med), float(s), (q if quantized else 0.0), ratio, dmax, dmin


def _grouped_quantile(cnt: np.ndarray, p: float) -> float:
    """Quantile p of non-negative integers |k| given by their counts, read as a
    grouped distribution: |k| = 0 stands for [0, 0.5), |k| = j >= 1 for
    [j - 0.5, j + 0.5), the values spread evenly in their cell (the textbook
    grouped median)."""
    F = np.cumsum(cnt)
    target = p * F[-1]
    j = int(np.searchsorted(F, target))
    below = F[j] - cnt[j]
    lo, width = (0.0, 0.5) if j == 0 else (j - 0.5, 1.0)
    return lo + width * (target - below) / cnt[j]


def _merge(starts: np.ndarray, stops: np.ndarray, gap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge intervals closer than ``gap``: (starts, stops, group of each input)."""
    order = np.argsort(starts, kind="stable")
    s, t = starts[order], stops[order]
    reach = np.maximum.accumulate(t)
    new = np.ones(s.size, dtype=bool)
    new[1:] = s[1:] - reach[:-1] >= gap
    gid = np.cumsum(new) - 1
    first = np.flatnonzero(new)
    group = np.empty(s.size, dtype=np.int64)
    group[order] = gid
    return s[first], np.maximum.reduceat(t, first) if s.size else t, group


def scan(
    data: np.ndarray,
    fs: float,
    spike_sigma: float = SPIKE_SIGMA,
    extend_sigma: float = EXTEND_SIGMA,
    merge_s: float = MERGE_S,
    bridge_s: float = BRIDGE_S,
) -> OutlierScan:
    """Find the spikes, bursts and steps of ``data`` ((channels, n), any units)."""
    data = np.atleast_2d(np.asarray(data, dtype=np.float64))
    C, n = data.shape
    return scan_pieces(
        [diffscan.of_array(np.diff(data[c])) for c in range(C)], n, fs, spike_sigma, extend_sigma, merge_s, bridge_s
    )


def scan_store(store, fs: float) -> OutlierScan:
    """``scan`` of the channels of an analysis' store (store.py), piece by piece."""
    return scan_pieces([diffscan.of_store(store, c) for c in range(store.channels)], store.n, fs)


def scan_pieces(
    channels: list[diffscan.Pieces],
    n: int,
    fs: float,
    spike_sigma: float = SPIKE_SIGMA,
    extend_sigma: float = EXTEND_SIGMA,
    merge_s: float = MERGE_S,
    bridge_s: float = BRIDGE_S,
) -> OutlierScan:
    """``scan`` of n samples per channel given as their differences' pieces."""
    gap = max(int(math.ceil(merge_s * fs)), 2)
    bridge = max(int(math.ceil(bridge_s * fs)), 2)
    chans: list[ChannelScan] = []
    g_start, g_stop, g_chan, g_peak = [], [], [], []
    none = np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    with ThreadPoolExecutor(max(1, min(2, os.cpu_count() or 1))) as pool:  # the passes release the GIL
        scales = list(pool.map(lambda p: _scale(p, max(n - 1, 0)), channels))
    for c, pieces in enumerate(channels):
        med, s, q, ratio, dmax, dmin = scales[c]
        if s <= 0 or not np.isfinite(s):
            chans.append(ChannelScan(float(s), q, *none, 0.0, ratio))
            continue
        zmax = max(dmax - med, med - dmin) / s
        if zmax <= spike_sigma:  # no core: nothing to flag (the common case)
            chans.append(ChannelScan(s, q, *none, zmax, ratio))
            continue
        # runs above the hysteresis level, merged on this channel when closer than the
        # bridge, kept when they hold a core; differences [a, b) disturb samples a+1 .. b-1
        ra, rb, rcore, rpeak = diffscan.runs_above(pieces, med, s, extend_sigma, spike_sigma)
        if not rcore.any():  # only a non-finite value got here
            chans.append(ChannelScan(s, q, *none, zmax, ratio))
            continue
        ga, gb, grp = _merge(ra, rb, bridge)
        keep = np.bincount(grp, weights=rcore, minlength=ga.size) > 0
        peak = np.full(ga.size, -np.inf)
        np.maximum.at(peak, grp, rpeak)  # each group's largest z
        ga, gb, peak = ga[keep], gb[keep], peak[keep]
        spans = np.stack([ga + 1, gb], axis=1).astype(np.int64)
        step = spans[:, 1] == spans[:, 0]
        chans.append(ChannelScan(s, q, spans[~step], spans[step, 0], zmax, ratio))
        g_start.append(ga + 1)
        g_stop.append(gb)
        g_chan.append(np.full(ga.size, c))
        g_peak.append(peak)
    res = OutlierScan(n, float(fs), chans)
    if g_start:
        _events(res, *(np.concatenate(v) for v in (g_start, g_stop, g_chan, g_peak)), gap, len(channels))
        _bursts_elsewhere(res, channels, scales, int(math.ceil(BURST_S * fs)))
    return res


def _events(res: OutlierScan, st: np.ndarray, sp: np.ndarray, ch: np.ndarray, pk: np.ndarray, gap: int, C: int) -> None:
    """The groups of every channel closer than ``gap`` as events of ``res``."""
    es, et, grp = _merge(st, sp, gap)
    order = np.argsort(grp, kind="stable")
    first = np.flatnonzero(np.diff(np.concatenate(([-1], grp[order]))))
    peaks = np.maximum.reduceat(pk[order], first)
    moved = np.logical_or.reduceat((sp > st)[order], first)  # a step only when every member is one
    masks = np.bitwise_or.reduceat(np.left_shift(1, ch[order].astype(np.int64)), first)
    for e in range(es.size):
        members = tuple(c for c in range(C) if int(masks[e]) >> c & 1)
        res.events.append(Event(int(es[e]), int(et[e]) if moved[e] else int(es[e]), members, float(peaks[e])))


def _bursts_elsewhere(res: OutlierScan, channels: list[diffscan.Pieces], scales: list[tuple], min_len: int) -> None:
    """A burst seen on some channels (a knock shakes every axis) is replaced on
    the others too when their differences inside its span exceed ``BURST_LEVEL``
    sigmas more often than the channel's quiet stretches of that length do
    (``_usual``): at 1 kHz a knock's slow swings move each difference by a sigma
    or two, under the spike threshold, yet many differences at once. Counts,
    not sums: the same answer whatever the pieces."""
    bursts = [i for i, e in enumerate(res.events) if e.stop - e.start >= min_len]
    if not bursts:
        return
    for c, ch in enumerate(res.channels):
        med, s = scales[c][0], ch.scale
        todo = [i for i in bursts if c not in res.events[i].channels]
        if not todo or s <= 0 or not np.isfinite(s):
            continue
        ev = [res.events[i] for i in todo]
        spans = np.array([[e.start - 1, e.stop] for e in ev], dtype=np.int64)  # their differences
        tally, inside = diffscan.counts_above(channels[c], med, s, BURST_LEVEL, spans)
        hit = np.array([k > _usual(tally, int(b - a)) for k, (a, b) in zip(inside, spans)], dtype=bool)
        if not hit.any():
            continue
        new = np.array([[e.start, e.stop] for e, h in zip(ev, hit) if h], dtype=np.int64)
        st, sp, _ = _merge(np.concatenate([ch.spans[:, 0], new[:, 0]]), np.concatenate([ch.spans[:, 1], new[:, 1]]), 1)
        res.channels[c] = dataclasses.replace(ch, spans=np.stack([st, sp], axis=1).astype(np.int64))
        for i, h in zip(todo, hit):
            if h:
                e = res.events[i]
                res.events[i] = dataclasses.replace(e, channels=tuple(sorted(e.channels + (c,))))


def _usual(tally: np.ndarray, L: int) -> float:
    """The most a stretch of L differences of the channel holds above the level
    in its quiet life: the mean plus ``BURST_Z`` standard deviations of the counts
    in windows of about L tiling the record (their spread, not a binomial's:
    the differences of band-limited noise are correlated), plus 2."""
    m = max(1, int(round(L / diffscan.CHUNK)))
    w = np.add.reduceat(tally, np.arange(0, tally.size, m))[: max(tally.size // m, 1)].astype(np.float64)
    r = L / (m * diffscan.CHUNK)
    sd = float(w.std(ddof=1)) if w.size > 1 else math.inf
    return r * float(w.mean()) + BURST_Z * math.sqrt(r) * sd + 2


def replace(data: np.ndarray, found: OutlierScan, inplace: bool = False) -> np.ndarray:
    """``data`` (a copy, or itself when ``inplace`` and float64) with every
    disturbed span replaced by the straight line between the good samples on
    either side of it."""
    out = data if inplace and data.dtype == np.float64 else np.array(data, dtype=np.float64, copy=True)
    for c, ch in enumerate(found.channels):
        if ch.spans.size == 0:
            continue
        s, t = ch.spans[:, 0], ch.spans[:, 1]
        lens = t - s
        pos = np.repeat(s, lens) + (np.arange(lens.sum()) - np.repeat(np.cumsum(lens) - lens, lens))
        left, right = np.repeat(s - 1, lens), np.repeat(t, lens)
        x = out[c]
        frac = (pos - left) / (right - left)
        x[pos] = x[left] + (x[right] - x[left]) * frac
    return out


def replaced_pieces(pieces: Any, spans: np.ndarray, ends: tuple[np.ndarray, np.ndarray]) -> Iterator[np.ndarray]:
    """``replace`` of one channel given as pieces (start, float64 samples): the
    disturbed spans as the line between the good samples on either side
    (``ends``: their values x[s - 1] and x[t]), the same numbers as ``replace``."""
    s, t = spans[:, 0], spans[:, 1]
    xl, xr = ends
    for a, x in pieces:
        x = np.array(x, dtype=np.float64, copy=True)
        b = a + x.size
        k = np.flatnonzero((t > a) & (s < b))
        if k.size:
            lens = np.minimum(t[k], b) - np.maximum(s[k], a)
            first = np.maximum(s[k], a)
            pos = np.repeat(first, lens) + (np.arange(lens.sum()) - np.repeat(np.cumsum(lens) - lens, lens))
            left, right = np.repeat(s[k] - 1, lens), np.repeat(t[k], lens)
            vl, vr = np.repeat(xl[k], lens), np.repeat(xr[k], lens)
            frac = (pos - left) / (right - left)
            x[pos - a] = vl + (vr - vl) * frac
        yield x


def mostly_spikes(found: OutlierScan, names: Optional[list[str]] = None) -> Optional[str]:
    """Why the recording cannot be analyzed as noise (None when it can): more
    than ``MOSTLY`` of a channel's samples disturbed, or differences with no
    Gaussian core left (the median scale is a spike's size)."""
    for c, ch in enumerate(found.channels):
        name = names[c] if names else f"channel {c}"
        if found.n and ch.count > MOSTLY * found.n:
            return (
                f"{name}: {100.0 * ch.count / found.n:.3g} % of the samples are spikes or bursts "
                f"(more than {100 * MOSTLY:.0f} %)"
            )
        if ch.core_ratio > CORE_RATIO:
            return (
                f"{name}: mostly spikes (the typical sample-to-sample jump is {ch.core_ratio:.3g} "
                "times the quiet quarter's: no noise floor left to measure them against)"
            )
    return None
