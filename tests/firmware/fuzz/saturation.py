#!/usr/bin/env python3
"""Coverage against time for libFuzzer targets: how long a run takes to
saturate, to choose `make fuzz-smoke`'s budget (FUZZ_SMOKE_SECONDS).

Runs each target for SECONDS from a copy of its corpus (or from nothing,
--empty), stamps every status line (`#N NEW/REDUCE/pulse cov: C ft: F`)
with the seconds since start, and prints, per target: the execs/s, the
final edges and features, the time the last new edge appeared, and the
times features reached 90 %, 99 % and 100 % of their final count.

    tests/firmware/fuzz/saturation.py [--empty] [--seconds S] BUILD_FUZZ_DIR TARGET...
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

STATUS = re.compile(r"^#(\d+)\s+(\w+)\s+cov: (\d+) ft: (\d+)")


def measure(binary, corpus, seconds, max_len):
    work = tempfile.mkdtemp(prefix="sat-")
    try:
        if corpus:
            for name in os.listdir(corpus):
                shutil.copy(os.path.join(corpus, name), work)
        cmd = [binary, f"-max_total_time={seconds}", "-print_final_stats=1", work]
        if max_len:
            cmd.insert(1, f"-max_len={max_len}")
        start = time.monotonic()
        proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        points, execs_per_s = [], None
        for line in proc.stderr:
            m = STATUS.match(line)
            if m:
                points.append((time.monotonic() - start, int(m.group(3)), int(m.group(4))))
            elif line.startswith("stat::average_exec_per_sec:"):
                execs_per_s = int(line.split(":")[-1])
        if proc.wait() != 0:
            sys.exit(f"{binary}: the run failed (rerun it by hand to see why)")
        return points, execs_per_s
    finally:
        shutil.rmtree(work)


def first_time(points, cov=0, ft=0):
    """Seconds until the edges reached cov and the features ft (NaN: never)."""
    return next((t for t, c, f in points if c >= cov and f >= ft), float("nan"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build_dir", help="where `make fuzz-build` put the targets (BUILD/fuzz)")
    ap.add_argument("targets", nargs="+")
    ap.add_argument("--seconds", type=int, default=60, help="run length per target (60)")
    ap.add_argument("--empty", action="store_true", help="start from nothing, not the repo's corpus")
    ap.add_argument("--max-len", type=int, default=0, help="libFuzzer -max_len (default: its own)")
    args = ap.parse_args()
    here = os.path.dirname(os.path.abspath(__file__))
    print(
        f"{'target':13} {'execs/s':>8} {'cov':>5} {'ft':>6} {'last cov s':>10} "
        f"{'ft90 s':>7} {'ft99 s':>7} {'ft100 s':>7}   from"
    )
    for t in args.targets:
        corpus = None if args.empty else os.path.join(here, "corpus", t)
        points, eps = measure(os.path.join(args.build_dir, t), corpus, args.seconds, args.max_len)
        if not points:
            sys.exit(f"{t}: no status lines")
        cov, ft = points[-1][1], points[-1][2]
        print(
            f"{t:13} {eps or 0:8} {cov:5} {ft:6} {first_time(points, cov=cov):10.1f} "
            f"{first_time(points, ft=0.9 * ft):7.1f} {first_time(points, ft=0.99 * ft):7.1f} "
            f"{first_time(points, ft=ft):7.1f}   {'empty' if args.empty else 'corpus'}",
            flush=True,
        )


if __name__ == "__main__":
    main()
