"""`imu-sim --pty`: the simulated device on a pseudo-terminal, driven the way
a user or a host program drives the real board, through pyserial.

Every device line is checked on its own (framing and CRC-16/CCITT-FALSE via
binascii.crc_hqx, independent of the firmware and of the host package).
Run with `python3 -m pytest -q tests/system/term` after `make` and `make sim`
(BUILD=, IMU_ELF=, IMU_SIM= point elsewhere)."""

from __future__ import annotations

import binascii
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
import serial

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = Path(os.environ.get("IMU_ELF", BUILD / "avr-atmega168" / "imu-allan.elf"))
SIM = Path(os.environ.get("IMU_SIM", BUILD / "host" / "imu-sim"))

CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz")
LEVELS = 15  # ATmega168 build
# --synthetic: white noise sigmas of ax..gz in counts (sim/sim_term.c)
SYNTH_SIGMA = (2.0, 2.5, 1.7, 0.9, 0.67, 0.57)

LINE = re.compile(rb"\$([\x20-\x7e]*)\*([0-9A-Fa-f]{4})\r\n\Z")


def crc16(body: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): binascii's CRC-CCITT."""
    return binascii.crc_hqx(body, 0xFFFF)


def test_crc_reference() -> None:
    assert crc16(b"123456789") == 0x29B1


@pytest.fixture(scope="module", autouse=True)
def built() -> None:
    if not ELF.is_file():
        pytest.fail(f"firmware not built: {ELF} is missing (run 'make' first)")
    if not SIM.is_file():
        pytest.fail(f"simulator not built: {SIM} is missing (run 'make sim' first)")


class SimTerm:
    """An `imu-sim --pty` process and a pyserial connection to its link."""

    def __init__(self, tmp: Path, *args: str) -> None:
        self.link = tmp / "tty"
        self.stdout = tmp / "sim.out"
        self.stderr = tmp / "sim.err"
        self.proc = subprocess.Popen(
            [str(SIM), "--pty", "--link", str(self.link), *args, str(ELF)],
            stdout=open(self.stdout, "wb"),
            stderr=open(self.stderr, "wb"),
        )
        deadline = time.monotonic() + 10
        while not self.link.is_symlink():
            if self.proc.poll() is not None:
                raise AssertionError(f"imu-sim exited {self.proc.returncode}: {self.errors()}")
            if time.monotonic() > deadline:
                raise AssertionError(f"no {self.link} after 10 s: {self.errors()}")
            time.sleep(0.01)
        self.ser: serial.Serial | None = None
        self.buf = b""
        self.seen: list[bytes] = []  # bodies of all lines read
        self.echoes: list[bytes] = []  # echo lines ("> ..." CR LF) read

    def errors(self) -> str:
        return self.stderr.read_text(errors="replace") if self.stderr.exists() else ""

    def open(self) -> None:
        self.ser = serial.Serial(str(self.link), 115200, timeout=0.2)
        self.buf = b""

    def close(self) -> None:
        if self.ser is not None:
            self.ser.close()
            self.ser = None

    def stop(self, sig: int = signal.SIGTERM) -> int:
        self.close()
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                return self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError("imu-sim ignored the signal") from None
        return self.proc.returncode

    def line(self, timeout: float = 5.0, strict: bool = True) -> bytes:
        """The body of the next device line; each must be framed, CRC intact
        (with strict=False a bad line reads as b"")."""
        assert self.ser is not None
        deadline = time.monotonic() + timeout
        while True:
            while b"\n" not in self.buf:
                if time.monotonic() > deadline:
                    raise AssertionError(
                        f"no device line within {timeout} s (partial {self.buf[:80]!r}); imu-sim: {self.errors()}"
                    )
                self.buf += self.ser.read(max(1, self.ser.in_waiting))
            raw, self.buf = self.buf.split(b"\n", 1)
            raw += b"\n"
            if not raw.startswith(b"> "):
                break
            self.echoes.append(raw)  # the echo of a typed line
        m = LINE.match(raw)
        if not strict and not (m and int(m.group(2), 16) == crc16(m.group(1))):
            return b""
        assert m, f"badly framed device line {raw!r}"
        body = m.group(1)
        assert int(m.group(2), 16) == crc16(body), f"bad CRC on {raw!r}"
        self.seen.append(body)
        return body

    def send(self, data: bytes) -> None:
        assert self.ser is not None
        self.ser.write(data)
        self.ser.flush()

    def reply(self, timeout: float = 5.0) -> str:
        """The next reply (ok/error), skipping report lines sent meanwhile."""
        deadline = time.monotonic() + timeout
        while True:
            body = self.line(max(0.01, deadline - time.monotonic()))
            if body == b"ok" or body.startswith((b"ok ", b"error")):
                return body.decode()

    def command(self, text: str, end: bytes = b"\r") -> str:
        self.send(text.encode() + end)
        return self.reply()

    def resync(self) -> None:
        """After lost bytes: end any partial line, then wait for the reply
        to a fresh 'stop', skipping the errors the debris got."""
        assert self.ser is not None
        self.send(b"\rstop\r")
        deadline = time.monotonic() + 5
        while not self.line(max(0.01, deadline - time.monotonic()), strict=False).startswith(b"ok stopped"):
            pass
        # then whatever else was on its way (the rest of a report)
        quiet = time.monotonic() + 0.3
        while time.monotonic() < quiet:
            if self.ser.read(max(1, self.ser.in_waiting)):
                quiet = time.monotonic() + 0.3
        self.buf = b""

    def report(self) -> tuple[dict, list[list[str]], int]:
        """`report`: its header keys, L rows and E row count, checked whole."""
        assert self.command("report") == "ok"
        body = self.line()
        while not body.startswith(b"H,"):  # a periodic report's tail
            body = self.line()
        fields = body.decode().split(",")
        seq = fields[1]
        head = dict(f.split("=", 1) for f in fields[2:])
        rows: list[list[str]] = []
        while True:
            body = self.line().decode()
            kind, rseq = body.split(",", 2)[:2]
            assert rseq == seq, f"line of report {rseq} inside report {seq}: {body}"
            if kind == "L":
                rows.append(body.split(",")[2:])
            elif kind == "E":
                return head, rows, int(body.split(",")[2])
            elif kind == "V":  # the report's check line
                assert body.split(",")[2] == f"id={head['id']}", body
            else:
                assert kind in ("S", "T"), body  # the summary, the noise terms


@pytest.fixture(scope="module")
def dev(tmp_path_factory: pytest.TempPathFactory):
    """One fast synthetic device for the command tests (each sets the
    state it needs)."""
    d = SimTerm(tmp_path_factory.mktemp("fast"), "--synthetic", "--fast")
    try:
        d.open()
        d.boot = d.line()
        # No periodic reports (about every 0.3 s at --fast): the tests
        # decide when a report goes out.
        assert d.command("interval 0") == "ok interval=0"
        yield d
    finally:
        d.stop()


def test_announces_device_and_boots(dev: SimTerm) -> None:
    out = dev.stdout.read_text()
    m = re.match(r"imu-sim: device on (/dev/\S+)\n", out)
    assert m, out
    assert os.path.realpath(dev.link) == os.path.realpath(m.group(1))
    boot = dev.boot.decode()
    assert boot.startswith("B,"), boot
    keys = dict(f.split("=", 1) for f in boot.split(",")[1:])
    assert keys["proto"] == "1" and keys["mcu"] == "atmega168"


def test_stop_reset_start(dev: SimTerm) -> None:
    assert re.fullmatch(r"ok stopped n=\d+", dev.command("stop"))
    assert dev.command("reset") == "ok reset"
    assert re.fullmatch(r"ok stopped n=0", dev.command("stop"))
    assert dev.command("start") == "ok started"
    time.sleep(0.3)  # about a minute simulated
    n = int(dev.command("stop").split("=")[1])
    assert n > 100, "the device took no samples from the synthetic IMU"
    # stopped: the count stands still
    time.sleep(0.1)
    assert dev.command("stop") == f"ok stopped n={n}"


def set_rate(dev: SimTerm, hz: int) -> None:
    """`rate`: the reply says `reset` when the rate changes (and only then)."""
    assert dev.command(f"rate {hz}") in (f"ok reset rate={hz}", f"ok rate={hz}")


def sample(dev: SimTerm, count: int) -> None:
    """Fresh accumulators, then exactly `count` samples (`start <count>`)."""
    assert dev.command("stop").startswith("ok stopped")
    assert dev.command("reset") == "ok reset"
    assert dev.command(f"start {count}") == "ok started"
    deadline = time.monotonic() + 20
    while "run=0" not in dev.command("status").split():
        assert time.monotonic() < deadline, f"'start {count}' did not end"
        time.sleep(0.05)
    assert dev.command("stop") == f"ok stopped n={count}"


def test_rate(dev: SimTerm) -> None:
    set_rate(dev, 250)
    assert dev.command("RATE 100") == "ok reset rate=100"  # case-insensitive
    assert dev.command("rate 100") == "ok rate=100"  # unchanged: no reset
    assert dev.command("rate 123").startswith("error:2")
    assert dev.command("rate").startswith("error:2")


def test_errors(dev: SimTerm) -> None:
    assert dev.command("frobnicate").startswith("error:1")
    assert dev.command("x" * 40).startswith("error:3")
    assert dev.command("stop " + "9" * 30).startswith("error:3")
    # line ends: LF and CRLF too; an empty line gets no reply
    assert dev.command("stop", b"\n").startswith("ok stopped")
    assert dev.command("stop", b"\r\n").startswith("ok stopped")
    dev.send(b"\r\n\r")
    assert dev.command("reset") == "ok reset"


def test_status(dev: SimTerm) -> None:
    body = dev.command("status")
    assert body.startswith("ok status "), body
    keys = dict(kv.split("=", 1) for kv in body[len("ok status ") :].split())
    documented = ("run", "fs", "mode", "range", "interval", "link", "cfg", "units", "rx")
    assert set(keys) == set(documented), f"status keys differ from docs/protocol.md: {body}"
    assert dev.command("stop").startswith("ok stopped")
    set_rate(dev, 100)
    keys = dict(kv.split("=", 1) for kv in dev.command("status")[len("ok status ") :].split())
    assert keys["run"] == "0" and keys["fs"] == "100" and keys["mode"] == "allan", keys
    assert keys["link"] == "0" and keys["cfg"] == "blank" and keys["units"] == "phys", keys
    assert keys["rx"] == "0:0:0:0", keys  # nothing lost, nothing timed out on a clean link
    assert dev.command("interval 7") == "ok interval=7"
    assert dev.command("start") == "ok started"
    keys = dict(kv.split("=", 1) for kv in dev.command("status")[len("ok status ") :].split())
    assert keys["run"] == "1" and keys["interval"] == "7", keys
    assert dev.command("interval 0") == "ok interval=0"


def test_pasted_lines(dev: SimTerm) -> None:
    """Two lines in one write: one reply each, in order."""
    dev.send(b"stop\rreset\r")
    replies = [dev.reply() for _ in range(2)]
    assert replies[0].startswith("ok stopped") and replies[1] == "ok reset"
    dev.send(b"start\nstop\n")
    replies = [dev.reply() for _ in range(2)]
    assert replies[0] == "ok started" and replies[1].startswith("ok stopped")


def test_pasted_four_lines(dev: SimTerm) -> None:
    """docs/protocol.md: while a reply goes out the device holds one more
    line and 8 more bytes; of four pasted lines the first two are answered,
    later ones may be lost whole (no reply), and nothing else changes."""
    assert dev.command("stop").startswith("ok stopped")
    dev.send(b"reset\rstatus\rstart\rstop\r")
    replies = []
    try:
        while True:
            replies.append(dev.reply(timeout=1.0))
    except Exception:
        pass
    finally:
        dev.resync()
    expect = ["ok reset", "ok status", "ok started", "ok stopped"]
    assert len(replies) >= 2, replies
    # whatever was answered is in order and right for its line; a line that
    # lost bytes says so (error:5), never runs as some other command
    answered = [r for r in replies if not r.startswith("error:5")]
    positions = []
    for r in answered:
        matches = [i for i, e in enumerate(expect) if r.startswith(e)]
        assert matches, replies
        positions.append(matches[0])
    assert positions[:2] == [0, 1] and positions == sorted(positions), replies
    # the device still answers normally
    assert dev.command("status").startswith("ok status")


def test_report(dev: SimTerm) -> None:
    assert dev.command("stop").startswith("ok stopped")
    set_rate(dev, 250)
    n = 6000
    sample(dev, n)
    head, rows, count = dev.report()
    assert head["fs"] == "250" and head["run"] == "0" and int(head["n"]) == n
    assert head["levels"] == str(LEVELS) and head["drops"] == "0"
    assert count == len(rows) == 6 * LEVELS == 90
    assert [(r[0], int(r[1])) for r in rows] == [(c, k) for c in CHANNELS for k in range(LEVELS)]
    for ch, level, pairs, acc, flags in rows:
        m = 1 << int(level)
        assert int(pairs) == max(n // m - 1, 0), (ch, level, pairs, n)
        assert len(acc) == 12 and flags == "00", (ch, level, acc, flags)
    # the synthetic IMU's white noise: adev(tau0) ~ sqrt(sigma^2 + 1/12)
    for (ch, _level, pairs, acc, _flags), sigma in zip(rows[::LEVELS], SYNTH_SIGMA):
        adev = (int(acc, 16) / (2 * int(pairs))) ** 0.5
        expect = (sigma**2 + 1 / 12) ** 0.5
        assert 0.85 * expect < adev < 1.15 * expect, (ch, adev, expect)


def test_command_during_report(dev: SimTerm) -> None:
    """docs/protocol.md: a command that arrives while a report is being sent
    runs between two of the report's lines; the report goes on after it."""
    assert dev.command("stop").startswith("ok stopped")
    try:
        for gap in (0.0, 0.003):  # inside the header, or further on
            dev.send(b"report\r")
            time.sleep(gap)
            dev.send(b"status\r")
            bodies = [dev.line()]
            while not bodies[-1].startswith(b"E,"):
                bodies.append(dev.line())
            replies = [b for b in bodies if b == b"ok" or b.startswith((b"ok ", b"error"))]
            assert [r.split(b" ")[0] for r in replies] == [b"ok", b"ok"], replies
            rows = [b for b in bodies if b.startswith(b"L,")]
            assert len(rows) == int(bodies[-1].split(b",")[2]) == 90
    finally:
        dev.resync()


def test_reopen(dev: SimTerm) -> None:
    """The device keeps running while no terminal is open."""
    assert dev.command("start") == "ok started"
    dev.close()
    time.sleep(0.3)
    assert dev.proc.poll() is None, dev.errors()
    dev.open()
    assert dev.command("stop").startswith("ok stopped")
    assert dev.command("start") == "ok started"


def test_adc_file_loops_and_skips_protocol_lines(tmp_path: Path) -> None:
    """--adc rows go round; '$' lines (a raw capture's count lines and
    replies) and '#' comments are skipped.  Two alternating rows: at level 0
    each pair differs by the rows' difference, from level 1 on the sums are
    constant, whatever the phase."""
    a = [500, 490, 790, 520, 497, 498, 63]
    b = [507, 487, 790, 530, 497, 498, 64]
    rows = tmp_path / "capture.tsv"
    rows.write_bytes(
        b"# a raw capture\r\n$ok mode=raw*1234\r\n"
        + "\t".join(map(str, a)).encode()
        + b"\r\n"
        + "\t".join(map(str, b)).encode()
        + b"\r\n"
        + b"$C,100*ABCD\r\n"
    )
    d = SimTerm(tmp_path, "--adc", str(rows), "--fast")
    try:
        d.open()
        assert d.line().startswith(b"B,")
        assert d.command("interval 0") == "ok interval=0"
        n = 1001
        sample(d, n)
        head, rows_l, count = d.report()
        assert int(head["n"]) == n and count == 90
        for ch, level, pairs, acc, _flags in rows_l:
            i = CHANNELS.index(ch)
            want = int(pairs) * (a[i] - b[i]) ** 2 if level == "0" else 0
            assert int(acc, 16) == want, (ch, level, pairs, acc)
    finally:
        code = d.stop()
    assert code == 0, d.errors()


def test_raw_capture_replays(tmp_path: Path) -> None:
    """`mode raw` through the terminal: the device sends the very rows of
    --adc (in order, going round), with count lines ($C,<rows>,<drops>);
    the capture, replies and count lines included, replays through imu-sim
    as it is."""
    table = [[100 + 10 * i + c for c in range(7)] for i in range(7)]
    rows = tmp_path / "rows.tsv"
    rows.write_text("".join("\t".join(map(str, r)) + "\n" for r in table))
    d = SimTerm(tmp_path, "--adc", str(rows), "--fast")
    try:
        d.open()
        assert d.line().startswith(b"B,")
        assert d.command("interval 0") == "ok interval=0"
        assert d.command("stop").startswith("ok stopped")
        assert d.command("reset") == "ok reset"
        assert d.command("mode raw") == "ok mode=raw"
        d.send(b"start 300\r")
        capture = b""
        deadline = time.monotonic() + 15
        while b"$C,300," not in capture:
            assert time.monotonic() < deadline, capture[-300:]
            capture += d.ser.read(max(1, d.ser.in_waiting))
        capture += d.ser.read(64)  # the rest of that line
    finally:
        d.stop()
    lines = capture.split(b"\r\n")
    assert b"> start 300" in lines  # the echo, a line of its own
    data = [list(map(int, line.split(b"\t"))) for line in lines if line and not line.startswith((b"$", b"> "))]
    assert len(data) == 300
    start = table.index(data[0])
    assert data == [table[(start + i) % 7] for i in range(300)]
    counts = [line for line in lines if line.startswith(b"$C,")]
    for line in counts:
        m = LINE.match(line + b"\r\n")
        assert m and int(m.group(2), 16) == crc16(m.group(1)), line
    # $C,<rows>,<drops>
    assert [c[3:].split(b"*")[0].split(b",")[:2] for c in counts] == [[b"100", b"0"], [b"200", b"0"], [b"300", b"0"]], (
        counts
    )
    assert b"$ok started*" in capture
    cap = tmp_path / "capture.tsv"
    cap.write_bytes(capture)
    proc = subprocess.run([str(SIM), "--adc", str(cap), str(ELF)], capture_output=True, timeout=60)
    assert proc.returncode == 0, proc.stderr.decode()
    heads = [line for line in proc.stdout.split(b"\r\n") if line.startswith(b"$H,")]
    assert heads and b",n=300," in heads[-1], heads


def test_realtime_pacing(tmp_path: Path) -> None:
    """Default pacing: simulated seconds are wall seconds (100 Hz here)."""
    d = SimTerm(tmp_path, "--synthetic")
    try:
        d.open()
        assert d.line().startswith(b"B,")
        set_rate(d, 100)
        assert d.command("reset") == "ok reset"
        t0 = time.monotonic()
        n0 = int(d.command("stop").split("=")[1])
        assert d.command("start") == "ok started"
        time.sleep(1.0)
        n1 = int(d.command("stop").split("=")[1])
        wall = time.monotonic() - t0
        assert 0.6 * 100 * wall < n1 - n0 < 1.2 * 100 * wall, (n0, n1, wall)
    finally:
        d.stop(signal.SIGINT)


def test_realtime_reply_latency(tmp_path: Path) -> None:
    """A stopped device sleeps; simulated time must not run ahead of the
    wall clock meanwhile, or typed commands would wait for it."""
    d = SimTerm(tmp_path, "--synthetic")
    try:
        d.open()
        assert d.line().startswith(b"B,")
        assert d.command("stop").startswith("ok stopped")
        for _ in range(3):
            time.sleep(0.3)
            t0 = time.monotonic()
            assert d.command("rate 100") in ("ok rate=100", "ok reset rate=100")
            assert time.monotonic() - t0 < 0.15
    finally:
        d.stop()


def test_signal_ends_and_removes_link(tmp_path: Path) -> None:
    d = SimTerm(tmp_path, "--synthetic", "--fast", "--no-wait")
    time.sleep(0.2)
    assert d.proc.poll() is None, d.errors()
    code = d.stop(signal.SIGTERM)
    assert code == 0, d.errors()
    assert not d.link.is_symlink() and not d.link.exists()
    assert "stopped at t=" in d.errors()


def test_replays_raw_capture_in_batch_mode(tmp_path: Path) -> None:
    """Without --pty too: a capture of 'mode raw' output replays as is."""
    lines = []
    for i in range(250):
        lines.append(f"{496 + i % 5}\t492\t790\t519\t498\t498\t63\r\n")
        if i % 100 == 99:
            lines.append(f"$C,{i + 1}*0000\r\n")
    lines.insert(0, "$ok mode=raw*0000\r\n")
    rows = tmp_path / "raw.tsv"
    rows.write_text("".join(lines), newline="")
    proc = subprocess.run([str(SIM), "--adc", str(rows), str(ELF)], capture_output=True, timeout=60)
    assert proc.returncode == 0, proc.stderr.decode()
    heads = [line for line in proc.stdout.split(b"\r\n") if line.startswith(b"$H,")]
    assert heads and b",n=250," in heads[-1], heads
