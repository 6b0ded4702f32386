"""`imu-allan sim` on a terminal: a progress line (simulated seconds, speed,
time left) on stderr while imu-sim runs, erased completely at the end; and
none at all when stderr is not a terminal.  Run through a real pty."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = Path(os.environ.get("IMU_ELF", BUILD / "avr-atmega168" / "imu-allan.elf"))
SIM = Path(os.environ.get("IMU_SIM", BUILD / "host" / "imu-sim"))
ENV = {**os.environ, "PYTHONPATH": str(REPO / "host_scripts"), "IMU_SIM": str(SIM)}


@pytest.fixture(scope="module")
def rows(tmp_path_factory: pytest.TempPathFactory) -> Path:
    for what, path in (("firmware", ELF), ("simulator", SIM)):
        if not path.is_file():
            pytest.fail(f"{what} not built: {path} is missing (run 'make' and 'make sim')")
    path = tmp_path_factory.mktemp("rows") / "imu.tsv"
    subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", "gen", "-n", "40000", "--fs", "100", "--seed", "3", "-o", str(path)],
        env=ENV,
        check=True,
    )
    return path


def _sim(rows: Path, log: Path) -> list[str]:
    return [sys.executable, "-m", "imu_allan.cli", "sim", "--adc", str(rows), "--firmware", str(ELF), "-o", str(log)]


def test_progress_on_a_terminal_then_erased(rows: Path, tmp_path: Path) -> None:
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        _sim(rows, tmp_path / "dev.log"), env=ENV, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave
    )
    os.close(slave)
    out = b""
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # EIO: the child closed its end
            break
        if not data:
            break
        out += data
    os.close(master)
    assert proc.wait() == 0
    text = out.decode()
    draws = [d for d in re.split(r"\r", text) if d.strip()]
    assert draws, f"no progress line in {text!r}"
    m = re.fullmatch(
        r"imu-sim: ([\d,]+) of 400 s simulated \((\d+)%\), ([\d.,]+)x real time, "
        r"([\d,]+) s left *(\x08*)",
        draws[-1],
    )
    assert m, draws[-1]
    assert all(len(d.rstrip(" \x08")) <= 79 for d in draws)
    widths = [len(d.rstrip(" \x08")) for d in draws]
    assert text.endswith("\r" + " " * widths[-1] + "\r")  # the last line drawn, all erased
    assert (tmp_path / "dev.log").stat().st_size > 0


def test_no_progress_when_stderr_is_not_a_terminal(rows: Path, tmp_path: Path) -> None:
    out = subprocess.run(_sim(rows, tmp_path / "dev.log"), env=ENV, capture_output=True, timeout=600)
    assert out.returncode == 0 and "\r" not in out.stderr.decode() and "simulated" not in out.stderr.decode()
