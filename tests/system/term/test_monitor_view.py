"""What `imu-allan monitor` shows, checked against what the device sent.

The simulated device (`imu-sim --pty`, as `make sim-term` runs it) talks to
the monitor in tmux, a real terminal emulator, at 80x24 and 120x40.  Every
expected value is read here from the monitor's own log (every byte the
device sent) with a regex and binascii's CRC, independently of the host
package: the reply lines, the device's summary, the count of intact lines,
the report's seq and drops.  Needs tmux (`make deps` installs it)."""

from __future__ import annotations

import binascii
import re
import signal
import subprocess
import time
from pathlib import Path
from typing import Iterator, Optional

import pytest
from test_monitor_term import ELF, REPO, SIM, TITLE, Tmux, _monitor_command

SIZES = [(80, 24), (120, 40)]
LINE = re.compile(rb"\$([\x20-\x7e]*)\*([0-9A-F]{4})\Z")


def _bodies(log: bytes) -> tuple[list[str], int]:
    """The bodies of the intact framed lines of ``log`` (CRC-16/CCITT-FALSE
    checked), and how many lines came damaged: a framed line that fails, and
    a line that lost its '$' (every line the device sends in summary mode is
    framed, but for the echo of a typed command, ``> ...``; the capture's
    first line may start mid-line, so it is not judged, nor is the text after
    the last line end: that line is still open)."""
    ok, bad = [], 0
    ended = log[: log.rfind(b"\n") + 1]
    for i, raw in enumerate(re.split(rb"\r\n|\r|\n", ended)):
        if b"$" not in raw:
            bad += bool(i and raw and not raw.startswith(b"> "))
            continue
        dollars = raw.count(b"$")
        m = LINE.fullmatch(raw[raw.rindex(b"$") :])
        if m and binascii.crc_hqx(m.group(1), 0xFFFF) == int(m.group(2), 16):
            ok.append(m.group(1).decode())
            bad += dollars - 1  # a '$' before the last one restarted a line
        else:
            bad += dollars
    return ok, bad


def _last_report(bodies: list[str]) -> tuple[int, int, list[str]]:
    """(seq, drops, summary lines) of the last whole report (its E line came)."""
    seq = int(next(b for b in reversed(bodies) if b.startswith("E,")).split(",")[1])
    head = next(b for b in bodies if b.startswith(f"H,{seq},"))
    drops = int(re.search(r",drops=(\d+)", head).group(1))
    return seq, drops, [b.split(",", 2)[2] for b in bodies if b.startswith(f"S,{seq},")]


def _at(lines: list[str], prefix: str) -> Optional[int]:
    return next((i for i, x in enumerate(lines) if x.startswith(prefix)), None)


def _words(rows: list[str]) -> str:
    return " ".join(" ".join(rows).split())


class Device:
    """imu-sim --pty on ``dir``/tty, with extra options (faults)."""

    def __init__(self, directory: Path, *options: str) -> None:
        self.link = directory / "tty"
        self.err = open(directory / "sim.err", "wb")
        self.proc = subprocess.Popen(
            [str(SIM), "--pty", "--link", str(self.link), "--synthetic", *options, str(ELF)],
            stdout=subprocess.DEVNULL,
            stderr=self.err,
        )
        deadline = time.monotonic() + 10
        while not self.link.is_symlink():
            assert self.proc.poll() is None and time.monotonic() < deadline, "no terminal link"
            time.sleep(0.02)

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.err.close()


@pytest.fixture
def view(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[tuple[Tmux, Path]]:
    """The monitor at the size asked (``request.param``, 80x24 by default) on
    a fresh simulated device; (tmux, the monitor's log)."""
    width, height = getattr(request, "param", (80, 24))
    dev = Device(tmp_path)
    log = tmp_path / "mon.log"
    t = Tmux(tmp_path, _monitor_command(dev.link, log), width, height)
    try:
        t.wait(lambda s: s[0].startswith(TITLE) and s[-1] == ">", "the monitor's view")
        # the device's boot line first: a command typed while it is in flight
        # has the boot line shown between the command and its reply
        t.wait(lambda s: log.exists() and b"$B," in log.read_bytes(), "the device's boot line in the log")
        yield t, log
    finally:
        t.kill()
        dev.stop()


def _fits(lines: list[str], width: int, height: int) -> None:
    assert len(lines) == height and all(len(x) <= width for x in lines), "\n".join(lines)
    assert lines[0].startswith(TITLE) and lines[-1].startswith(">")


@pytest.mark.parametrize("view", SIZES, indirect=True, ids=["80x24", "120x40"])
def test_a_multi_line_reply_is_shown_whole_and_a_long_one_wrapped(view: tuple[Tmux, Path]) -> None:
    """`help` answers with one line per command: every line under `> help`, in
    order; `status` is longer than 80 columns: wrapped, nothing cut."""
    t, log = view
    width, height = int(t.value("window_width")), int(t.value("window_height"))
    t.keys("help", "Enter")

    def help_lines() -> list[str]:
        return [b for b in _bodies(log.read_bytes())[0] if b.startswith("ok help ")]

    lines = t.wait(lambda s: len(help_lines()) >= 10 and help_lines()[-1] in s, "the whole help reply")
    want = help_lines()
    at = lines.index("> help")
    assert lines[at + 1 : at + 1 + len(want)] == want and lines[at + 1 + len(want)] == ">"
    _fits(lines, width, height)
    t.keys("status", "Enter")
    lines = t.wait(lambda s: any(x.startswith("ok status ") for x in s), "the reply to status")
    status = next(b for b in _bodies(log.read_bytes())[0] if b.startswith("ok status "))
    assert len(status) > 80  # longer than the small terminal: wrapped there
    below = lines[lines.index("> status") + 1 : -1]
    assert _words(below) == status and len(below) == (1 if width >= len(status) else 2)
    _fits(lines, width, height)


@pytest.mark.parametrize("view", SIZES, indirect=True, ids=["80x24", "120x40"])
def test_the_report_is_the_device_summary_as_it_prints_it(view: tuple[Tmux, Path]) -> None:
    """The physical table and the N/B lines, each row as the device printed
    it: the terms block on the first screen at 80x24, the whole summary at
    120x40; the advice line under the status line, one row."""
    t, log = view
    width, height = int(t.value("window_width")), int(t.value("window_height"))
    t.keys("report", "Enter")
    lines = t.wait(lambda s: any(x.startswith("N at ") for x in s), "the report's noise terms")
    seq, _, summary = _last_report(_bodies(log.read_bytes())[0])
    terms = next(i for i, x in enumerate(summary) if x.startswith("N at "))
    n = lines.index(summary[terms])
    assert lines[n : n + 1] + lines[n + 2 : n + 6] == summary[terms : terms + 5]  # channel names between
    if height >= 40:
        assert all(x in lines for x in summary)
    else:
        assert summary[0] in lines and summary[2] in lines  # the table's caption and first tau
    status = _at(lines, f"report seq {seq}, ")
    assert status is not None
    assert lines[status + 1].startswith("record: B +-") and len(lines[status + 1]) <= width
    _fits(lines, width, height)


def _status(lines: list[str]) -> str:
    """The status line, its wrapped rows joined."""
    at = _at(lines, "report seq ")
    if at is None:
        at = _at(lines, "no report yet") or 0
    rows = [lines[at]] + [x for x in lines[at + 1 : at + 3] if x.startswith("  ")]
    return _words(rows)


def test_the_status_line_says_the_report_age_and_the_link_counters(view: tuple[Tmux, Path]) -> None:
    t, log = view
    t.keys("report", "Enter")
    t.wait(lambda s: _at(s, "report seq ") is not None, "a report")

    def agrees(lines: list[str]) -> bool:
        bodies, bad = _bodies(log.read_bytes())
        seq, drops, _ = _last_report(bodies)
        want = f"report seq {seq}, .* ago; lines ok {len(bodies)}, bad {bad}; drops: device {drops}, link 0"
        return re.fullmatch(want, _status(lines)) is not None

    lines = t.wait(agrees, "the status line agreeing with the log")
    age = int(re.search(r", (\d+) s ago;", _status(lines)).group(1))
    t.wait(lambda s: int(re.search(r", (\d+) s ago;", _status(s)).group(1)) >= age + 2, "the age growing")


def test_damaged_lines_are_counted_bad(tmp_path: Path) -> None:
    """Bit errors on the link (imu-sim --link-flip): the status line's
    lines ok and bad are those of the log, read here."""
    dev = Device(tmp_path, "--link-flip", "0.0005", "--fault-seed", "3")
    log = tmp_path / "mon.log"
    t = Tmux(tmp_path, _monitor_command(dev.link, log))
    try:
        t.wait(lambda s: s[0].startswith(TITLE) and s[-1] == ">", "the monitor's view")
        for _ in range(3):
            t.keys("report", "Enter")
            time.sleep(1.0)

        def agrees(lines: list[str]) -> bool:
            bodies, bad = _bodies(log.read_bytes())
            got = re.search(r"lines ok (\d+), bad (\d+);", _status(lines))
            return bad > 0 and got is not None and (int(got.group(1)), int(got.group(2))) == (len(bodies), bad)

        t.wait(agrees, "bad lines counted as the log has them", timeout=40)
    finally:
        t.kill()
        dev.stop()


ROW = re.compile(rb"\d{1,4}(?:\t\d{1,4}){6}")


def _raw_link(log: bytes) -> tuple[int, int, int]:
    """(intact rows, rows lost between intact count lines, the device's drops
    from the last count line) of a `mode raw` capture: a count line
    ``$C,<rows sent>,<drops>,...`` minus the previous one is what was sent
    between them; the intact rows received between them are what came.  A
    reply that restarts the count (``ok mode=...``, ``ok reset``) or a boot
    line leaves the interval across it unchecked."""
    rows = lost = drops = 0
    since, last = 0, None
    for raw in re.split(rb"\r\n|\r|\n", log)[1:]:  # the first line may start mid-row
        if ROW.fullmatch(raw) and all(int(v) <= 1023 for v in raw.split(b"\t")):
            rows += 1
            since += 1
            continue
        m = LINE.fullmatch(raw[raw.rfind(b"$") :]) if b"$" in raw else None
        if not (m and binascii.crc_hqx(m.group(1), 0xFFFF) == int(m.group(2), 16)):
            continue
        if m.group(1).startswith(b"C,"):
            count, drops = (int(v) for v in m.group(1).split(b",")[1:3])
            lost += 0 if last is None else count - last - since
            since, last = 0, count
        elif m.group(1).startswith((b"ok mode=", b"ok reset", b"B,")):
            since, last = 0, None
    return rows, lost, drops


def test_rows_lost_on_the_link_are_counted_as_drops(tmp_path: Path) -> None:
    """Bytes lost on the link in `mode raw` (imu-sim --link-loss): the status
    line's link drops are the rows the count lines say were sent and did
    not arrive intact, and lines ok counts the intact rows too."""
    dev = Device(tmp_path, "--link-loss", "0.003", "--fault-seed", "5")
    log = tmp_path / "mon.log"
    t = Tmux(tmp_path, _monitor_command(dev.link, log))
    try:
        t.wait(lambda s: s[0].startswith(TITLE) and s[-1] == ">", "the monitor's view")
        for mode in ("raw", "allan"):
            for _ in range(5):  # a command line can lose a byte too: sent again
                t.keys(f"mode {mode}", "Enter")
                deadline = time.monotonic() + 3
                while f"$ok mode={mode}".encode() not in log.read_bytes() and time.monotonic() < deadline:
                    time.sleep(0.1)
                if f"$ok mode={mode}".encode() in log.read_bytes():
                    break
            time.sleep(6 if mode == "raw" else 0)

        def agrees(lines: list[str]) -> bool:
            data = log.read_bytes()
            rows, lost, drops = _raw_link(data)
            got = re.search(r"lines ok (\d+), bad \d+; drops: device (\d+), link (\d+)", _status(lines))
            ok = len(_bodies(data)[0]) + rows
            return lost > 0 and got is not None and tuple(int(v) for v in got.groups()) == (ok, drops, lost)

        t.wait(agrees, "the rows lost counted as the log has them", timeout=40)
    finally:
        t.kill()
        dev.stop()


def test_the_log_goes_to_a_folder_the_repository_ignores(tmp_path: Path) -> None:
    dev = Device(tmp_path)
    t = Tmux(tmp_path, _monitor_command(dev.link, None))
    try:
        lines = t.wait(lambda s: s[0].startswith(TITLE) and s[-1] == ">", "the monitor's view")
        t.keys("status", "Enter")
        t.wait(lambda s: any(x.startswith("ok status") for x in s), "the reply to status")
        logs = list((tmp_path / "imu-allan-logs").glob("imu-allan-*.log"))
        assert len(logs) == 1 and b"$ok status " in logs[0].read_bytes()
        assert f"log imu-allan-logs/{logs[0].name}" in _words(lines)  # the view names it
        assert not list(tmp_path.glob("imu-allan-*.log"))  # nothing loose in the current directory
    finally:
        t.kill()
        dev.stop()
    ignored = subprocess.run(
        ["git", "-C", str(REPO), "check-ignore", "-q", "--no-index", f"imu-allan-logs/{logs[0].name}"]
    )
    assert ignored.returncode == 0, "the repository's .gitignore does not ignore imu-allan-logs/"


def test_a_resize_redraws_the_view_for_the_new_size(view: tuple[Tmux, Path]) -> None:
    """80x24 -> 120x40 -> 80x24 -> 120x40: each time the whole view drawn
    again at the new size (the device's whole summary at 120x40), one frame,
    nothing left in the scrollback."""
    t, log = view
    t.keys("report", "Enter")
    t.wait(lambda s: any(x.startswith("N at ") for x in s), "a report")
    for width, height in ((120, 40), (80, 24), (120, 40)):
        t.run("resize-window", "-t", "t", "-x", str(width), "-y", str(height))
        lines = t.wait(
            lambda s, h=height: len(s) == h and any(x.startswith("N at ") for x in s) and s[-1] == ">",
            f"the view at {width}x{height}",
        )
        _fits(lines, width, height)
        summary = _last_report(_bodies(log.read_bytes())[0])[2]
        assert all(x in lines for x in summary) or height < 40
        assert [x for x in lines if x.startswith(TITLE)] == lines[:1]  # one frame, no leftovers
        assert t.value("history_size") == "0"
