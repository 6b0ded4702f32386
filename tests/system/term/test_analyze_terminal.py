"""`imu-allan analyze` in a real 80x24 terminal (tmux): the first screen is the
answer table, not the tail of the details (the text goes through the pager
when it overflows the screen); q leaves with status 0; PAGER=cat prints it
all, as before.  Needs tmux (`make deps` installs it)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Iterator

import pytest
from tmux_window import Tmux

REPO = Path(__file__).resolve().parents[3]
HOST = REPO / "host_scripts"
CH = ("ax", "ay", "az", "gx", "gy", "gz")
# how long analyze may take on 30,000 rows on a busy 2-core machine
ANALYZE_S = 180.0


@pytest.fixture(scope="module")
def rows(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("tmux") is None:
        pytest.fail("tmux is not installed (make deps installs it)")
    path = tmp_path_factory.mktemp("term") / "rows.txt"
    gen = [sys.executable, "-m", "imu_allan.cli", "gen", "-n", "30000", "--fs", "100", "--seed", "21", "-o", str(path)]
    subprocess.run(gen, env={**os.environ, "PYTHONPATH": str(HOST)}, check=True)
    return path


def _analyze(rows: Path, pager: str) -> Iterator[Tmux]:
    env = "env -u LESS " + ("-u PAGER" if pager == "" else f"PAGER={pager}")
    t = Tmux(
        rows.parent,
        f"cd {HOST} && {env} PYTHONPATH={HOST} {sys.executable} -m imu_allan.cli analyze {rows} "
        "--fs 100 --no-model --no-warmup; echo EXIT=$?",
    )
    try:
        yield t
    finally:
        t.kill()


def _has_table(lines: list[str]) -> bool:
    return any(ln.startswith("Noise terms (IEEE 952)") for ln in lines)


def test_the_first_screen_is_the_answer(rows: Path) -> None:
    for t in _analyze(rows, ""):
        lines = t.wait(_has_table, "the answer table", ANALYZE_S)
        assert lines[0].startswith(str(rows)[:40])  # the source line, then the table
        shown = {ln.split()[0] for ln in lines if ln.split()}
        assert set(CH) <= shown  # every channel's row on the first screen
        assert all(len(ln) <= 80 for ln in lines)
        t.keys("q")
        t.wait(lambda s: any(ln == "EXIT=0" for ln in s), "exit status 0 after q", ANALYZE_S)


def test_pager_cat_prints_it_all(rows: Path) -> None:
    for t in _analyze(rows, "cat"):
        lines = t.wait(lambda s: any(ln == "EXIT=0" for ln in s), "the end of the output", ANALYZE_S)
        assert not _has_table(lines)  # the answer scrolled off the top: why the pager is there
        piped = subprocess.run(
            [sys.executable, "-m", "imu_allan.cli", "analyze", str(rows), "--fs", "100", "--no-model", "--no-warmup"],
            cwd=HOST,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()
        end = lines.index("EXIT=0")
        assert lines[end - 1].strip() and lines[end - 1].strip() in piped[-1]  # the whole text went by
