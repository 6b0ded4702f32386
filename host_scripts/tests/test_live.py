"""`imu-allan rows`, and `cmd` / `monitor` against a fake device on a pseudo-terminal."""

from __future__ import annotations

import io
import json
import os
import re
import select
import threading
import time
import tty
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pytest
from conftest import bin_frame, line, random_codes, raw_row, report_lines, thesis_like

BOOT = line("B,proto=1,fw=0.2.0,mcu=atmega168,reset=por")


def _raw(codes: np.ndarray) -> bytes:
    out = [BOOT, line("ok mode=raw")]
    for i, r in enumerate(codes):
        out.append(raw_row(r))
        if (i + 1) % 100 == 0:
            out.append(line(f"C,{i + 1}"))
    return b"".join(out)


def _rows_file(path: Path) -> list[list[int]]:
    return [list(map(int, ln.split("\t"))) for ln in path.read_text().splitlines() if not ln.startswith("#")]


# ---- rows -------------------------------------------------------------------------


def test_rows_from_raw_capture(tmp_path: Path, run_cli) -> None:
    codes = random_codes(1000, 1)
    cap = tmp_path / "cap.log"
    cap.write_bytes(b"\x00\x12partial row\r\n" + _raw(codes) + b"12\t3")
    out = tmp_path / "rows.txt"
    rc, _, err = run_cli("rows", cap, "-o", out)
    assert rc == 0, err
    assert _rows_file(out) == codes.tolist()
    assert err.count("\n") == 1 and "1000 rows written" in err and "rows lost 0" in err
    # the rows file and the raw capture itself replay through reference alike
    rc, ref_file, _ = run_cli("reference", out, "--fs", "100", "--json")
    clean = tmp_path / "clean.log"
    clean.write_bytes(_raw(codes))
    rc2, ref_cap, _ = run_cli("reference", clean, "--fs", "100", "--json")
    assert rc == rc2 == 0
    assert json.loads(ref_file)["rows"] == json.loads(ref_cap)["rows"]


def test_rows_from_binary_capture_with_losses(tmp_path: Path, run_cli) -> None:
    codes = random_codes(600, 2)
    frames = [bin_frame(i % 256, r) for i, r in enumerate(codes)]
    bad = bytearray(frames[300])
    bad[5] ^= 0x10  # CRC fails: counted, never written
    frames[300] = bytes(bad)
    del frames[100:103]  # three frames lost
    cap = tmp_path / "cap.bin"
    cap.write_bytes(line("ok mode=binary") + b"".join(frames))
    out = tmp_path / "rows.txt"
    rc, _, err = run_cli("rows", cap, "-o", out)
    assert rc == 3 and out.exists()
    keep = [i for i in range(600) if not 100 <= i < 103 and i != 300]
    assert _rows_file(out) == codes[keep].tolist()
    assert "596 rows written" in err and "frames lost 4" in err and "bad frames 1" in err


def test_rows_bad_row_and_stdout(tmp_path: Path, run_cli) -> None:
    codes = random_codes(200, 3)
    cap = tmp_path / "cap.log"
    data = _raw(codes)
    cap.write_bytes(data.replace(raw_row(codes[150]), raw_row(codes[150]).replace(b"\t", b"\tx", 1)))
    rc, out, err = run_cli("rows", cap, "-o", "-")
    assert rc == 3 and "bad rows 1" in err and "rows lost 1" in err
    assert len([ln for ln in out.splitlines() if not ln.startswith("#")]) == 199


def test_rows_without_samples_exits_1(tmp_path: Path, run_cli) -> None:
    cap = tmp_path / "allan.log"
    cap.write_bytes(b"".join(report_lines(thesis_like(50, 1), 3)))
    rc, _, err = run_cli("rows", cap, "-o", tmp_path / "r.txt")
    assert rc == 1 and err.count("\n") == 1 and "no raw rows or binary frames" in err


# ---- a fake device on a pseudo-terminal -------------------------------------------


class FakeDevice:
    """The master side of a pty: answers each command line with ``answer(cmd)``."""

    def __init__(self, answer: Callable[[str], bytes], first: bytes = b"", hold: float = 5.0) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no CR/LF translation before pyserial opens it
        self.path = os.ttyname(self.slave)
        self.answer, self.first, self.hold = answer, first, hold
        self.commands: list[str] = []  # their text, the check taken off
        self.checked: list[bool] = []  # each ended in its right check
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        if self.first:
            time.sleep(0.2)  # let the reader open the port
            self._write(self.first)
        buf, end = b"", time.monotonic() + self.hold
        while not self._stop.is_set() and time.monotonic() < end:
            r, _, _ = select.select([self.master], [], [], 0.05)
            if not r:
                continue
            buf += os.read(self.master, 1024)
            while b"\r" in buf:
                cmd, buf = buf.split(b"\r", 1)
                text, star, check = cmd.decode().partition("*")
                self.commands.append(text)
                self.checked.append(bool(star) and check == "%04X" % _ref_crc16(text.encode()))
                self._write(self.answer(text))
        os.close(self.master)  # the reader sees the port go away

    def _write(self, data: bytes) -> None:
        for i in range(0, len(data), 512):
            os.write(self.master, data[i : i + 512])

    def stop(self) -> None:
        self._stop.set()
        self.thread.join(5)
        os.close(self.slave)


def _ref_crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE bit by bit (docs/protocol.md), written apart from framing.py's table."""
    reg = 0xFFFF
    for byte in data:
        for bit in range(7, -1, -1):
            top = reg >> 15
            reg = (reg << 1) & 0xFFFF
            if top ^ ((byte >> bit) & 1):
                reg ^= 0x1021
    return reg


@pytest.fixture
def device() -> Iterator[Callable[..., FakeDevice]]:
    made: list[FakeDevice] = []

    def make(answer: Callable[[str], bytes] = lambda c: b"", first: bytes = b"", hold: float = 5.0) -> FakeDevice:
        d = FakeDevice(answer, first, hold)
        d.thread.start()
        made.append(d)
        return d

    yield make
    for d in made:
        d.stop()


def _traffic() -> bytes:
    """What a busy device sends besides a reply: frames (with '$', CR, LF inside),
    raw rows, a report, garbage."""
    codes = random_codes(40, 4)
    return (
        b"".join(bin_frame(i, r) for i, r in enumerate(codes[:20]))
        + b"\x00garbage\r\n"
        + b"".join(raw_row(r) for r in codes[20:])
        + b"".join(report_lines(thesis_like(20, 2), 2))
        + line("ok not-this-one")[:-3]
    )  # a cut line that looks like a reply


def test_cmd_ok(device, run_cli) -> None:
    dev = device(lambda c: _traffic() + line("ok reset rate=250"))
    rc, out, err = run_cli("cmd", "--port", dev.path, "rate", "250")
    assert (rc, out, err) == (0, "ok reset rate=250\n", "")
    assert dev.commands == ["rate 250"] and dev.checked == [True]


def test_cmd_appends_the_lines_check() -> None:
    """A command goes as ``text*XXXX``: the device runs it only if the check
    is the CRC of the text as received (a flipped bit gets error:5)."""
    from imu_allan.device.link import command_line
    from imu_allan.errors import InputError

    assert _ref_crc16(b"123456789") == 0x29B1  # the CRC's check value
    assert command_line(["interval", "36"]) == b"interval 36*%04X\r" % _ref_crc16(b"interval 36")
    assert command_line(["start 4294967295"]).startswith(b"start 4294967295*")
    with pytest.raises(InputError, match="no '\\*'"):
        command_line(["rate", "1*2"])


def test_cmd_error(device, run_cli) -> None:
    dev = device(lambda c: line("error:1 unknown command"))
    rc, out, err = run_cli("cmd", "--port", dev.path, "--baud", "9600", "frobnicate")
    assert (rc, out) == (1, "error:1 unknown command\n")


def test_cmd_timeout(device, run_cli) -> None:
    dev = device(lambda c: _traffic() + b"$ok*0000\r\n")  # a reply with a bad CRC
    t = time.monotonic()
    rc, out, err = run_cli("cmd", "--port", dev.path, "--timeout", "0.4", "status")
    assert rc == 1 and out == "" and time.monotonic() - t < 3
    assert err == f"imu-allan cmd: no reply from {dev.path} within 0.4 s\n"


def test_cmd_usage_errors(run_cli, tmp_path: Path) -> None:
    rc, _, err = run_cli("cmd", "--port", tmp_path / "no-such-port", "status")
    assert rc == 2 and err.count("\n") == 1 and "cannot open port" in err
    rc, _, err = run_cli("cmd", "--port", tmp_path / "p", "m\u00e9lange")
    assert rc == 2 and "printable ASCII" in err


def _monitor_stream() -> tuple[bytes, np.ndarray, list[bytes]]:
    rows = thesis_like(300, 5)
    rep = report_lines(rows, 4, seq=9, extra=",mode=both,range=1.5,cfg=saved")
    codes = random_codes(30, 6)
    frames = b"".join(bin_frame(i, r) for i, r in enumerate(codes))
    data = (
        b"\xa5\x00garbage"
        + BOOT
        + line("ok mode=both")
        + frames
        + b"$L,9,ax,0,12*0000\r\n"
        + b"".join(rep[:5])
        + b"".join(rep)
        + line("ok")
    )
    return data, rows, rep


def test_monitor_once(device, run_cli, tmp_path: Path, monkeypatch) -> None:
    data, rows, rep = _monitor_stream()
    dev = device(first=data)
    log = tmp_path / "mon.log"
    rc, out, err = run_cli("monitor", "--port", dev.path, "--log", log, "--once")
    assert rc == 0, err
    assert "report seq 9" in out and "mode both, range 1.5 g, settings saved" in out
    assert "reply: ok mode=both" in out and "frames 30" in out
    assert "bad_crc 1" in out and "incomplete_reports 1" in out
    adev = np.sqrt(np.mean(np.diff(rows[:, 0].astype(float)) ** 2) / 2)
    table = out[out.index("tau_s") :].splitlines()
    assert table[0].split() == ["tau_s", "ax", "ay", "az", "gx", "gy", "gz"]
    assert table[1].split()[:2] == ["0.0100", f"{adev:#.3g}".rstrip(".")]
    assert len([t for t in table[1:] if t[:10].strip().replace(".", "").isdigit()]) == 4
    summary = [b[len("$S,9,") : b.index(b"*")].decode() for b in rep if b.startswith(b"$S,9,")]
    lines = out.split("\n")
    at = lines.index(summary[0])  # the device's own lines, after the host's table
    host = next(i for i, x in enumerate(lines) if x.lstrip().startswith("tau_s"))
    assert at > host and lines[at : at + len(summary)] == summary
    assert data.startswith(log.read_bytes()) and len(log.read_bytes()) > len(data) - 20
    rc, out, _ = run_cli("decode", log, "--json")  # the log reads back
    assert rc == 0 and json.loads(out)["header"]["seq"] == 9


def test_monitor_default_log_name_and_lost_port(device, run_cli, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    dev = device(first=line("ok") + raw_row([1] * 7) * 3, hold=0.6)
    rc, out, err = run_cli("monitor", "--port", dev.path, "--once")
    assert rc == 1 and "connection lost" in err
    logs = list(tmp_path.rglob("*"))  # nothing loose in the current directory: one folder, one log
    assert sorted(p.relative_to(tmp_path).parts[0] for p in logs) == ["imu-allan-logs"] * 2
    log = next(p for p in logs if p.is_file())
    assert log.parent == tmp_path / "imu-allan-logs" and len(log.name) == len("imu-allan-20250101-120000.log")
    assert log.read_bytes() == line("ok") + raw_row([1] * 7) * 3
    assert f"log {log.relative_to(tmp_path)}" in err
    dev = device(first=line("ok"), hold=0.6)  # --log DIR/: a new file named by the time in DIR
    rc, out, err = run_cli("monitor", "--port", dev.path, "--once", "--log", f"{tmp_path / 'mine'}/")
    made = list((tmp_path / "mine").iterdir())
    assert rc == 1 and len(made) == 1 and made[0].name.startswith("imu-allan-") and made[0].read_bytes() == line("ok")


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_monitor_on_a_terminal_redraws_in_place(device, tmp_path: Path) -> None:
    """On a terminal: the alternate screen, every line put at its own row
    (no newline, so nothing scrolls), cut to the width (80x24 when the size
    cannot be asked), and the normal screen back at the end."""
    from imu_allan.cli.monitor import run_monitor

    data, _, _ = _monitor_stream()
    dev = device(first=data)
    out, err = _Tty(), io.StringIO()
    rc = run_monitor(dev.path, 115200, str(tmp_path / "m.log"), True, out=out, err=err)
    screen = out.getvalue()
    assert rc == 0 and screen.startswith("\x1b[?1049h")
    screen, after = screen.split("\x1b[?1049l")  # --once: the view left on the normal screen
    assert "\n" not in screen and "report seq 9" in after
    last = screen.split("\x1b[1;1H")[-1]
    rows = re.findall(r"\x1b\[(\d+);1H\x1b\[2K([^\x1b]*)", "\x1b[1;1H" + last)
    assert [int(r) for r, _ in rows] == list(range(1, 25))
    text = [t for _, t in rows]
    status = next(i for i, t in enumerate(text) if t.startswith("report seq 9, "))
    assert text[0].startswith("imu-allan monitor:") and "Ctrl-C" in " ".join(text[:status])
    assert all(len(t) <= 80 for t in text) and "1 complete reports" in err.getvalue()
    assert text[-3].startswith("device started: fw ") and text[-2:] == ["ok mode=both", "ok"]  # whole lines


def test_monitor_view_rate_and_losses() -> None:
    from imu_allan.render.screen import Monitor

    codes = random_codes(1000, 7)
    mon = Monitor("/dev/x", 115200, "x.log")
    data = _raw(codes).replace(raw_row(codes[450]), b"")  # one row lost
    step = len(data) // 10
    for k in range(11):  # 10 pieces over 2 s: ~500 rows/s
        mon.feed(data[k * step : (k + 1) * step], now=100 + 0.2 * k)
    text = mon.render()
    assert "no complete report yet" in text and text.endswith("\nok mode=raw\n")
    assert "rows 999, frames 0" in text and "lost: rows 1, frames 0" in text
    assert 400 < mon.rate < 600


def test_cmd_port_lost(device, run_cli) -> None:
    dev = device(hold=0.3)  # never answers, then goes away
    rc, out, err = run_cli("cmd", "--port", dev.path, "--timeout", "5", "status")
    assert rc == 1 and out == "" and err.count("\n") == 1 and "connection lost" in err


def test_rows_says_the_drops_of_the_count_lines(tmp_path: Path, run_cli) -> None:
    """The device's own drops, from its count lines, are said beside the rows lost on the way
    (count lines once said drops=5 while rows printed 'rows lost 0')."""
    rows = [b"%d\t1\t2\t3\t4\t5\t6\r\n" % i for i in range(300)]
    cap = tmp_path / "cap.log"
    cap.write_bytes(
        line("ok mode=raw")
        + b"".join(rows[:100])
        + line("C,100,2")
        + b"".join(rows[100:200])
        + line("C,200,5")
        + line("ok reset")
        + b"".join(rows[200:300])
        + line("C,100,1")
    )
    rc, _, err = run_cli("rows", cap, "-o", tmp_path / "r.txt")
    assert rc == 3 and "rows lost 0" in err and "device drops 6" in err, err  # 5 in the first run, 1 after
    rc, out, err = run_cli("analyze", cap, "--fs", "100", "--no-model", "--json")
    assert rc == 0, err
    assert any("device_drops 6" in n for n in json.loads(out)["notes"])


def test_cmd_sends_again_a_line_whose_bytes_were_lost(device, run_cli) -> None:
    """'error:5 input lost' means nothing ran: cmd tries again (3 times in all)."""
    answers = iter([line("error:5 input lost"), line("ok interval=3600")])
    dev = device(lambda c: next(answers))
    rc, out, err = run_cli("cmd", "--port", dev.path, "--timeout", "2", "interval", "3600")
    assert rc == 0 and out == "ok interval=3600\n", err
    assert dev.commands == ["interval 3600", "interval 3600"]
    dev2 = device(lambda c: line("error:5 input lost"))
    rc, out, _ = run_cli("cmd", "--port", dev2.path, "--timeout", "2", "status")
    assert rc == 1 and out == "error:5 input lost\n" and dev2.commands == ["status"] * 3
