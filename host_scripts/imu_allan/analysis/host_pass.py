"""The host's statistics of the samples: one read of the source into a store
(store.py: memory, or per-channel files past ``--memory``), then per channel,
from the store, the outlier scan (outliers.py), the octave overlapping and
non-overlapping AVAR (the compiled kernels), the Welch PSD and the clipped
codes. The same code runs on both stores, so a streamed analysis reports
the numbers an in-memory one does; only the statistics that need every
sample at once (MDEV, HDEV, other tau grids) wait for the samples in memory.
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

from ..channels import CODE_MAX
from ..errors import InputError
from ..progress import Progress
from ..sources.detect import SampleSource
from ..stats import allan, psd
from . import outliers
from .outlier_pass import OutlierPass, note_outliers
from .store import MemoryStore, Store, collect, replaced, take_ahead


@dataclass
class HostPass:
    """What the pass over the samples gave: the octave curves, the samples
    themselves when they fit in memory, the Welch PSD, the clipped codes and the outliers."""

    n: int
    octave: allan.OctaveResult
    data: Optional[np.ndarray]
    """(channels, n) samples in input units, or None when streamed."""
    psd_later: "Future[tuple[np.ndarray, np.ndarray]]"
    """The Welch PSD, computed in the background while the noise terms are fitted."""
    taus: str
    """The tau grid of the curves: the one asked, or octave when streamed."""
    clipped: Optional[np.ndarray] = None
    """Samples at code 0 or 1023 per channel (ADC codes only)."""
    outliers: Optional[OutlierPass] = None
    store: Optional[Store] = None
    """The samples (after any replacement of outliers), open until ``close``."""

    @property
    def psd(self) -> tuple[np.ndarray, np.ndarray]:
        """(f, psd (channels, f)): the Welch PSD of every channel (waits for it)."""
        return self.psd_later.result()

    def close(self) -> None:
        if not self.psd_later.cancel():  # it reads the store: let it end first
            self.psd_later.exception()
        if self.store is not None:
            self.store.close()


@dataclass
class Curve:
    """One statistic of one channel at its taus, in input units squared."""

    ms: np.ndarray
    var: np.ndarray
    N: np.ndarray  # phase points behind each value (samples + 1)
    stride: np.ndarray
    flags: list[list[str]] = field(default_factory=list)


WORKERS = max(1, min(2, os.cpu_count() or 1))
"""Channels computed at once (the kernels and the FFTs release the GIL)."""


def per_channel(store: Store, fn: Callable[[int], Any], label: Optional[str]) -> list[Any]:
    """fn(c) for every channel of ``store``, ``WORKERS`` at a time, in channel order;
    a progress line ``label`` (None: none, as in the background)."""
    C = store.channels
    with ThreadPoolExecutor(WORKERS) as pool:
        results = pool.map(fn, range(C))
        if label is None:
            return list(results)
        out = []
        with Progress(label, C, unit=" channels") as bar:
            for i, r in enumerate(results):
                out.append(r)
                bar.update(i + 1)
    return out


def octaves(store: Store, label: str = "Allan variances") -> allan.OctaveResult:
    """The octave result of every channel of ``store`` as one (levels, channels) result."""
    return join(per_channel(store, store.octave, label))


def join(parts: list[allan.OctaveResult]) -> allan.OctaveResult:
    r = parts[0]
    return allan.OctaveResult(
        r.n,
        r.ms,
        np.concatenate([p.oavar for p in parts], axis=1),
        r.terms,
        r.stride,
        np.concatenate([p.avar for p in parts], axis=1),
        r.pairs,
    )


def welch(store: Store, fs: float, label: Optional[str] = "PSD") -> tuple[np.ndarray, np.ndarray]:
    """The Welch PSD of every channel (pwelch's segments for the store's n);
    ``label`` None: no progress line (in the background)."""
    nseg = psd.segment_length(store.n)

    def one(c: int) -> tuple[np.ndarray, np.ndarray]:
        w = psd.Welch(1, fs, nseg)
        for b in store.blocks(c):
            w.push(b[None, :])
        return w.result()

    parts = per_channel(store, one, label)
    return parts[0][0], np.concatenate([p for _, p in parts], axis=0)


def welch_later(store: Store, fs: float) -> "Future[tuple[np.ndarray, np.ndarray]]":
    """``welch`` started in another thread: the FFTs and the compiled loops release
    the GIL, so it runs beside the noise fits (Python) that do not need it."""
    pool = ThreadPoolExecutor(1)
    fut = pool.submit(welch, store, fs, None)
    pool.shutdown(wait=False)
    return fut


def host_pass(samples: SampleSource, chans: list[str], fs: float, opts: Any, notes: list[str]) -> HostPass:
    sel = [samples.channels.index(c) for c in chans]
    store = take_ahead(samples, sel, opts.memory_budget) or collect(
        samples.open_blocks(), sel, opts.memory_budget, samples.name, samples.n_hint
    )
    try:
        return _statistics(store, samples, fs, opts, notes, chans)
    except BaseException:
        store.close()
        raise


def _statistics(
    store: Store, samples: SampleSource, fs: float, opts: Any, notes: list[str], chans: list[str]
) -> HostPass:
    n = store.n
    if n < 4:
        raise InputError(f"'{samples.name}': {n} samples: too few for any statistic")
    clipped = None
    if samples.integer:
        clipped = np.array(
            [
                sum(int(np.count_nonzero((b == 0) | (b == CODE_MAX))) for b in store.blocks(c))
                for c in range(store.channels)
            ],
            dtype=np.int64,
        )
    found = outliers.scan_store(store, fs)
    why = outliers.mostly_spikes(found, chans)
    if why and opts.outliers == "replace":
        raise InputError(f"'{samples.name}': refused: {why}; --outliers keep analyzes it as it is")
    if why:
        notes.append(f"{why}: kept as asked (--outliers keep); its statistics describe the spikes")
    if getattr(opts, "keep_store", False) and n >= 64:  # the warm-up's windows, from the octave pass
        from .dynamic import raw_windows

        store.windows = raw_windows(n, fs)[:2]
    res = octaves(store)
    other = None
    if found.count:
        clean = replaced(store, found)
        res_clean = octaves(clean, "Allan variances without the outliers")
        if opts.outliers == "replace":
            clean.base = store  # the raw samples close with the clean ones
            store, res, other = clean, res_clean, res
        else:
            clean.close()
            other = res_clean
        note_outliers(found, opts.outliers, notes)
    streamed = not isinstance(store, MemoryStore)
    data = None if streamed else store.in_memory()
    if streamed:
        notes.append(
            f"more samples than --memory allows ({opts.memory_budget / 2**20:.0f} MB): streamed through "
            "temporary files; octave overlapping and non-overlapping ADEV, PSD and outliers only"
        )
        if opts.taus != "octave":
            notes.append(f"--taus {opts.taus} needs the samples in memory: octave taus used instead")
    return HostPass(
        n,
        res,
        data,
        welch_later(store, fs),
        opts.taus if data is not None else "octave",
        clipped,
        OutlierPass(found, opts.outliers, other),
        store,
    )


def host_curves(host: HostPass, c_i: int, extra: bool = True) -> dict[str, Curve]:
    """The host's curves of channel c_i: oavar (fitted), avar, mvar, hvar (input units^2)."""
    res = host.octave
    n = host.n
    out: dict[str, Curve] = {}
    data = host.data
    if host.taus == "octave":
        out["oavar"] = Curve(res.ms, res.oavar[:, c_i], np.full(res.ms.size, n + 1), res.stride)
        ok = res.pairs > 0
        out["avar"] = Curve(res.ms[ok], res.avar[ok, c_i], np.full(int(ok.sum()), n + 1), res.ms[ok])
    if data is not None:
        x = data[c_i]
        if host.taus != "octave":
            ms = allan.tau_grid(host.taus, allan.max_m("oavar", n))
            with Progress("overlapping AVAR", ms.size) as bar:
                v, _ = allan.oavar(x, ms, progress=bar.update)
            out["oavar"] = Curve(ms, v, np.full(ms.size, n + 1), np.ones(ms.size, dtype=np.int64))
            v, cnt = allan.avar(x, ms)
            ok = cnt > 0
            out["avar"] = Curve(ms[ok], v[ok], np.full(int(ok.sum()), n + 1), ms[ok])
        if not extra:
            return out
        ms3 = allan.tau_grid(host.taus, allan.max_m("mvar", n))
        with Progress("modified AVAR", ms3.size) as bar:
            v, _ = allan.mvar(x, ms3, progress=bar.update)
        out["mvar"] = Curve(ms3, v, np.full(ms3.size, n + 1), np.ones(ms3.size, dtype=np.int64))
        with Progress("Hadamard variance", ms3.size) as bar:
            v, _ = allan.ohvar(x, ms3, progress=bar.update)
        out["hvar"] = Curve(ms3, v, np.full(ms3.size, n + 1), np.ones(ms3.size, dtype=np.int64))
    return out
