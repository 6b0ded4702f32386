"""Host kernels against allantools, side by side (the host figures of make bench).

    PYTHONPATH=host_scripts python bench/host_kernels.py [--n 1e7] [--pairs 7] [--json out.json]

Each ratio comes from alternating A/B pairs (allantools, then imu-allan, on the
same data, like against like) and is reported as the pairwise median with min
and max. Values: the largest relative difference from allantools at the same
taus. Memory: peak RSS growth of a fresh process running the kernel, over the
input's size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "host_scripts"))


def pairs(fa, fb, count: int) -> dict:
    ratios, ta, tb = [], [], []
    for _ in range(count):
        t = time.perf_counter()
        fa()
        a = time.perf_counter() - t
        t = time.perf_counter()
        fb()
        b = time.perf_counter() - t
        ta.append(a)
        tb.append(b)
        ratios.append(a / b)
    return {
        "median": round(float(np.median(ratios)), 2),
        "min": round(min(ratios), 2),
        "max": round(max(ratios), 2),
        "allantools_s": round(float(np.median(ta)), 4),
        "imu_allan_s": round(float(np.median(tb)), 4),
        "pairs": count,
    }


def peak_mem_ratio(n: int, stat: str) -> float:
    code = (
        "import numpy as np, sys\n"
        f"sys.path.insert(0, {str(REPO / 'host_scripts')!r})\n"
        "from imu_allan.stats import allan\n"
        f"x = np.random.default_rng(3).standard_normal({n})\n"
        "def field(name):\n"
        "    for l in open('/proc/self/status'):\n"
        "        if l.startswith(name): return int(l.split()[1]) * 1024\n"
        "open('/proc/self/clear_refs', 'w').write('5')\n"
        "base = field('VmRSS:')\n"
        f"allan.{stat}(x, allan.tau_grid('octave', x.size // 2))\n"
        "print((field('VmHWM:') - base) / x.nbytes)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    return round(float(out.stdout.strip()), 3) if out.returncode == 0 else float("nan")


def main() -> int:
    import allantools

    from imu_allan.stats import allan

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=float, default=1e7, help="samples (default 1e7)")
    ap.add_argument("--pairs", type=int, default=7, help="alternating A/B pairs (default 7)")
    ap.add_argument("--json", help="also write the figures to this file")
    args = ap.parse_args()
    n = int(args.n)
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.standard_normal(n) * 0.01) + rng.standard_normal(n)  # as bench/run.py
    octave = allan.tau_grid("octave", n // 2)
    log = allan.tau_grid("log", n // 2, per_decade=10)
    from imu_allan.stats import kernels

    r: dict = {"samples": n, "kernels": "compiled" if kernels.COMPILED else "numpy fallback"}
    print("kernels:", r["kernels"], flush=True)

    def diff(ours, theirs):
        k = min(len(ours), len(theirs))
        return float(np.max(np.abs(np.asarray(ours[:k]) / np.asarray(theirs[:k]) - 1)))

    cases = [
        (
            "overlapping_octave",
            lambda: allantools.oadev(x, rate=1.0, data_type="freq", taus="octave"),
            lambda: allan.oavar(x, octave),
        ),
        (
            "nonoverlapping_octave",
            lambda: allantools.adev(x, rate=1.0, data_type="freq", taus="octave"),
            lambda: allan.avar(x, octave),
        ),
        (
            "overlapping_log10",
            lambda: allantools.oadev(x, rate=1.0, data_type="freq", taus=log.astype(float)),
            lambda: allan.oavar(x, log),
        ),
    ]
    for name, fa, fb in cases:
        theirs = fa()[1] ** 2
        ours = fb()[0]
        r[name] = pairs(fa, fb, args.pairs)
        r[name]["max_rel_diff_vs_allantools"] = float(f"{diff(ours, theirs):.3g}")
        print(name, r[name], flush=True)
    for stat in ("oavar", "avar"):
        r[f"peak_mem_ratio_{stat}"] = peak_mem_ratio(n, stat)
        print(f"peak_mem_ratio_{stat}", r[f"peak_mem_ratio_{stat}"], flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(r, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
