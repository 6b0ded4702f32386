"""The thesis' noise model (Gauss-Markov bias + rate random walk + white
noise, noise/model.py) built from each channel's fitted terms, simulated as
long as the recording, and its FIT% against the measurement: on the octave
ADEV, on the PSD and, with samples, on the time series itself ("signal").

The simulation is streamed like the samples (store.py): each block goes to
the Welch PSD and the signal's sums, and to a store whose octave curves the
compiled kernels compute; memory stays bounded whatever the length.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Optional

import numpy as np

from ..device.records import DeviceReport
from ..noise import model, terms
from ..profiles import Profile
from ..progress import Progress
from ..stats import psd
from .host_pass import WORKERS, HostPass
from .store import collect


def _tau_b(fit: terms.FitResult) -> Optional[float]:
    b = fit.terms["B"]
    if b.tau_range:
        return math.sqrt(b.tau_range[0] * b.tau_range[1])
    if fit.b_classic:
        return fit.b_classic["tau_s"]
    return None


def _list(a: np.ndarray) -> list[Optional[float]]:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(a, dtype=np.float64).tolist()]


def _simulate(i: int, p: Any, n: int, fs: float, host: Optional[HostPass], scale: float, opts: Any) -> dict[str, Any]:
    """One channel's model, simulated: its octave result, PSD and signal sums."""
    welch = psd.Welch(1, fs, psd.segment_length(n)) if host is not None else None
    store = host.store if host is not None else None
    mean = 0.0
    if store is not None:  # the same pieces in memory and from files: the same mean
        mean = sum(float(b.sum(dtype=np.float64)) for b in store.blocks(i)) / store.n * scale
    sums = [0.0, 0.0]

    def blocks():
        done = 0
        for b in model.simulate(p, n, seed=opts.seed * 1000 + i):
            if welch is not None:
                welch.push(b[None, :])
            if store is not None:
                s = store.read(i, done, b.size).astype(np.float64) * scale - mean
                sums[0] += float(np.sum((s - b) ** 2))
                sums[1] += float(np.sum(s**2))
            done += b.size
            yield b[None, :]

    sim = collect(blocks(), [0], opts.memory_budget // 8, "model", None, quiet=True)
    try:
        res = sim.octave(0)
    finally:
        sim.close()
    return {"res": res, "psd": welch.result() if welch is not None else None, "sig": sums, "held": store is not None}


def model_all(
    doc: dict[str, Any],
    fits: dict[str, terms.FitResult],
    fit_curves: dict[str, list[tuple[int, float]]],
    chans: list[str],
    profile: Profile,
    fs: float,
    host: Optional[HostPass],
    report: Optional[DeviceReport],
    opts: Any,
) -> None:
    """Adds ``channels.<ch>.model`` (params, curve, fit_percent, psd) to ``doc``."""
    params = []
    for ch in chans:
        fit = fits[ch]
        vals = {k: (fit.terms[k].value if fit.terms[k].value is not None else None) for k in terms.TERMS}
        params.append(model.from_terms(vals, fs, _tau_b(fit)))
    n = (
        host.n
        if host is not None
        else (max((r.covers for r in report.rows if r.pairs), default=0) if report is not None else 0)
    )
    if n < 4:
        return
    scale = [profile.scale(ch).per_count for ch in chans]
    with (
        Progress("simulating the thesis model", len(chans), unit=" channels") as bar,
        ThreadPoolExecutor(WORKERS) as pool,
    ):
        sims = []
        jobs = [pool.submit(_simulate, i, p, n, fs, host, scale[i], opts) for i, p in enumerate(params)]
        for j in jobs:
            sims.append(j.result())
            bar.update(len(sims))
    for i, ch in enumerate(chans):
        doc["channels"][ch]["model"] = _one(doc["channels"][ch], params[i], sims[i], fit_curves[ch], fs, host)


def _one(c: dict[str, Any], mp: Any, sim: dict[str, Any], fit_curve: list, fs: float, host: Optional[HostPass]) -> dict:
    res = sim["res"]
    out: dict[str, Any] = {"params": mp.as_dict(), "fit_percent": {}}
    # ADEV curves on the fit's octave grid whatever --taus shows, so FIT% does not depend on it
    sim_v = {int(m): v for m, v in zip(res.ms, res.oavar[:, 0] if host is not None else res.avar[:, 0])}
    pts = [(m, d) for m, d in fit_curve if m in sim_v and math.isfinite(sim_v[m]) and sim_v[m] > 0]
    pairs = [(d, math.sqrt(sim_v[m])) for m, d in pts]
    out["curve"] = [{"tau_s": m / fs, "dev": math.sqrt(sim_v[m])} for m, _ in pts]
    if pairs:
        s_, m_ = np.log10([a for a, _ in pairs]), np.log10([b for _, b in pairs])
        out["fit_percent"]["adev_log10"] = model.fit_percent(s_, m_)
        out["fit_percent"]["adev_log10_nrmse"] = model.fit_nrmse(s_, m_)
    if sim["psd"] is not None and "psd" in c:
        f, p = sim["psd"]
        if p.shape[1]:
            fb, pb = psd.log_bins(f, p)
            sp = np.array(c["psd"]["psd"], dtype=np.float64)
            if sp.size == pb.shape[1] and sp.size:
                ok = (sp > 0) & (pb[0] > 0)
                out["fit_percent"]["psd_log10"] = model.fit_percent(np.log10(sp[ok]), np.log10(pb[0][ok]))
                out["fit_percent"]["psd_log10_nrmse"] = model.fit_nrmse(np.log10(sp[ok]), np.log10(pb[0][ok]))
                out["psd"] = _list(pb[0])
    num, den = sim["sig"]
    if sim["held"] and den > 0:
        out["fit_percent"]["signal"] = (1.0 - math.sqrt(num / den)) * 100.0
    return out
