"""Shared pieces of the simulator scenarios: the real firmware ELF runs in
simavr (imu-sim); every result is checked exactly by `imu-allan check`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = BUILD / "avr-atmega168" / "imu-allan.elf"
SIM = BUILD / "host" / "imu-sim"


def cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Run this checkout's imu-allan command line as a user would."""
    env = dict(os.environ, PYTHONPATH=str(REPO / "host_scripts"))
    proc = subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", *args], capture_output=True, text=True, errors="replace", env=env
    )
    if check and proc.returncode != 0:
        raise AssertionError(f"imu-allan {' '.join(args)} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}")
    return proc


@pytest.fixture(scope="session", autouse=True)
def built() -> None:
    missing = [str(p) for p in (ELF, SIM) if not p.is_file()]
    if missing:
        pytest.fail(f"not built: {', '.join(missing)} (run 'make sim-test', which builds them)")


class Run:
    """One scenario: rows file -> simulated device -> log, stats."""

    def __init__(self, tmp: Path, name: str) -> None:
        self.rows = tmp / f"{name}.tsv"
        self.log = tmp / f"{name}.log"
        self.stats_file = tmp / f"{name}.stats.json"

    def simulate(self, fs: int | None = None, uart_in: Path | None = None) -> dict:
        args = [
            "sim",
            "--adc",
            str(self.rows),
            "-o",
            str(self.log),
            "--firmware",
            str(ELF),
            "--stats",
            str(self.stats_file),
        ]
        if fs is not None:
            args += ["--fs", str(fs)]
        if uart_in is not None:
            args += ["--uart-in", str(uart_in)]
        cli(*args)
        return json.loads(self.stats_file.read_text())

    def check(self, fs: int | None = None) -> str:
        args = ["check", str(self.log), str(self.rows)]
        if fs is not None:
            args += ["--fs", str(fs)]
        return cli(*args).stdout

    def decode(self) -> dict:
        return json.loads(cli("decode", "--json", str(self.log)).stdout)


@pytest.fixture
def run(tmp_path: Path):
    return lambda name: Run(tmp_path, name)
