"""The link soak: random commands, some back to back, over a link that loses
and flips bytes (1e-3 each, both ways), to the real firmware in imu-sim.
Every command is sent as the host tools send it, with its check (`*XXXX`,
the CRC-16 of its text: docs/protocol.md, "Commands"), and must run as sent
or be refused (error:5 when it lost a byte or its check does not match);
none may run with text other than what was sent.  Each `ok` reply the host
can read (its CRC holds) is matched, in order, to a command sent; a reply
that matches none is a mismatch, and so is a `status` showing an interval
never sent.  Sampling must go on with no drop.

    python3 tests/system/sim/soak.py [--runs 1000] [--jobs 2] [--seed 1]   (make soak)

Two faults towards the device leave nothing the UART could see: a byte the
link lost whole (the UART just never receives a frame: `interval 2290`
arrives as the valid `interval 229`) and a byte whose data bits were flipped
(a valid frame; 8N1 has no parity).  The command's check catches them: the
figure that must be 0 is `mismatch`, over every run; the runs where either
happened are counted (runs_with_unseen), and their mismatches apart too
(mismatch_after_unseen, included in `mismatch`), to show what the check
caught.  `--no-check` sends the commands bare, as a person types them:
then only the faults the UART or the line discipline can see are refused,
and `mismatch` counts only the runs without the others."""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "host_scripts"))
from faultsim import make_rows, simulate  # noqa: E402

from imu_allan.device.link import command_line  # noqa: E402  (what the host tools send)

RATES = (100, 1500)
SECONDS = 3.0
RATE_LOSS = RATE_FLIP = 1e-3
PLAIN = ["status", "units", "echo", "units counts", "units phys", "echo on", "echo off"]


def commands(rng: np.random.Generator, count: int) -> list[str]:
    values = iter(rng.choice(np.arange(1000, 3601), count, replace=False))
    return [f"interval {next(values)}" if rng.random() < 0.6 else str(rng.choice(PLAIN)) for _ in range(count)]


def sent_as(cmd: str, check: bool) -> str:
    """The line of cmd as sent, without its CR: with its check, as
    `imu-allan cmd` and the monitor send it, or bare."""
    return command_line([cmd])[:-1].decode("ascii") if check else cmd


def schedule(rng: np.random.Generator, cmds: list[str], n: int, check: bool = True) -> str:
    """--uart-in text: the commands in groups of 1 to 3 sent back to back,
    the groups at random rows between 10 % and 90 % of the run."""
    out, i = [], 0
    rows = sorted(rng.integers(n // 10, 9 * n // 10, size=len(cmds)))
    while i < len(cmds):
        k = int(rng.integers(1, 4))
        out.append(f"{rows[i]}\t" + "".join(sent_as(c, check) + "\\r" for c in cmds[i : i + k]))
        i += k
    return "\n".join(out) + "\n"


def matches(cmd: str, reply: str) -> bool:
    word, _, arg = cmd.partition(" ")
    if word == "status":
        return reply.startswith("ok status ")
    if word == "interval":
        return reply == f"ok interval={arg}"
    if word in ("units", "echo"):
        return reply == f"ok {word}={arg}" if arg else reply.startswith(f"ok {word}=")
    return False


def shows_sent_interval(reply: str, before: list[str]) -> bool:
    """A status shows the default interval or one sent before it."""
    m = re.search(r" interval=(\d+)", reply) if reply.startswith("ok status") else None
    return not m or m.group(1) == "60" or f"interval {m.group(1)}" in before


def judge(cmds: list[str], replies: list[str]) -> Counter:
    """Match the replies to the commands, in order."""
    c: Counter = Counter(sent=len(cmds))
    p = 0
    for r in replies:
        if r.startswith("error:5"):
            c["error5"] += 1
        elif r.startswith("error:7"):
            c["timeout"] += 1
        elif r.startswith("error"):
            c["refused_other"] += 1
        elif r == "ok":
            continue  # the harness's own final `report`
        else:
            # the first command from p this reply answers; a status only one
            # sent after the interval it shows (an earlier status may have
            # had its reply damaged on the way back)
            j = next((j for j in range(p, len(cmds)) if matches(cmds[j], r) and shows_sent_interval(r, cmds[:j])), None)
            if j is None:
                c["mismatch"] += 1
                c.setdefault("examples", []).append(r)  # type: ignore[arg-type]
                continue
            c["ran"] += 1
            p = j + 1
    return c


def one_run(seed: int, tmp: Path, check: bool = True) -> Counter:
    rng = np.random.default_rng(seed)
    fs = RATES[seed % len(RATES)]
    n = int(SECONDS * fs)
    d = tmp / f"s{seed}"
    d.mkdir()
    make_rows(d / "r.tsv", n, seed)
    cmds = commands(rng, int(rng.integers(10, 21)))
    run = simulate(
        d / "r.tsv",
        d,
        fs,
        "--link-loss",
        str(RATE_LOSS),
        "--link-flip",
        str(RATE_FLIP),
        "--fault-seed",
        str(seed),
        uart=schedule(rng, cmds, n, check),
        check=False,
    )
    if run.returncode != 0:
        return Counter(runs=1, failed_runs=1, sent=len(cmds))
    setup = 4  # the harness's own stop, rate, reset, start replies
    c = judge(cmds, [b for b in run.lines() if b.startswith(("ok", "error"))][setup:])
    c["runs"] = 1
    head = run.headers()[-1]
    if int(head["drops"]) or int(head["n"]) != n:
        c["sampling_faults"] += 1
    unseen = run.stats["fault_in_data_flips"] + run.stats["fault_in_lost"] > 0
    c["runs_with_unseen"] += unseen
    if unseen:
        # with the check these are mismatches like any other: it is what
        # catches them; bare, the firmware cannot, so they are told apart
        c["mismatch_after_unseen"] += c["mismatch"] if check else c.pop("mismatch", 0)
    for k in ("fault_in_lost", "fault_in_flipped", "fault_out_lost", "fault_out_flipped"):
        c[k] += run.stats[k]
    return c


def soak(runs: int, jobs: int = 2, seed: int = 1, check: bool = True) -> Counter:
    total: Counter = Counter()
    examples: list[str] = []
    with tempfile.TemporaryDirectory() as t, ThreadPoolExecutor(jobs) as pool:
        for c in pool.map(lambda s: one_run(s, Path(t), check), range(seed, seed + runs)):
            examples += c.pop("examples", [])
            total.update(c)
    total["examples"] = examples[:5]  # type: ignore[assignment]
    return total


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--no-check",
        dest="check",
        action="store_false",
        help="send the commands without their check (as typed by a person)",
    )
    a = ap.parse_args()
    t = soak(a.runs, a.jobs, a.seed, a.check)
    keys = [
        "runs",
        "failed_runs",
        "sampling_faults",
        "sent",
        "ran",
        "error5",
        "timeout",
        "refused_other",
        "mismatch",
        "runs_with_unseen",
        "mismatch_after_unseen",
        "fault_in_lost",
        "fault_in_flipped",
        "fault_out_lost",
        "fault_out_flipped",
    ]
    for k in keys:
        print(f"{k:26s} {t[k]}")
    if t["examples"]:
        print("mismatched replies (first 5):", *t["examples"], sep="\n  ")
    return 1 if t["mismatch"] or t["failed_runs"] or t["sampling_faults"] else 0


if __name__ == "__main__":
    sys.exit(main())
