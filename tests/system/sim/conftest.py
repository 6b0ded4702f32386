"""Shared pieces of the simulator scenarios: the real firmware ELF runs in
simavr (imu-sim); every result is checked exactly by `imu-allan check`."""

from __future__ import annotations

import contextlib
import io
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


# The commands that only read and write files run in this process, the same
# argv through the same main(): a fresh interpreter for each would import
# numpy and scipy again (about 2 s of CPU for gen and decode, which need
# scipy, against 5 s for simulating 30,000 rows).  `sim` and anything else run
# as their own process, as a user runs them.
IN_PROCESS = frozenset({"gen", "check", "decode", "rows", "dynamic", "analyze"})


def cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Run this checkout's imu-allan command line as a user would."""
    if args[0] in IN_PROCESS and _this_checkouts_package():
        proc = _in_process(args)
    else:
        env = dict(os.environ, PYTHONPATH=str(REPO / "host_scripts"))
        proc = subprocess.run(
            [sys.executable, "-m", "imu_allan.cli", *args], capture_output=True, text=True, errors="replace", env=env
        )
    if check and proc.returncode != 0:
        raise AssertionError(f"imu-allan {' '.join(args)} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}")
    return proc


def _this_checkouts_package() -> bool:
    import imu_allan

    return Path(imu_allan.__file__).resolve().is_relative_to(REPO / "host_scripts")


def _in_process(args: tuple[str, ...]) -> subprocess.CompletedProcess:
    """imu-allan ARGS by its main(), stdout and stderr caught, an exit
    (argparse's) taken as the status it gives."""
    from imu_allan.cli.main import main

    out, err = (io.TextIOWrapper(io.BytesIO(), encoding="utf-8", errors="replace") for _ in range(2))
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(list(args))
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else int(exc.code is not None)
    out.flush()
    err.flush()
    text = (f.buffer.getvalue().decode(errors="replace") for f in (out, err))  # type: ignore[attr-defined]
    return subprocess.CompletedProcess(["imu-allan", *args], rc, *text)


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


# The longest test first (2^20 samples at 1 kHz, several times the next
# longest): pytest -n 2 hands tests out in collection order, and started
# late it would leave one core idle while it finishes.
LONGEST = "test_long_run_of_2_20_samples"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.name != LONGEST)
