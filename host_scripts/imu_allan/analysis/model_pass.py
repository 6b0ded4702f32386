"""The thesis' noise model (Gauss-Markov bias + rate random walk + white
noise, noise/model.py) built from each channel's fitted terms, and its FIT%
against the measurement: on the octave ADEV, on the PSD and, with samples,
on the time series itself ("signal").

The model's ADEV and PSD are its processes' own (the noise catalogue's exact
discrete-time Allan variance and PSD, noise/processes.py): what a simulation
as long as the recording estimates, without its scatter, and at a cost that
does not grow with the recording. The time series is simulated for the
first ``SIGNAL_SAMPLES`` samples and compared with the recording's first ones.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Optional

import numpy as np

from ..device.records import DeviceReport
from ..noise import model, terms
from ..noise.streams import NoiseParams, NoiseProcess
from ..profiles import Profile
from ..progress import Progress
from ..stats import psd
from .host_pass import WORKERS, HostPass

SIGNAL_SAMPLES = 1 << 20
"""Samples of the time series' FIT% (the model simulated, the recording's first
ones): its value settles to ~0.1 % long before, and the cost stays fixed."""


def _tau_b(fit: terms.FitResult) -> Optional[float]:
    b = fit.terms["B"]
    if b.tau_range:
        return math.sqrt(b.tau_range[0] * b.tau_range[1])
    if fit.b_classic:
        return fit.b_classic["tau_s"]
    return None


def _list(a: np.ndarray) -> list[Optional[float]]:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(a, dtype=np.float64).tolist()]


def theory(p: model.ModelParams) -> Any:
    """The model as the noise catalogue's sum of processes (its exact AVAR and PSD)."""
    rng = np.random.default_rng(0)  # the streams' generators: unused here
    q = NoiseParams(white=p.white, gm_sigma=p.gm_sigma, gm_tau=p.gm_tau, rrw=p.rrw, quant=p.quant, ramp=p.ramp)
    return NoiseProcess(q, p.fs, 1, rng, rng, rng, quant_rng=rng).model


def _simulate(i: int, p: Any, host: Optional[HostPass], scale: float, opts: Any) -> dict[str, Any]:
    """One channel's model: its processes, and the signal FIT%'s sums on the
    first SIGNAL_SAMPLES samples (recording minus its mean there, and the model)."""
    store = host.store if host is not None else None
    sums = [0.0, 0.0]
    if store is not None:
        n = min(store.n, SIGNAL_SAMPLES)
        head = store.read(i, 0, n).astype(np.float64) * scale
        head -= float(head.sum()) / n
        done = 0
        for b in model.simulate(p, n, seed=opts.seed * 1000 + i):
            s = head[done : done + b.size]
            sums[0] += float(np.sum((s - b) ** 2))
            sums[1] += float(np.sum(s**2))
            done += b.size
    return {"model": theory(p), "sig": sums, "held": store is not None}


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
        jobs = [pool.submit(_simulate, i, p, host, scale[i], opts) for i, p in enumerate(params)]
        for j in jobs:
            sims.append(j.result())
            bar.update(len(sims))
    for i, ch in enumerate(chans):
        doc["channels"][ch]["model"] = _one(doc["channels"][ch], params[i], sims[i], fit_curves[ch], fs, host)


def _one(c: dict[str, Any], mp: Any, sim: dict[str, Any], fit_curve: list, fs: float, host: Optional[HostPass]) -> dict:
    out: dict[str, Any] = {"params": mp.as_dict(), "fit_percent": {}}
    # ADEV curves on the fit's octave grid whatever --taus shows, so FIT% does not depend on it
    ms = np.array([m for m, _ in fit_curve], dtype=np.float64)
    sim_v = dict(zip((m for m, _ in fit_curve), sim["model"].avar(ms, fs).tolist())) if ms.size else {}
    pts = [(m, d) for m, d in fit_curve if math.isfinite(sim_v[m]) and sim_v[m] > 0]
    pairs = [(d, math.sqrt(sim_v[m])) for m, d in pts]
    out["curve"] = [{"tau_s": m / fs, "dev": math.sqrt(sim_v[m])} for m, _ in pts]
    if pairs:
        s_, m_ = np.log10([a for a, _ in pairs]), np.log10([b for _, b in pairs])
        out["fit_percent"]["adev_log10"] = model.fit_percent(s_, m_)
        out["fit_percent"]["adev_log10_nrmse"] = model.fit_nrmse(s_, m_)
    if host is not None and "psd" in c and host.psd[1].shape[1]:
        f = host.psd[0][host.psd[0] > 0]
        fb, pb = psd.log_bins(f, sim["model"].psd(f, fs)[None, :])
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
