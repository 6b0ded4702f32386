"""The whole-curve noise fit's cost (imu_allan.noise.fit): a catalogue stream and the real
recording beside the repository, process CPU seconds per channel of 1e6 samples.  Called by
run.py (`make bench`), whose table holds their targets; run alone it prints both.

Usage: bench/noise_fits.py
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "host_scripts"))


def noise_fit() -> dict:
    """Seconds of the whole-curve noise fit (imu_allan.noise.fit) per channel of a
    1e6-sample recording: a catalogue stream with a band limit, flicker, a rate random
    walk and a Gauss-Markov process (the curve, its EDF and the fit; the curve itself
    is the octave engine's, timed elsewhere).  Process CPU time, median, min and max of 5."""
    from imu_allan.noise import AR1, LP, RW, Flicker
    from imu_allan.noise.fit import fit_curve
    from imu_allan.stats import allan, edf

    fs, n = 100.0, 10**6
    out = []
    for seed in range(5):
        x = (LP(0.8, 30.0, 1) + Flicker(0.2) + RW(0.015) + AR1(0.3, 120.0)).simulate(n, fs, seed)
        ms = allan.tau_grid("octave", allan.max_m("oavar", n))
        var, _ = allan.oavar(x, ms)
        t0 = time.process_time()
        efn = edf.edf_function(ms, np.full(ms.size, n + 1), np.ones(ms.size, dtype=np.int64))
        fit_curve(ms / fs, var, efn, fs=fs)
        out.append(time.process_time() - t0)
    return {
        "noise_fit_s_per_channel": round(float(np.median(out)), 3),
        "noise_fit_s_per_channel_min": round(float(np.min(out)), 3),
        "noise_fit_s_per_channel_max": round(float(np.max(out)), 3),
        "noise_fit_s_per_channel_runs": [round(v, 3) for v in out],
    }


REAL = REPO.parent / "shared" / "data" / "adis16405_imu2_codes.tsv.gz"
"""The real ADIS16405 at rest (100 Hz, 1e6 rows), beside the repository where it is present."""


def noise_fit_real() -> dict:
    """The same fit's seconds on each channel of the real recording (gyros and accelerometers:
    the accelerometers' resonance and line trials cost the most), process CPU time; each
    channel's curve once, after one untimed fit of a textbook curve on the same taus (what a
    process builds once, the flicker table, is built; the columns the fit keeps are not those of
    a curve timed after it: the first channel's own curve would be fitted from its own)."""
    if not REAL.is_file():
        return {"noise_fit_real": f"skipped: {REAL.name} absent"}
    import gzip

    from imu_allan.noise.fit import fit_curve
    from imu_allan.stats import allan, edf

    with gzip.open(REAL, "rt") as f:
        rows = np.loadtxt(f, dtype=np.float64)
    fs, n = 100.0, rows.shape[0]
    ms = allan.tau_grid("octave", allan.max_m("oavar", n))
    efn = edf.edf_function(ms, np.full(ms.size, n + 1), np.ones(ms.size, dtype=np.int64))
    curves = [allan.oavar(rows[:, c], ms)[0] for c in range(6)]
    tau = ms / fs
    fit_curve(tau, 1e-4 / tau + 1e-8 * tau, efn, fs=fs)  # white noise and a walk
    out = []
    for var in curves:
        t0 = time.process_time()
        fit_curve(ms / fs, var, efn, fs=fs)
        out.append(time.process_time() - t0)
    return {
        "noise_fit_real_s_per_channel": round(float(np.median(out)), 3),
        "noise_fit_real_s_per_channel_max": round(float(np.max(out)), 3),
        "noise_fit_real_s_per_channel_runs": [round(v, 3) for v in out],
    }


if __name__ == "__main__":
    print(json.dumps({**noise_fit(), **noise_fit_real()}, indent=2))
