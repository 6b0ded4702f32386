"""A person at a serial terminal (issue 12), through the real pty of
`imu-sim --pty` with pyserial: the first command after the port opens,
echo and line editing, error texts, help, and the summary screen."""
from __future__ import annotations

import re
import time
from pathlib import Path

from test_sim_term import LINE, SimTerm, built, crc16  # noqa: F401  (built: the fixture)


# ---- the terminal conversation (issue 12) ---------------------------------

def _until_quiet(t: SimTerm, quiet_s: float = 0.4) -> bytes:
    """Everything the device sends until it is quiet for quiet_s."""
    assert t.ser is not None
    got = b""
    quiet = time.monotonic() + quiet_s
    while time.monotonic() < quiet:
        data = t.ser.read(max(1, t.ser.in_waiting))
        if data:
            got += data
            quiet = time.monotonic() + quiet_s
    return got


def test_first_command_after_the_port_opens_is_answered(tmp_path: Path) -> None:
    """The command goes out the moment the port opens, while the device is
    still powering up: it is answered, and no byte was lost."""
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        t.send(b"status\r")
        assert t.reply(8.0).startswith("ok status run=1 ")
        assert [e for e in t.echoes if e.startswith(b"> status")]
    finally:
        assert t.stop() == 0
    assert "lost" not in t.errors()


def test_typed_text_is_echoed_and_edited(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        assert t.line().startswith(b"B,")
        t.send(b"stat")
        assert _until_quiet(t) == b"> stat"
        # `statsu` Backspace Backspace `us`: the device runs `status`
        t.send(b"su\x08\x7fus\r")
        got = _until_quiet(t)
        assert got.startswith(b"su\b \b\b \bus\r\n$ok status run=1 ")
        # Ctrl-C and Esc drop the line: nothing runs, the echo line ends
        t.send(b"stop\x03")
        assert _until_quiet(t) == b"> stop\r\n"
        t.send(b"reset\x1b")
        assert _until_quiet(t) == b"> reset\r\n"
        assert t.command("status").startswith("ok status run=1 ")
        # echo off: nothing but the reply; the setting shows with `echo`
        t.send(b"echo off\r")
        assert _until_quiet(t).startswith(b"> echo off\r\n$ok echo=off*")
        t.send(b"echo\r")
        assert _until_quiet(t).startswith(b"$ok echo=off*")
        assert t.command("echo on") == "ok echo=on"
    finally:
        assert t.stop() == 0


ERRORS = {
    "rate 333": "error:2 rate: unsupported; 50|100|200|250|500|1000|1250 (Hz)",
    "range 8": "error:2 range: bad argument; 1.5|2|4|6 (g)",
    "interval 4000": "error:2 interval: too long; 0..3600 s",
    "mode fast": "error:2 mode: bad argument; allan|raw|binary|both",
    "echo maybe": "error:2 echo: bad argument; [off|on]",
    "stop 3": "error:2 stop: bad argument; no argument",
    "statsu": "error:1 statsu: unknown command; see help",
    "start 4294967295 x": "error:3 start: line too long; 16 chars",
}


def test_every_error_names_command_problem_and_what_is_allowed(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        for text, want in ERRORS.items():
            assert t.command(text) == want, text
            assert re.fullmatch(r"error:\d \S+: [^;]+; .+", want)
    finally:
        assert t.stop() == 0


def test_help_shows_each_command_with_its_arguments(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        t.send(b"help\r")
        lines = [t.reply() for _ in range(14)]
        words = [ln.split()[2] for ln in lines]
        assert words == ["report", "reset", "stop", "start", "rate", "status", "help",
                         "interval", "mode", "range", "save", "load", "defaults", "echo"]
        assert "ok help rate 50|100|200|250|500|1000|1250 (Hz)" in lines
        assert "ok help mode allan|raw|binary|both" in lines
        assert all(len(ln) + 8 <= 80 for ln in lines)   # $, *CRC, CR LF
        # arguments help shows are accepted
        assert t.command("echo on") == "ok echo=on"
        assert t.command("range 4") == "ok reset range=4"
    finally:
        assert t.stop() == 0


def test_report_ends_with_a_summary_screen(tmp_path: Path) -> None:
    """After `report`, the last 25 lines hold the whole summary (24 but the
    title once all 15 levels have pairs; docs/protocol.md): a title saying
    what and in which units, the tau table, a T line per channel, the check
    line, the end line; none wider than 80 columns."""
    t = SimTerm(tmp_path, "--synthetic", "--fast")
    try:
        t.open()
        assert t.line().startswith(b"B,")
        assert t.command("interval 0") == "ok interval=0"   # only the report asked for
        time.sleep(3)                       # some seconds of samples
        t.send(b"report\r")
        raw = b""
        deadline = time.monotonic() + 30
        while not (end := re.search(rb"\$E,\d+,90\*[0-9A-F]{4}\r\n", raw)):
            assert time.monotonic() < deadline, raw[-300:]
            raw += t.ser.read(max(1, t.ser.in_waiting))
        raw = raw[:end.end()]
    finally:
        t.stop()
    lines = raw.split(b"\r\n")[:-1]
    screen = lines[-25:]
    assert all(len(ln) + 2 <= 80 for ln in screen), [ln for ln in screen if len(ln) + 2 > 80]
    titles = [i for i, ln in enumerate(screen) if b"Allan deviation (ADC counts) by tau (s)" in ln]
    assert titles, screen
    levels = sum(1 for ln in screen[titles[0] + 2:] if ln.startswith(b"$S,"))
    assert titles[0] >= 1 or levels == 15, (titles, levels)  # 24 lines unless 15 levels
    body = screen[titles[0]:]
    assert body[1].split(b",", 2)[2].split(b"*")[0].split() == [b"tau_s", b"ax", b"ay", b"az", b"gx", b"gy", b"gz"]
    tl = [ln for ln in body if ln.startswith(b"$T,")]
    assert [ln.split(b",")[2] for ln in tl] == [b"ax", b"ay", b"az", b"gx", b"gy", b"gz"]
    for ln in tl:
        m = LINE.match(ln + b"\r\n")
        assert m and int(m.group(2), 16) == crc16(m.group(1))
        _, _, _, ln_n, n_val, ln_b, b_val = m.group(1).split(b",")
        assert float(n_val) > 0 and float(b_val) > 0 and int(ln_n) < 15 and int(ln_b) < 15
    assert body[-1].startswith(b"$E,")
