"""`imu-allan monitor` as a person sees it: the simulated device on a
pseudo-terminal (`imu-sim --pty`, as `make sim-term` runs it) and the monitor
in a real terminal emulator, tmux, of 80x24 and other sizes.  Keys are typed
with send-keys; what is on the screen, and what went into the scrollback,
is read with capture-pane.  Needs tmux (`make deps` installs it)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator, Optional

import pytest
from tmux_window import Tmux

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = Path(os.environ.get("IMU_ELF", BUILD / "avr-atmega168" / "imu-allan.elf"))
SIM = Path(os.environ.get("IMU_SIM", BUILD / "host" / "imu-sim"))
HOST = REPO / "host_scripts"
TITLE = "imu-allan monitor: "


@pytest.fixture(scope="module", autouse=True)
def needs() -> None:
    for what, path in (("firmware", ELF), ("simulator", SIM)):
        if not path.is_file():
            pytest.fail(f"{what} not built: {path} is missing (run 'make' and 'make sim')")
    if shutil.which("tmux") is None:
        pytest.fail("tmux is not installed (make deps installs it)")


@pytest.fixture
def link(tmp_path: Path) -> Iterator[Path]:
    """The simulated device's terminal link (imu-sim --pty --synthetic)."""
    path = tmp_path / "tty"
    err = open(tmp_path / "sim.err", "wb")
    proc = subprocess.Popen(
        [str(SIM), "--pty", "--link", str(path), "--synthetic", str(ELF)], stdout=subprocess.DEVNULL, stderr=err
    )
    try:
        deadline = time.monotonic() + 10
        while not path.is_symlink():
            assert proc.poll() is None, (tmp_path / "sim.err").read_text()
            assert time.monotonic() < deadline, "no terminal link after 10 s"
            time.sleep(0.02)
        yield path
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        err.close()


def _monitor_command(link: Path, log: Optional[Path]) -> str:
    """The monitor between two snapshots of the terminal's modes (stty -g), run
    in the link's directory and given short names, as a user of `make sim-term`
    types them (without ``log``: the monitor's default log)."""
    env = f"PYTHONPATH={HOST}"
    modes = link.parent / "mon.log"
    return (
        f"cd {link.parent}; stty -g > {modes}.stty-before; "
        f"{env} {sys.executable} -m imu_allan.cli monitor --port {link.name}"
        + (f" --log {log.relative_to(link.parent)}" if log is not None else "")
        + f"; echo EXIT=$?; stty -g > {modes}.stty-after"
    )


def _modes_restored(tmp_path: Path) -> None:
    before, after = (tmp_path / "mon.log.stty-before"), (tmp_path / "mon.log.stty-after")
    deadline = time.monotonic() + 5
    while not after.exists() or not after.read_text():
        assert time.monotonic() < deadline, "no stty -g after the monitor"
        time.sleep(0.05)
    assert before.read_text() == after.read_text()  # echo and canonical mode back


@pytest.fixture
def monitor(tmp_path: Path, link: Path) -> Iterator[Tmux]:
    t = Tmux(tmp_path, _monitor_command(link, tmp_path / "mon.log"))
    try:
        t.wait(lambda s: s[0].startswith(TITLE) and s[-1].startswith(">"), "the monitor's view")
        yield t
    finally:
        t.kill()


def _long_report(t: Tmux) -> list[str]:
    """A report with more octave levels than 80x24 can show: 1000 Hz for
    5 s (12 levels), asked for with `report`."""
    t.keys("rate 1000", "Enter")
    t.wait(lambda s: any(x.startswith("ok ") and "rate=1000" in x for x in s), "the reply to rate 1000")
    time.sleep(5)
    t.keys("report", "Enter")
    return t.wait(  # the summary's first tau is 1 ms
        lambda s: any(x.startswith("report seq") for x in s) and any(x.split()[:1] == ["0.00100"] for x in s),
        "a report at 1000 Hz",
    )


def _row(lines: list[str], prefix: str) -> int:
    return next(i for i, x in enumerate(lines) if x.startswith(prefix))


def test_fits_80x24_shows_what_is_typed_and_leaves_no_copies(monitor: Tmux, tmp_path: Path) -> None:
    monitor.keys("stat")
    lines = monitor.wait(lambda s: s[-1] == "> stat", "the typed text on the last line")
    assert len(lines) == 24 and lines[0].startswith(TITLE)
    monitor.keys("uz", "BSpace", "s", "Enter")  # Backspace edits the line on the host
    lines = monitor.wait(lambda s: any(x.startswith("ok status run=1") for x in s), "the reply to status")
    assert lines[-1] == ">" and lines[0].startswith(TITLE)
    lines = _long_report(monitor)
    # 80x24 cannot hold the report: the title and status stay, the report is cut and says so
    assert lines[0].startswith(TITLE) and _row(lines, "report seq") < _row(lines, "N at ")
    assert any(x.startswith("-- lines 1-") and "PgUp/PgDn" in x for x in lines), lines
    assert all(len(x) <= 80 for x in lines) and len(lines) == 24
    monitor.keys("PageDown")
    lines = monitor.wait(lambda s: not any(x.startswith("-- lines 1-") for x in s), "the report scrolled")
    assert lines[0].startswith(TITLE) and not any(x.startswith("N at ") for x in lines)
    # redraws went to the alternate screen: nothing in the scrollback
    assert monitor.value("alternate_on") == "1" and monitor.value("history_size") == "0"
    monitor.keys("C-c")
    lines = monitor.wait(lambda s: any(x == "EXIT=0" for x in s), "the monitor ended")
    assert monitor.value("alternate_on") == "0"
    everything = monitor.everything()
    assert TITLE + "1 complete reports" in everything.replace("\n", "")
    assert "lines ok" not in everything and "PgUp/PgDn" not in everything  # no frame left
    _modes_restored(tmp_path)


def test_the_device_going_away_ends_the_monitor_cleanly(tmp_path: Path) -> None:
    """imu-sim ends while the monitor shows it: one line saying so, exit 1,
    and the terminal as it was (an exception path, not Ctrl-C)."""
    path = tmp_path / "tty"
    sim = subprocess.Popen(
        [str(SIM), "--pty", "--link", str(path), "--synthetic", str(ELF)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    t = Tmux(tmp_path, _monitor_command(path, tmp_path / "mon.log"))
    try:
        deadline = time.monotonic() + 10
        while not path.is_symlink():
            assert time.monotonic() < deadline and sim.poll() is None
            time.sleep(0.02)
        t.wait(lambda s: s[0].startswith(TITLE) and s[-1].startswith(">"), "the monitor's view")
        t.keys("sta")
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=10)
        t.wait(lambda s: any(x.startswith("EXIT=") for x in s), "the monitor ended")
        text = t.everything().replace("\n", "")  # the terminal wraps long lines
        assert "EXIT=1" in text and f"imu-allan monitor: {path.name}: connection lost" in text
        assert t.value("alternate_on") == "0"
        _modes_restored(tmp_path)
    finally:
        t.kill()
        if sim.poll() is None:
            sim.kill()
            sim.wait()


def test_the_view_follows_the_terminal_size(monitor: Tmux) -> None:
    _long_report(monitor)
    monitor.wait(lambda s: any(x.startswith("-- lines") for x in s), "the cut report")
    monitor.run("resize-window", "-t", "t", "-x", "100", "-y", "40")
    lines = monitor.wait(
        lambda s: len(s) == 40 and s[-1] == ">" and any(x.startswith("Allan deviation by tau") for x in s),
        "the device's whole summary at 100x40",
    )
    assert lines[0].startswith(TITLE) and lines[-1] == ">"
    table = _row(lines, "Allan deviation by tau")
    assert _row(lines, "N at ") < table and lines[table + 2].split()[0] == "0.00100"
    monitor.run("resize-window", "-t", "t", "-x", "60", "-y", "10")
    lines = monitor.wait(lambda s: len(s) == 10 and s[0].startswith(TITLE) and s[-1] == ">", "the view at 60x10")
    assert all(len(x) <= 60 for x in lines) and any(x.startswith("-- ") for x in lines)
    assert monitor.value("history_size") == "0"


def test_a_second_program_gets_port_busy_and_the_monitor_lives_on(monitor: Tmux, link: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(HOST)}
    for argv in (
        ["cmd", "--port", str(link), "status"],
        ["monitor", "--port", str(link), "--once", "--log", os.devnull],
    ):
        out = subprocess.run(
            [sys.executable, "-m", "imu_allan.cli", *argv], env=env, capture_output=True, text=True, timeout=30
        )
        assert out.returncode == 2 and out.stdout == ""
        assert out.stderr.count("\n") == 1 and "port busy" in out.stderr, out.stderr
    monitor.keys("status", "Enter")
    monitor.wait(lambda s: any(x.startswith("ok status") for x in s), "the monitor still answering")


def test_advice_line_fits_80x24_and_follows_every_report(monitor: Tmux) -> None:
    """The recording advice (docs/dynamic.md) is one line under the status
    line, recomputed from each new report: periodic reports every 2 s."""

    def seq(s: list[str]) -> str:
        return next((x.split()[2] for x in s if x.startswith("report seq")), "")

    def advice(s: list[str]) -> list[str]:
        return [x for x in s if x.startswith("record: B +-")]

    monitor.keys("interval 2", "Enter")
    first = monitor.wait(lambda s: seq(s) and advice(s), "a report with its advice line")
    later = monitor.wait(lambda s: seq(s) not in ("", seq(first)) and advice(s), "the next report and its advice")
    assert len(later) == 24 and all(len(x) <= 80 for x in first + later)
    assert _row(later, "report seq") + 1 == _row(later, "record: B +-")  # one row, under the status
    assert advice(later) != advice(first)  # the time still needed moves with each report
