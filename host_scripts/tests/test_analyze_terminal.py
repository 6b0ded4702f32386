"""`imu-allan analyze` in a real 80x24 terminal (tmux): the first screen is the
answer table, not the tail of the details (the text goes through the pager
when it overflows the screen); q leaves with status 0; PAGER=cat prints it
all, as before.  Needs tmux (`make deps` installs it)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterator

import pytest
from conftest import CH, thesis_like, write_rows

HOST = Path(__file__).resolve().parents[1]


class Tmux:
    """One tmux server of our own (-L) with one window of 80x24 running a command."""

    def __init__(self, command: str) -> None:
        self.socket = f"imu-allan-analyze-{os.getpid()}-{id(self)}"
        self.run("-f", "/dev/null", "new-session", "-d", "-s", "t", "-x", "80", "-y", "24", command)
        self.run("set-option", "-t", "t", "remain-on-exit", "on")

    def run(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True, text=True, check=True).stdout

    def screen(self) -> list[str]:
        return self.run("capture-pane", "-p", "-t", "t").split("\n")[:-1]

    def wait(self, ok: Callable[[list[str]], bool], what: str, timeout: float = 180.0) -> list[str]:
        deadline = time.monotonic() + timeout
        while True:
            lines = self.screen()
            if ok(lines):
                return lines
            if time.monotonic() > deadline:
                raise AssertionError(f"not on the screen after {timeout} s: {what}\n" + "\n".join(lines))
            time.sleep(0.2)

    def kill(self) -> None:
        subprocess.run(["tmux", "-L", self.socket, "kill-server"], capture_output=True)


@pytest.fixture(scope="module")
def rows(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("tmux") is None:
        pytest.fail("tmux is not installed (make deps installs it)")
    return write_rows(tmp_path_factory.mktemp("term") / "rows.txt", thesis_like(30000, 21))


def _analyze(rows: Path, pager: str) -> Iterator[Tmux]:
    env = "env -u LESS " + ("-u PAGER" if pager == "" else f"PAGER={pager}")
    t = Tmux(
        f"cd {HOST} && {env} PYTHONPATH={HOST} {sys.executable} -m imu_allan.cli analyze {rows} "
        "--fs 100 --no-model --no-warmup; echo EXIT=$?"
    )
    try:
        yield t
    finally:
        t.kill()


def _has_table(lines: list[str]) -> bool:
    return any(ln.startswith("Noise terms (IEEE 952)") for ln in lines)


def test_the_first_screen_is_the_answer(rows: Path) -> None:
    for t in _analyze(rows, ""):
        lines = t.wait(_has_table, "the answer table")
        assert lines[0].startswith(str(rows)[:40])  # the source line, then the table
        shown = {ln.split()[0] for ln in lines if ln.split()}
        assert set(CH) <= shown  # every channel's row on the first screen
        assert all(len(ln) <= 80 for ln in lines)
        t.run("send-keys", "-t", "t", "q")
        t.wait(lambda s: any(ln == "EXIT=0" for ln in s), "exit status 0 after q")


def test_pager_cat_prints_it_all(rows: Path) -> None:
    for t in _analyze(rows, "cat"):
        lines = t.wait(lambda s: any(ln == "EXIT=0" for ln in s), "the end of the output")
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
