"""`make demo`, as a new user runs it: it ends with the device's own summary
and the check's verdict on one 80x24 screen, and names the file that holds the
decoded table (whose columns carry their units)."""

from __future__ import annotations

import os
import subprocess

from conftest import REPO


def test_make_demo_ends_with_the_summary_and_the_verdict_on_one_screen() -> None:
    build = [f"BUILD={os.environ['BUILD']}"] if "BUILD" in os.environ else []  # else the README's `make demo`
    out = subprocess.run(
        ["make", "--no-print-directory", "-s", "-C", str(REPO), "demo", *build],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    if not build:
        assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]
    screen = lines[-23:]  # 24 rows less the shell's prompt
    assert screen[-1] == "check: OK: the device report agrees with the reference"
    assert screen[0].startswith("Allan deviation by tau (s)")
    assert screen[-6].startswith("N at ") and screen[-5].split()[0] == "N" and screen[-4].split()[0] == "B"
    # the decoded table is where the demo says, with its units in the header
    decoded_path, check_path = lines[lines.index(screen[0]) - 2].split(": ")[1].split()
    decoded = (REPO / decoded_path).read_text().splitlines()  # REPO / an absolute path is that path
    head = next(i for i, line in enumerate(decoded) if line.startswith("ch "))
    assert decoded[head].split()[5:9] == ["avar", "code^2", "adev", "code"]
    rows = [line.split() for line in decoded[head + 1 :] if line.strip() and not line.startswith("not used")]
    assert len(rows) == 6 * 15 and {r[0] for r in rows} == {"ax", "ay", "az", "gx", "gy", "gz"}
    assert (REPO / check_path).read_text().splitlines()[-1] == screen[-1].removeprefix("check: ")
