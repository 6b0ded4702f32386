"""The monitor's pieces without a terminal: the command line editor (the
bytes a terminal sends for each key) and the view cut to a terminal size."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
from conftest import line, report_lines, thesis_like, write_rows
from test_live import device  # noqa: F401  (the fake device on a pseudo-terminal)

from imu_allan.render.screen import Monitor
from imu_allan.render.terminal import LineEditor


def test_typing_backspace_and_enter() -> None:
    ed = LineEditor()
    assert ed.feed(b"statsu") == ([], []) and ed.text == "statsu"
    assert ed.feed(b"\x7f\x7fus") == ([], []) and ed.text == "status"  # DEL, as xterm sends
    assert ed.feed(b"\x08\x08us\r") == (["status"], []) and ed.text == ""  # BS too
    assert ed.feed(b"rate 250\r\n") == (["rate 250"], [])  # CR LF is one Enter
    assert ed.feed(b"  \r") == ([], [])  # a blank line is not sent


def test_esc_and_ctrl_u_drop_the_line_and_keys_are_told_apart() -> None:
    ed = LineEditor()
    ed.feed(b"mode raw")
    assert ed.feed(b"\x1b", final=False) == ([], []) and ed.pending  # maybe a key's start
    assert ed.feed(b"[6~") == ([], ["page_down"]) and ed.text == "mode raw"
    ed.feed(b"\x1b")  # a lone Esc (nothing followed in time)
    assert ed.text == "" and not ed.pending
    ed.feed(b"stop\x15")
    assert ed.text == ""
    assert ed.feed(b"\x1b[5~x\x1b[C\x03\x01")[1] == ["page_up"] and ed.text == "x"


def test_history_walks_the_lines_sent() -> None:
    ed = LineEditor()
    ed.feed(b"status\rrate 250\r")
    ed.feed(b"\x1b[A")
    assert ed.text == "rate 250"
    ed.feed(b"\x1b[A\x1b[A")
    assert ed.text == "status"
    ed.feed(b"\x1b[B\x1b[B")
    assert ed.text == ""
    assert ed.feed(b"\x1b[A\x1b[A\r") == (["status"], [])


REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = BUILD / "avr-atmega168" / "imu-allan.elf"
SIM = BUILD / "host" / "imu-sim"


@pytest.fixture(scope="module")
def device_log(tmp_path_factory) -> bytes:
    """What the real firmware sends for 9000 rows at 100 Hz (imu-sim): reports
    with the device's human summary, 13 taus and the noise terms."""
    if not (ELF.is_file() and SIM.is_file()):
        pytest.skip(f"{ELF.name} or imu-sim not built (run 'make firmware sim')")
    d = tmp_path_factory.mktemp("monitor")
    adc = write_rows(d / "adc.tsv", thesis_like(9000, 3))
    subprocess.run([str(SIM), "--adc", str(adc), "-o", str(d / "dev.log"), str(ELF)], capture_output=True, timeout=300)
    return (d / "dev.log").read_bytes()


def _summary(log: bytes) -> list[str]:
    """The S lines of the log's last report, read here with a regex (CRC not checked)."""
    last = max(int(m) for m in re.findall(rb"\$S,(\d+),", log))
    return [m.decode() for m in re.findall(rb"\$S,%d,([^*\r\n]*)\*" % last, log)]


def _with_report(levels: int) -> Monitor:
    mon = Monitor("/dev/ttyUSB0", 115200, "imu-allan-logs/imu-allan-20261123-020000.log", commands=True)
    mon.feed(b"".join(report_lines(thesis_like(2 ** (levels + 1), 3), levels, seq=4)) + line("ok"), now=100.0)
    assert mon.report is not None
    return mon


def _from_device(log: bytes) -> Monitor:
    mon = Monitor("/dev/ttyUSB0", 115200, "imu-allan-logs/imu-allan-20261123-020000.log", commands=True)
    mon.feed(log + line("ok"), now=100.0)
    assert mon.report is not None and mon.report.summary == _summary(log)
    return mon


def _words(rows: list[str]) -> str:
    """The screen's text with runs of blanks as one: a wrapped line reads as the line."""
    return " ".join(" ".join(rows).split())


def _shows_whole(rows: list[str], text: str) -> bool:
    return " ".join(text.split()) in _words(rows)


@pytest.mark.parametrize("columns,rows", [(80, 24), (120, 40), (100, 40), (60, 10), (40, 6)])
def test_the_view_fits_the_terminal_and_cuts_nothing(columns: int, rows: int, device_log: bytes) -> None:
    mon = _from_device(device_log)
    lines, cursor, scroll = mon.screen(columns, rows, typed="sta", now=103.0)
    assert len(lines) == rows and all(len(x) <= columns for x in lines)
    assert lines[-1] == "> sta" and cursor == (rows - 1, 5)
    top = mon.title(), mon.status_line(103.0), mon.advice_line(1 << 16)
    if rows >= 10:  # the fixed lines whole, wrapped where the width needs it
        assert lines[0].startswith("imu-allan monitor: /dev/ttyUSB0")
        assert all(_shows_whole(lines, t) for t in top[:2]) and f"report seq {mon.report.seq}, 3 s ago" in _words(lines)
        assert _shows_whole(lines, mon.advice_line(columns)) or _shows_whole(lines, top[2])
    if rows >= 24:
        assert lines[lines.index("> sta") - 1] == "ok"  # the reply, under the report


def test_the_answer_first_the_device_summary_with_its_terms_on_top(device_log: bytes) -> None:
    """The noise terms block (N, B lines as the device prints them) comes
    before the deviation table, under the table's channel names: in 80x24
    both are on the first screen; in 120x40 the whole summary is."""
    mon = _from_device(device_log)
    summary = _summary(device_log)
    small, _, _ = mon.screen(80, 24, typed="", now=101.0)
    for text in summary[-5:-1]:
        assert text in small
    names = small[small.index(summary[-5]) + 1]
    assert names.split() == summary[1].split()[1:] and names.index("ax") == summary[1].index("ax")
    assert summary[2] in small  # the table starts on the first screen
    big, _, _ = mon.screen(120, 40, typed="", now=101.0)
    assert all(text in big for text in summary)


def test_a_long_reply_is_shown_whole_under_the_report(device_log: bytes) -> None:
    mon = _from_device(device_log)
    summary = _summary(device_log)
    mon.sent("help")
    help_lines = [f"ok help command{i} [arg|other] (unit)" for i in range(15)]
    mon.feed(b"".join(line(t) for t in help_lines), now=101.0)
    lines, _, _ = mon.screen(80, 24, typed="", now=101.0)
    at = lines.index("> help")
    assert lines[at + 1 : at + 16] == help_lines and lines[at + 16] == "> "
    assert any(x.startswith("-- lines 1-") for x in lines[:at])  # the report gave way, and says so
    mon.sent("status")
    status = "ok status run=1 mode=allan range=1.5 units=phys cfg=blank fs=100 interval=60 link=0 rx=0:0:0:0"
    mon.feed(line(status), now=102.0)
    lines, _, _ = mon.screen(80, 24, typed="", now=102.0)
    cut = status.rfind(" ", 0, 81)  # wrapped at its last space within 80 columns
    assert lines[-4:-1] == ["> status", status[:cut], "  " + status[cut + 1 :]]
    assert summary[-4] in lines  # the report has its room back


def test_a_reply_taller_than_the_terminal_says_what_is_above(device_log: bytes) -> None:
    mon = _from_device(device_log)
    mon.sent("help")
    mon.feed(b"".join(line(f"ok help command{i}") for i in range(15)), now=101.0)
    lines, _, _ = mon.screen(60, 16, typed="", now=101.0)
    mark = next(i for i, x in enumerate(lines) if x.startswith("-- ") and "above" in x)
    shown = lines[mark + 1 : -1]
    assert shown == [f"ok help command{i}" for i in range(15 - len(shown), 15)]
    assert f"-- {16 - len(shown)} lines above" in lines[mark]  # "> help" and the first replies


def test_the_status_line_counts_lines_drops_and_the_report_age() -> None:
    mon = Monitor("p", 115200, "x.log")
    assert mon.status_line(0.0) == "no report yet; lines ok 0, bad 0; drops: device 0, link 0"
    rows = thesis_like(2**6, 3)
    rep = report_lines(rows, 5, seq=7, drops=3)
    damaged = line("ok status")[:-8] + b"0000\r\n"  # its CRC wrong
    mon.feed(b"".join(rep) + damaged + line("ok"), now=50.0)
    assert mon.status_line(52.4) == f"report seq 7, 2 s ago; lines ok {len(rep) + 1}, bad 1; drops: device 3, link 0"
    assert mon.status_line(50.0 + 600).startswith("report seq 7, 10 min ago;")


def test_scrolling_stops_at_the_ends(device_log: bytes) -> None:
    mon = _from_device(device_log)
    lines, _, scroll = mon.screen(80, 24, typed="", scroll=1000, now=100.0)
    mark = next(x for x in lines if x.startswith("-- lines "))
    first, last, total = (int(v) for v in mark.split()[2].replace("-", " ").split() + [mark.split()[4].rstrip(";")])
    assert last == total and scroll == first - 1
    _, _, scroll = mon.screen(80, 24, typed="", scroll=-5, now=100.0)
    assert scroll == 0


def test_a_long_command_line_shows_its_end() -> None:
    mon = _with_report(4)
    lines, cursor, _ = mon.screen(20, 10, typed="interval 3600 and more words")
    assert lines[-1] == "> interval 3600 and more words"[-19:] and cursor == (9, 19)


def test_wrapping_breaks_at_spaces_and_keeps_every_character() -> None:
    from imu_allan.render.wrap import wrap

    text = "ok status run=1 mode=allan range=1.5 units=phys cfg=blank fs=100 interval=60 link=0"
    for width in (20, 33, 80):
        rows = wrap(text, width)
        assert all(len(r) <= width for r in rows) and " ".join(" ".join(rows).split()) == text
        assert all(r.startswith("  ") for r in rows[1:]) and not rows[0].startswith(" ")
    assert wrap("x" * 25, 10) == ["x" * 10, "  " + "x" * 8, "  " + "x" * 7]


def test_a_port_held_by_another_program_is_busy_in_one_line(device, run_cli, tmp_path) -> None:  # noqa: F811
    import serial

    dev = device(hold=5.0)
    holder = serial.Serial(dev.path, 115200, exclusive=True)  # as picocom or a monitor holds it
    try:
        for argv in (
            ("cmd", "--port", dev.path, "status"),
            ("monitor", "--port", dev.path, "--once", "--log", tmp_path / "m.log"),
        ):
            rc, out, err = run_cli(*argv)
            assert rc == 2 and out == "" and err.count("\n") == 1
            assert f"port busy: '{dev.path}' is open in another program" in err
        assert not (tmp_path / "m.log").exists()
    finally:
        holder.close()
    rc, out, err = run_cli("cmd", "--port", dev.path, "--timeout", "0.5", "status")
    assert "port busy" not in err  # free again once closed
