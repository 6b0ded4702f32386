"""The monitor's pieces without a terminal: the command line editor (the
bytes a terminal sends for each key) and the view cut to a terminal size."""

from __future__ import annotations

import pytest
from conftest import line, report_lines, thesis_like
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


def _with_report(levels: int) -> Monitor:
    mon = Monitor("/dev/ttyUSB0", 115200, "imu-allan-20261123-020000.log", commands=True)
    mon.feed(b"".join(report_lines(thesis_like(2 ** (levels + 1), 3), levels, seq=4)) + line("ok"))
    assert mon.report is not None
    return mon


@pytest.mark.parametrize("columns,rows", [(80, 24), (100, 40), (60, 10), (40, 6)])
def test_the_view_fits_the_terminal(columns: int, rows: int) -> None:
    mon = _with_report(15)
    body = mon.report_text().rstrip("\n").split("\n")
    lines, cursor, scroll = mon.screen(columns, rows, typed="sta")
    assert len(lines) == rows and all(len(x) <= columns for x in lines)
    assert lines[0].startswith("imu-allan monitor: /dev/ttyUSB0"[:columns])
    assert lines[-1] == "> sta" and cursor == (rows - 1, 5)
    assert lines[-2] == "replies: ok" and lines[-4].startswith("samples: rows 0"[:columns])
    room = rows - 5
    if len(body) <= room:
        assert lines[1 : 1 + len(body)] == [b[:columns] for b in body]
    else:
        shown = room - 1
        assert lines[1 : 1 + shown] == [b[:columns] for b in body[:shown]]
        assert lines[room] == f"-- lines 1-{shown} of {len(body)}; PgUp/PgDn scroll --"[:columns]


def test_scrolling_stops_at_the_ends() -> None:
    mon = _with_report(15)
    body = mon.report_text().rstrip("\n").split("\n")
    shown = 24 - 5 - 1
    lines, _, scroll = mon.screen(80, 24, typed="", scroll=1000)
    assert scroll == len(body) - shown and lines[1 : 1 + shown] == body[-shown:]
    _, _, scroll = mon.screen(80, 24, typed="", scroll=-5)
    assert scroll == 0


def test_a_long_command_line_shows_its_end() -> None:
    mon = _with_report(4)
    lines, cursor, _ = mon.screen(20, 10, typed="interval 3600 and more words")
    assert lines[-1] == "> interval 3600 and more words"[-19:] and cursor == (9, 19)


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
