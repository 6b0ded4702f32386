"""imu-sim's rooms call each other one way only: no call circle between its
source files (a function defined in one and called from the other, both
ways, directly or round a longer loop), and no include circle."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
SIM_DIR = REPO / "sim"


def _reaches(graph: dict[str, set[str]], start: str) -> set[str]:
    seen: set[str] = set()
    todo = [start]
    while todo:
        for nxt in graph.get(todo.pop(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def test_no_call_circle_between_sim_files(tmp_path: Path) -> None:
    if not shutil.which("nm") or not Path("/usr/include/simavr").is_dir():
        pytest.skip("needs nm and simavr's headers (make deps)")
    defined: dict[str, str] = {}
    used: dict[str, set[str]] = {}
    for src in sorted(SIM_DIR.glob("*.c")):
        obj = tmp_path / (src.stem + ".o")
        subprocess.run(
            [
                "cc",
                "-std=gnu99",
                "-c",
                "-I",
                str(REPO / "firmware"),
                "-isystem",
                "/usr/include/simavr",
                str(src),
                "-o",
                str(obj),
            ],
            check=True,
        )
        for line in subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout.splitlines():
            parts = line.split()
            if len(parts) == 3 and parts[1] in "TDBR":
                defined[parts[2]] = src.stem
            elif len(parts) == 2 and parts[0] == "U":
                used.setdefault(src.stem, set()).add(parts[1])
    calls = {m: {defined[s] for s in syms if defined.get(s, m) != m} for m, syms in used.items()}
    assert calls["imu_sim"], "no calls found: the check itself is broken"
    circles = [m for m in calls if m in _reaches(calls, m)]
    assert not circles, {m: sorted(calls[m]) for m in circles}


def test_no_include_circle_between_sim_headers() -> None:
    inc = re.compile(r'#include "([a-z_]+\.h)"')
    graph = {h.name: set(inc.findall(h.read_text())) for h in SIM_DIR.glob("*.h")}
    circles = [h for h in graph if h in _reaches(graph, h)]
    assert not circles, circles
